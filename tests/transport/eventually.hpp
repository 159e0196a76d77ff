// Test helper: counters are updated by the io thread when a write completes, which can be
// just after the peer already read the bytes; poll briefly instead of racing it.
#pragma once

#include <chrono>
#include <thread>

namespace scaratwin::transport {

template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout = std::chrono::milliseconds(2000)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace scaratwin::transport
