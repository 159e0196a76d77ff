// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see pty_link.hpp)
#include "pty_link.hpp"

#include <fcntl.h>
#include <sys/inotify.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace scaratwin::robot {

Result<PtyLink> PtyLink::open(bool watch_hosts) {
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
  if (watch_hosts) {
    // added after the keeper's open: only hosts are counted
    link.inotify_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (link.inotify_ < 0 ||
        inotify_add_watch(link.inotify_, name, IN_OPEN | IN_CLOSE_WRITE | IN_CLOSE_NOWRITE) < 0) {
      return Error{EmulatorError::kPty,
                   "cannot watch " + link.slave_path_ +
                       " for a host opening it (inotify): " + std::strerror(errno)};
    }
  }
  return link;
}

PtyLink::PtyLink(PtyLink&& other) noexcept
    : master_(other.master_),
      keeper_(other.keeper_),
      inotify_(other.inotify_),
      hosts_(other.hosts_),
      slave_path_(std::move(other.slave_path_)),
      out_(std::move(other.out_)),
      dropped_(other.dropped_) {
  other.master_ = -1;
  other.keeper_ = -1;
  other.inotify_ = -1;
}

PtyLink::~PtyLink() {
  if (inotify_ >= 0) ::close(inotify_);
  if (keeper_ >= 0) ::close(keeper_);
  if (master_ >= 0) ::close(master_);
}

int PtyLink::take_first_opens() {
  if (inotify_ < 0) return 0;
  int first = 0;
  alignas(inotify_event) char buf[4096];
  for (;;) {
    const ssize_t n = ::read(inotify_, buf, sizeof buf);
    if (n <= 0) break;
    for (ssize_t off = 0; off < n;) {
      const auto* ev = reinterpret_cast<const inotify_event*>(buf + off);
      if (ev->mask & IN_OPEN) {
        if (hosts_ == 0) ++first;
        ++hosts_;
      }
      if ((ev->mask & (IN_CLOSE_WRITE | IN_CLOSE_NOWRITE)) && hosts_ > 0) {
        --hosts_;
        // the last host is gone: a real port's buffers go with it
        if (hosts_ == 0) tcflush(keeper_, TCIFLUSH);
      }
      off += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
    }
  }
  return first;
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
