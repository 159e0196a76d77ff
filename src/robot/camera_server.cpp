// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see camera_server.hpp)
#include "camera_server.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <vector>

#include <fmt/format.h>

namespace scaratwin::robot {

Result<std::unique_ptr<CameraServer>> CameraServer::start(std::uint16_t port,
                                                          const plant::Plant& plant,
                                                          const plant::LensModel& lens) {
  auto channel = SideChannel::listen(port);
  if (!channel) return channel.error();
  // a picture must arrive whole: wait (up to 2 s) for a client slow to read it; only this
  // server's thread waits
  channel->set_blocking_replies(true);
  std::unique_ptr<CameraServer> s(new CameraServer(plant, lens, std::move(channel).value()));
  s->stop_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (s->stop_fd_ < 0) {
    return Error{EmulatorError::kSideChannel, std::string("eventfd: ") + std::strerror(errno)};
  }
  s->thread_ = std::thread([p = s.get()] { p->run(); });
  return s;
}

CameraServer::CameraServer(const plant::Plant& plant, const plant::LensModel& lens,
                           SideChannel channel)
    : plant_(plant), lens_(lens), channel_(std::move(channel)), port_(channel_.port()) {}

CameraServer::~CameraServer() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (stop_fd_ >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(stop_fd_, &one, sizeof one);
  }
  if (thread_.joinable()) thread_.join();
  if (stop_fd_ >= 0) ::close(stop_fd_);
}

void CameraServer::serve(std::uint64_t sim_us) {
  const unsigned wanted = wanted_.load(std::memory_order_acquire);
  if (wanted == 0) return;
  {
    std::lock_guard lock(mu_);
    wanted_.store(0, std::memory_order_relaxed);
    if (wanted & kLend) {
      // from now on the loop changes nothing of the plant's model until it is handed back
      lent_ = true;
      model_lent_.store(true, std::memory_order_release);
    }
    if (wanted & kCapture) {
      capture_error_.clear();
      if (Status st = camera_->capture(plant_); !st) capture_error_ = st.error().message;
      capture_sim_us_ = sim_us;
      captured_ = true;
    }
  }
  cv_.notify_all();
}

std::string CameraServer::make_renderer() {
  std::unique_lock lock(mu_);
  if (camera_) return {};
  wanted_.fetch_or(kLend, std::memory_order_release);
  cv_.wait(lock, [this] { return lent_ || stopping_; });
  if (!lent_) return "the robot is stopping";
  // the renderer reads the plant's model while the loop runs on without changing it
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  auto c = plant::PlantCamera::create(plant_, lens_);
  std::fprintf(stderr, "the camera's renderer made in %lld ms\n",
               static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                          std::chrono::steady_clock::now() - t0)
                                          .count()));
  if (c) {
    camera_ = std::move(c).value();
  } else {
    error = c.error().message;
  }
  lent_ = false;
  model_lent_.store(false, std::memory_order_release);
  lock.unlock();
  cv_.notify_all();
  return error;
}

void CameraServer::take_model_back() {
  if (!model_lent_.load(std::memory_order_acquire)) return;
  std::unique_lock lock(mu_);
  cv_.wait(lock, [this] { return !lent_; });
}

void CameraServer::run() {
  // the firmware's loop is the robot's real time, the webcam's frames are not: under a full
  // machine, the loop (and the host beside it) get the cores first
  ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kNice);
  serve_clients();
  // the GL context ends on the thread that used it
  std::lock_guard lock(mu_);
  camera_.reset();
}

void CameraServer::serve_clients() {
  for (;;) {
    std::vector<pollfd> fds{{stop_fd_, POLLIN, 0}, {channel_.listen_fd(), POLLIN, 0}};
    for (const int fd : channel_.client_fds()) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0 && errno != EINTR) return;
    if (fds[0].revents != 0) return;
    channel_.poll([this](const std::string& line, int) { return answer(line); });
    if (!camera_ && !first_client_seen_ && !channel_.client_fds().empty()) {
      // the first client: the renderer is made now, while the client sets up, rather than at
      // its first picture, when the robot may be moving (a failure is told at that picture)
      first_client_seen_ = true;
      make_renderer();
    }
  }
}

std::string CameraServer::answer(const std::string& request) {
  std::istringstream in(request);
  std::string verb;
  int w = 0, h = 0;
  in >> verb >> w >> h;
  if (verb != "grab") return "ERR unknown command '" + verb + "': use grab <width> <height>";
  const CameraModel& cam = plant_.built().scene.camera;
  const int max_w = plant::kWebcamScale * cam.width_px, max_h = plant::kWebcamScale * cam.height_px;
  if (w < 16 || h < 16 || w > max_w || h > max_h) {
    return fmt::format("ERR grab needs a size from 16x16 to {}x{}", max_w, max_h);
  }
  if (!camera_) {
    if (std::string error = make_renderer(); !error.empty()) {
      return "ERR the camera cannot render: " + error;
    }
  }
  // the poses, from the emulator's loop between two of its passes
  std::uint64_t sim_us = 0;
  {
    std::unique_lock lock(mu_);
    captured_ = false;
    wanted_.fetch_or(kCapture, std::memory_order_release);
    cv_.wait(lock, [this] { return captured_ || stopping_; });
    if (!captured_) return "ERR the robot is stopping";
    if (!capture_error_.empty()) return "ERR the camera cannot render: " + capture_error_;
    sim_us = capture_sim_us_;
  }
  // the slow part, while the robot runs on
  auto img = camera_->draw(w, h);
  if (!img) return "ERR the camera cannot render: " + img.error().message;
  std::string out = fmt::format("FRAME {} {} {} {} {}\n", camera_->frames(), sim_us, img->width_px,
                                img->height_px, img->rgb.size());
  out.append(reinterpret_cast<const char*>(img->rgb.data()), img->rgb.size());
  return out;
}

}  // namespace scaratwin::robot
