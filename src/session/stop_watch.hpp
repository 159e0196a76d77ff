// The session's stop: while a procedure runs, a flag a front end sets (Ctrl-C in Python, a
// line callback that raised) stops the robot at once through Hub::interrupt(); every later
// wait of that hub fails with "interrupted", so the procedure ends at its next step, with what
// was recorded kept.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "scaratwin/hub/hub.hpp"

namespace scaratwin::session {

class StopWatch {
 public:
  // Watches `stop` (null: nothing to watch) for `hub` until destroyed.
  StopWatch(const std::atomic<bool>* stop, Hub& hub) : stop_(stop), hub_(hub) {
    if (stop_ == nullptr) return;
    thread_ = std::thread([this] {
      std::unique_lock<std::mutex> lock(mu_);
      while (!done_) {
        if (stop_->load()) {
          hub_.interrupt();
          return;
        }
        cv_.wait_for(lock, std::chrono::milliseconds(50));
      }
    });
  }
  ~StopWatch() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  StopWatch(const StopWatch&) = delete;
  StopWatch& operator=(const StopWatch&) = delete;

 private:
  const std::atomic<bool>* stop_;
  Hub& hub_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

}  // namespace scaratwin::session
