#include "admission.hpp"

#include <algorithm>
#include <cstddef>

namespace scaratwin::sim {

bool looks_like_http(std::string_view first_line) {
  static constexpr std::string_view kMethods[] = {"GET ",    "POST ",    "PUT ",     "HEAD ",
                                                  "DELETE ", "OPTIONS ", "CONNECT ", "PATCH ",
                                                  "TRACE ",  "PRI "};
  return std::any_of(std::begin(kMethods), std::end(kMethods),
                     [&](std::string_view m) { return first_line.substr(0, m.size()) == m; });
}

ControllerClaims::ControllerClaims(int robots)
    : served_(static_cast<std::size_t>(std::max(robots, 0)), 0) {}

ControllerClaims::Verdict ControllerClaims::claim(std::optional<int> robot, bool link_held) {
  std::lock_guard lock(mutex_);
  if (robot && (*robot < 0 || *robot >= static_cast<int>(served_.size()))) return Verdict::kInUse;
  const bool any_served = std::any_of(served_.begin(), served_.end(), [](char c) { return c; });
  // the link's client: when the link has none, and what it names is not driven apart
  if (!link_held && !(any_served && (!robot || served_[static_cast<std::size_t>(*robot)]))) {
    session_robot_ = robot;
    return Verdict::kControl;
  }
  // a further controller: of one robot that nobody drives yet
  if (link_held && robot && session_robot_ && *session_robot_ != *robot &&
      !served_[static_cast<std::size_t>(*robot)]) {
    served_[static_cast<std::size_t>(*robot)] = 1;
    return Verdict::kServe;
  }
  return Verdict::kInUse;
}

void ControllerClaims::release(int robot) {
  std::lock_guard lock(mutex_);
  if (robot >= 0 && robot < static_cast<int>(served_.size())) {
    served_[static_cast<std::size_t>(robot)] = 0;
  }
}

std::optional<int> ControllerClaims::session_robot() const {
  std::lock_guard lock(mutex_);
  return session_robot_;
}

bool ControllerClaims::controlled(int robot, bool link_connected) const {
  std::lock_guard lock(mutex_);
  if (robot < 0 || robot >= static_cast<int>(served_.size())) return false;
  if (served_[static_cast<std::size_t>(robot)]) return true;
  return link_connected && (!session_robot_ || *session_robot_ == robot);
}

}  // namespace scaratwin::sim
