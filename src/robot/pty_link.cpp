// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see pty_link.hpp)
#include "pty_link.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace scaratwin::robot {

Result<PtyLink> PtyLink::open() {
  PtyLink link;
  link.master_ = posix_openpt(O_RDWR | O_NOCTTY);
  if (link.master_ < 0)
    return Error{EmulatorError::kPty, std::string("posix_openpt: ") + std::strerror(errno)};
  if (grantpt(link.master_) != 0 || unlockpt(link.master_) != 0) {
    return Error{EmulatorError::kPty, std::string("grantpt/unlockpt: ") + std::strerror(errno)};
  }
  const char* name = ptsname(link.master_);
  if (name == nullptr)
    return Error{EmulatorError::kPty, std::string("ptsname: ") + std::strerror(errno)};
  link.slave_path_ = name;
  link.keeper_ = ::open(name, O_RDWR | O_NOCTTY);
  if (link.keeper_ < 0) {
    return Error{EmulatorError::kPty,
                 "cannot open " + link.slave_path_ + ": " + std::strerror(errno)};
  }
  termios tio{};
  tcgetattr(link.keeper_, &tio);
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  tcsetattr(link.keeper_, TCSANOW, &tio);
  termios mtio{};
  tcgetattr(link.master_, &mtio);
  cfmakeraw(&mtio);
  tcsetattr(link.master_, TCSANOW, &mtio);
  fcntl(link.master_, F_SETFL, fcntl(link.master_, F_GETFL) | O_NONBLOCK);
  return link;
}

PtyLink::PtyLink(PtyLink&& other) noexcept
    : master_(other.master_),
      keeper_(other.keeper_),
      slave_path_(std::move(other.slave_path_)),
      out_(std::move(other.out_)),
      dropped_(other.dropped_) {
  other.master_ = -1;
  other.keeper_ = -1;
}

PtyLink::~PtyLink() {
  if (keeper_ >= 0) ::close(keeper_);
  if (master_ >= 0) ::close(master_);
}

std::vector<std::uint8_t> PtyLink::read_available() {
  std::vector<std::uint8_t> data;
  std::uint8_t buf[512];
  for (;;) {
    const ssize_t n = ::read(master_, buf, sizeof buf);
    if (n <= 0) break;
    data.insert(data.end(), buf, buf + n);
  }
  return data;
}

void PtyLink::flush() {
  std::size_t off = 0;
  while (off < out_.size()) {
    const ssize_t n = ::write(master_, out_.data() + off, out_.size() - off);
    if (n <= 0) break;
    off += static_cast<std::size_t>(n);
  }
  dropped_ += out_.size() - off;
  out_.clear();
}

}  // namespace scaratwin::robot
