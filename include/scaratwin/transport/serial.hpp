// Serial link: the physical link between the hub and the robot's Arduino ("ID=v1=v2=...=\n"
// lines at 115200 baud by default). Works on real USB serial devices (/dev/ttyACM*,
// /dev/ttyUSB*, /dev/serial/by-id/...) and on pseudo-terminals (the firmware emulator and the
// tests). The port is put in raw mode, 8N1, no hardware or software flow control, opened
// exclusively (TIOCEXCL) and its stale input flushed. When the device fails or disappears
// (unplugged, emulator stopped) the link closes it and reopens the same path every
// reconnect_min..reconnect_max until it is back.
//
// A device that is already talking when the port opens (the emulator, a board without the
// auto-reset) can deliver a cut first line: the decoder reports it and resyncs at the newline.
// Real boards reset when the port opens (1.5-2 s in the bootloader); wait for the firmware's
// hello after every kConnected state change before sending commands.
#pragma once

#include <memory>
#include <string>

#include "scaratwin/transport/link.hpp"

namespace scaratwin::transport {

inline constexpr unsigned kDefaultBaud = 115200;

// Link options for the serial framing: lines up to 96 bytes, no binary payloads.
LinkOptions serial_link_defaults();

struct SerialOptions {
  std::string device;            // e.g. /dev/ttyACM0 or the slave side of a pty
  unsigned baud = kDefaultBaud;  // one of 9600, 19200, 38400, 57600, 115200, 230400, 460800,
                                 // 500000, 576000, 921600, 1000000, 2000000
  bool exclusive = true;         // TIOCEXCL: no other process may open the port meanwhile
  LinkOptions link = serial_link_defaults();
};

class SerialLink : public Link {
 public:
  // Starts opening the device at once (in the background; see wait_connected()). Fails only
  // on options that cannot work (empty path, unsupported baud rate).
  static Result<std::unique_ptr<SerialLink>> create(SerialOptions options,
                                                    std::shared_ptr<IoThread> io = nullptr);

 private:
  using Link::Link;
};

}  // namespace scaratwin::transport
