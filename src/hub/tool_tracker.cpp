#include "scaratwin/hub/tool_tracker.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "scaratwin/sim/mjcf.hpp"

namespace scaratwin {
namespace {

std::uint64_t mono_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000ULL;
}

// the cubic terms of a point, centred on the workspace and scaled to about unit size
std::array<double, 10> terms(const std::array<double, 2>& p) {
  const double x = (p[0] - 0.15) * 10.0, y = p[1] * 10.0;
  return {1.0, x, y, x * x, x * y, y * y, x * x * x, x * x * y, x * y * y, y * y * y};
}

}  // namespace

// --- NetCamera ---------------------------------------------------------------------------------

NetCamera::~NetCamera() {
  if (fd_ >= 0) ::close(fd_);
}

Result<std::unique_ptr<NetCamera>> NetCamera::connect(const std::string& host, std::uint16_t port) {
  std::unique_ptr<NetCamera> c(new NetCamera());
  c->fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    return Error{HubError::kCamera, "camera: '" + host + "' is not an IPv4 address"};
  }
  if (c->fd_ < 0 || ::connect(c->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    return Error{HubError::kCamera,
                 fmt::format("camera {}:{}: {}", host, port, std::strerror(errno))};
  }
  int one = 1;
  setsockopt(c->fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return c;
}

Result<CameraFrame> NetCamera::grab(int width_px, int height_px) {
  const std::string req = fmt::format("grab {} {}\n", width_px, height_px);
  if (::send(fd_, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) {
    return Error{HubError::kCamera, "camera: the connection is gone"};
  }
  // header line, then the pixels and a newline
  auto fill = [&](std::size_t want) -> bool {
    char chunk[65536];
    while (buf_.size() < want) {
      pollfd p{fd_, POLLIN, 0};
      // a big picture rendered by a busy machine's emulator can take seconds
      if (::poll(&p, 1, 10000) != 1) return false;
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) return false;
      buf_.append(chunk, static_cast<std::size_t>(n));
    }
    return true;
  };
  std::size_t nl;
  while ((nl = buf_.find('\n')) == std::string::npos) {
    if (!fill(buf_.size() + 1))
      return Error{HubError::kCamera, "camera: no reply to grab within 10 s"};
  }
  const std::string header = buf_.substr(0, nl);
  buf_.erase(0, nl + 1);
  if (header.rfind("ERR", 0) == 0) return Error{HubError::kCamera, "camera: " + header};
  std::istringstream in(header);
  std::string word;
  CameraFrame f;
  std::size_t bytes = 0;
  in >> word >> f.number >> f.device_us >> f.image.width >> f.image.height >> bytes;
  if (word != "FRAME" || !in ||
      bytes != static_cast<std::size_t>(f.image.width) * f.image.height * 3) {
    return Error{HubError::kCamera, "camera: bad frame header '" + header + "'"};
  }
  if (!fill(bytes + 1)) return Error{HubError::kCamera, "camera: frame cut short"};
  f.image.rgb.assign(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(bytes));
  buf_.erase(0, bytes + 1);
  return f;
}

// --- PlaneCorrection ----------------------------------------------------------------------------

void PlaneCorrection::add(const std::array<double, 2>& guess, const std::array<double, 2>& truth) {
  guess_.push_back(guess);
  truth_.push_back(truth);
}

Status PlaneCorrection::fit() {
  const std::size_t n = guess_.size();
  if (n < 20) {
    return Error{HubError::kTracker,
                 fmt::format("tracker: {} learning samples, at least 20 needed", n)};
  }
  // how the samples spread: the cubic terms are observable only over an area; along a
  // single path (one arc, out and back) only an offset and a linear map are
  double mean[2] = {0.0, 0.0};
  for (const auto& t : truth_) {
    mean[0] += t[0] / static_cast<double>(n);
    mean[1] += t[1] / static_cast<double>(n);
  }
  double cxx = 0.0, cxy = 0.0, cyy = 0.0;
  for (const auto& t : truth_) {
    const double dx = t[0] - mean[0], dy = t[1] - mean[1];
    cxx += dx * dx / static_cast<double>(n);
    cxy += dx * dy / static_cast<double>(n);
    cyy += dy * dy / static_cast<double>(n);
  }
  const double tr = cxx + cyy, det = cxx * cyy - cxy * cxy;
  const double narrow = 0.5 * tr - std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
  const bool spread = std::sqrt(std::max(0.0, narrow)) >= 0.02;
  const int m = spread ? 10 : 3;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), m);
  Eigen::VectorXd bx(static_cast<Eigen::Index>(n)), by(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto t = terms(guess_[i]);
    for (int j = 0; j < m; ++j) a(static_cast<Eigen::Index>(i), j) = t[j];
    bx(static_cast<Eigen::Index>(i)) = truth_[i][0] - guess_[i][0];
    by(static_cast<Eigen::Index>(i)) = truth_[i][1] - guess_[i][1];
  }
  const auto qr = a.colPivHouseholderQr();
  const Eigen::VectorXd sx = qr.solve(bx), sy = qr.solve(by);
  cx_ = {};
  cy_ = {};
  for (int j = 0; j < m; ++j) {
    cx_[j] = sx(j);
    cy_[j] = sy(j);
  }
  fitted_ = true;
  return Ok{};
}

