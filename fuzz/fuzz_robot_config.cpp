// libFuzzer target for the robot description loader (TOML): see robot_config_fuzz_checks.hpp for
// the invariants.
#include <cstdio>
#include <cstdlib>

#include "robot_config_fuzz_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string violation = scaratwin::fuzz::check_robot_config(data, size);
  if (!violation.empty()) {
    std::fprintf(stderr, "invariant violated: %s\n", violation.c_str());
    std::abort();
  }
  return 0;
}
