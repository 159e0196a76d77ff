// scaratwin-robot: the emulated USB serial port, a pseudo-terminal. The master side carries
// the firmware's UART0; the slave side (/dev/pts/N, printed at start) is what a host opens as
// if it were /dev/ttyACM0. One slave descriptor stays open here in raw mode, so the line
// discipline never echoes or translates bytes and the master does not see a hang-up when the
// host closes the port. As on a real port, bytes sent while no host reads pile up in the
// terminal's buffer (about 4 KiB, then the newest are dropped): a host should flush its input
// after opening the port (tcflush(TCIFLUSH)) and wait for a hello or a state report.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator (GPL-3.0-or-later because it links libsimavr).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"

namespace scaratwin::robot {

class PtyLink {
 public:
  static Result<PtyLink> open();
  PtyLink(PtyLink&& other) noexcept;
  PtyLink& operator=(PtyLink&&) = delete;
  PtyLink(const PtyLink&) = delete;
  ~PtyLink();

  const std::string& slave_path() const { return slave_path_; }
  int master_fd() const { return master_; }
  // Reads what the host wrote (non-blocking); empty when nothing is waiting.
  std::vector<std::uint8_t> read_available();
  // Buffers a byte for the host; flush() writes the buffer (dropping what does not fit).
  void put(std::uint8_t byte) { out_.push_back(byte); }
  void flush();
  std::uint64_t dropped_bytes() const { return dropped_; }

 private:
  PtyLink() = default;
  int master_ = -1;
  int keeper_ = -1;  // slave descriptor held open in raw mode
  std::string slave_path_;
  std::vector<std::uint8_t> out_;
  std::uint64_t dropped_ = 0;
};

}  // namespace scaratwin::robot
