// LinkMonitor: sequence gaps and latency of the joint frames of the virtual link.
#include "scaratwin/web/link_monitor.hpp"

#include <algorithm>
#include <chrono>

namespace scaratwin::web {

void LinkMonitor::on_joint_frame(std::uint16_t seq, std::uint32_t t_us, const JointVector& q,
                                 std::int64_t applied_us) {
  std::lock_guard lock(mutex_);
  ++status_.frames;
  if (have_seq_) {
    const auto gap = static_cast<std::uint16_t>(seq - last_seq_ - 1U);
    // a repeated or older seq (gap near 65535) is a reordering, not a loss of 65535 frames
    if (gap < 32768U) status_.lost += gap;
  }
  have_seq_ = true;
  last_seq_ = seq;
  // difference modulo 2^32, read as signed: a sample "from the future" (clock skew) is 0
  const auto diff = static_cast<std::int32_t>(static_cast<std::uint32_t>(applied_us) - t_us);
  const double latency_s = std::max(0, diff) * 1e-6;
  status_.has_latency = true;
  status_.latency_last_s = latency_s;
  status_.has_physical = true;
  status_.physical = q;
  physical_us_ = applied_us;
  window_.push_back({applied_us, latency_s});
  trim(applied_us);
}

void LinkMonitor::set_connected(bool connected) {
  std::lock_guard lock(mutex_);
  status_.connected = connected;
  have_seq_ = false;
  if (!connected) status_.twin_mode.clear();  // the hub that said it has left
}

void LinkMonitor::restart_sequence() {
  std::lock_guard lock(mutex_);
  have_seq_ = false;
}

void LinkMonitor::set_twin_mode(std::string mode) {
  std::lock_guard lock(mutex_);
  status_.twin_mode = std::move(mode);
}

void LinkMonitor::trim(std::int64_t now_us) {
  while (!window_.empty() &&
         static_cast<double>(now_us - window_.front().applied_us) > window_us_) {
    window_.pop_front();
  }
}

LinkStatus LinkMonitor::status(std::int64_t now_us) const {
  std::lock_guard lock(mutex_);
  LinkStatus out = status_;
  double sum = 0.0;
  double max = 0.0;
  std::size_t n = 0;
  for (const Sample& s : window_) {
    if (static_cast<double>(now_us - s.applied_us) > window_us_) continue;
    sum += s.latency_s;
    max = std::max(max, s.latency_s);
    ++n;
  }
  out.latency_mean_s = n > 0 ? sum / static_cast<double>(n) : 0.0;
  out.latency_max_s = max;
  out.frame_rate_hz = static_cast<double>(n) / (window_us_ * 1e-6);
  out.physical_age_s = out.has_physical ? static_cast<double>(now_us - physical_us_) * 1e-6 : 0.0;
  return out;
}

LinkStatus LinkMonitor::status() const {
  // the clock of transport::steady_now_us(), which stamps the frames
  const auto now = std::chrono::steady_clock::now().time_since_epoch();
  return status(std::chrono::duration_cast<std::chrono::microseconds>(now).count());
}

}  // namespace scaratwin::web
