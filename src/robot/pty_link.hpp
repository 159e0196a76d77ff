// scaratwin-robot: the emulated USB serial port, a pseudo-terminal. The master side carries
// the firmware's UART0; the slave side (/dev/pts/N, printed at start) is what a host opens as
// if it were /dev/ttyACM0. One slave descriptor stays open here in raw mode, so the line
// discipline never echoes or translates bytes and the master does not see a hang-up when the
// host closes the port. Bytes sent while the host does not read pile up in the terminal's
// buffer (about 4 KiB, then the newest are dropped): a host should flush its input after
// opening the port (tcflush(TCIFLUSH)) and wait for a hello or a state report.
//
// Watching the host (watch_hosts): the slave device is watched with inotify, so every open and
// close of it by a host is seen as it happens, however quickly a close follows an open; the
// emulator resets the MCU when a host opens a port no host had open (a Uno's DTR). When the
// last host closes it, what it left unread is dropped, as a real port's buffers are.
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
  static Result<PtyLink> open(bool watch_hosts);
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
  // Drops what put() buffered (no host to read it).
  void discard() { out_.clear(); }
  std::uint64_t dropped_bytes() const { return dropped_; }

  // The inotify descriptor to poll for hosts opening and closing the port; -1 when not
  // watching.
  int host_events_fd() const { return inotify_; }
  // Reads the opens and closes seen since the last call; how many times a host opened the port
  // while no host had it open (an open and its close both since the last call count too).
  int take_first_opens();
  // Whether a host has the port open (always true when not watching).
  bool host_open() const { return inotify_ < 0 || hosts_ > 0; }

 private:
  PtyLink() = default;
  int master_ = -1;
  int keeper_ = -1;  // slave descriptor held open in raw mode
  int inotify_ = -1;
  int hosts_ = 0;  // host descriptors open on the slave
  std::string slave_path_;
  std::vector<std::uint8_t> out_;
  std::uint64_t dropped_ = 0;
};

}  // namespace scaratwin::robot
