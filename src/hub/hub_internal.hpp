// Helpers shared by the hub's translation units (hub.cpp: connect, runs, mirror;
// hub_physical.cpp: the physical robot; hub_virtual.cpp: the virtual robot). Not part of the
// public interface.
#pragma once

#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include "scaratwin/core/result.hpp"

namespace scaratwin::hub_detail {

inline constexpr int kHubError = error_code(HubError::kFailed);

inline std::chrono::milliseconds ms(double s) {
  return std::chrono::milliseconds(static_cast<long long>(std::llround(s * 1000)));
}

inline Error hub_error(std::string message) { return Error{kHubError, std::move(message)}; }

}  // namespace scaratwin::hub_detail