std::array<double, 2> PlaneCorrection::apply(const std::array<double, 2>& guess) const {
  const auto t = terms(guess);
  double dx = 0.0, dy = 0.0;
  for (int j = 0; j < 10; ++j) {
    dx += cx_[j] * t[j];
    dy += cy_[j] * t[j];
  }
  return {guess[0] + dx, guess[1] + dy};
}

// --- ToolTracker --------------------------------------------------------------------------------

Result<std::unique_ptr<ToolTracker>> ToolTracker::start(Hub& hub, const TrackerOptions& o) {
  if (!(o.fps > 0.0 && o.fps <= 100.0) || o.persist < 1 || !(o.threshold_m > 0.0)) {
    return Error{HubError::kBadOption,
                 "tracker: fps must be in (0, 100], persist >= 1, threshold > 0"};
  }
  auto cam = NetCamera::connect(o.host, o.port);
  if (!cam) return cam.error();
  std::unique_ptr<ToolTracker> t(new ToolTracker(hub, o));
  t->camera_ = std::move(cam).value();
  t->reports_thread_ = std::thread([p = t.get()] { p->watch_reports(); });
  t->camera_thread_ = std::thread([p = t.get()] { p->track(); });
  return t;
}

ToolTracker::~ToolTracker() {
  stop_ = true;
  if (reports_thread_.joinable()) reports_thread_.join();
  if (camera_thread_.joinable()) camera_thread_.join();
}

void ToolTracker::set_learning(bool on) { learning_ = on; }

Status ToolTracker::fit() {
  std::lock_guard lock(mu_);
  streak_ = 0;
  return correction_.fit();
}

std::optional<std::uint64_t> ToolTracker::first_alarm_mono_us() const {
  std::lock_guard lock(mu_);
  return first_alarm_us_;
}

std::vector<ToolTracker::Sample> ToolTracker::samples() const {
  std::lock_guard lock(mu_);
  return samples_;
}

void ToolTracker::watch_reports() {
  // every state report (100 Hz or more), kept for two seconds, by the robot's clock
  std::uint32_t last = 0;
  bool any = false;
  while (!stop_) {
    const PhysicalState ps = hub_.physical();
    if (ps.valid && (!any || ps.raw.t_us != last)) {
      any = true;
      last = ps.raw.t_us;
      std::lock_guard lock(mu_);
      reports_.emplace_back(ps.raw.t_us, ps.q);
      while (reports_.size() > 400) reports_.pop_front();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

std::optional<JointVector> ToolTracker::joints_at(std::uint64_t device_us) const {
  // the reports' clock is the firmware's micros(), 32 bits; the camera's is the same clock
  const auto t = static_cast<std::uint32_t>(device_us);
  for (std::size_t i = 1; i < reports_.size(); ++i) {
    const auto& a = reports_[i - 1];
    const auto& b = reports_[i];
    const auto span = static_cast<std::int32_t>(b.first - a.first);
    const auto off = static_cast<std::int32_t>(t - a.first);
    if (span <= 0 || off < 0 || off > span) continue;
    if (span > 50000) return std::nullopt;  // a gap in the reports
    const double w = static_cast<double>(off) / span;
    JointVector q{};
    for (int j = 0; j < kNumJoints; ++j) q[j] = a.second[j] + w * (b.second[j] - a.second[j]);
    return q;
  }
  return std::nullopt;
}

void ToolTracker::track() {
  const RobotModel& model = hub_.model();
  const CameraModel& cam = model.scene.camera;
  const auto period = std::chrono::microseconds(static_cast<long>(1e6 / options_.fps));
  auto next = std::chrono::steady_clock::now();
  while (!stop_) {
    next += period;
    auto frame = camera_->grab(options_.width_px, options_.height_px);
    const std::uint64_t arrived = mono_us();
    if (frame) {
      ++frames_;
      Sample s;
      s.mono_us = arrived;
      s.device_us = frame->device_us;
      double col = 0.0, row = 0.0;
      // the report after the frame may still be on the wire: wait for it
      std::this_thread::sleep_for(std::chrono::milliseconds(12));
      std::optional<JointVector> q;
      {
        std::lock_guard lock(mu_);
        q = joints_at(frame->device_us);
      }
      if (q && detect_marker(frame->image, col, row)) {
        const std::array<double, 3> virt = sim::marker_position(model, *q);
        // the nominal camera's pixel: the picture is a scaled copy of the camera's size
        const double sx = static_cast<double>(cam.width_px) / frame->image.width;
        const double sy = static_cast<double>(cam.height_px) / frame->image.height;
        std::array<double, 3> p{};
        if (unproject_to_plane(cam, col * sx, row * sy, virt[2], p)) {
          std::lock_guard lock(mu_);
          if (learning_) {
            correction_.add({p[0], p[1]}, {virt[0], virt[1]});
          } else if (correction_.fitted()) {
            const auto seen = correction_.apply({p[0], p[1]});
            s.seen = true;
            s.offset_m = std::hypot(seen[0] - virt[0], seen[1] - virt[1]);
            streak_ = s.offset_m > options_.threshold_m ? streak_ + 1 : 0;
            if (streak_ == options_.persist) {
              ++alarms_;
              if (!first_alarm_us_) first_alarm_us_ = arrived;
              hub_.record_event("desync", fmt::format("camera: the tool is {:.1f} mm from the "
                                                      "virtual robot's",
                                                      s.offset_m * 1000.0));
            }
          }
        }
      }
      std::lock_guard lock(mu_);
      samples_.push_back(s);
    }
    std::this_thread::sleep_until(next);
  }
}

}  // namespace scaratwin
