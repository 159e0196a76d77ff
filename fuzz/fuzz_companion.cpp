// libFuzzer target for the paper's companion TCP dialect (framing and decoding, as the
// simulator's companion server reads a client's bytes): see companion_fuzz_checks.hpp for the
// invariants.
#include <cstdio>
#include <cstdlib>

#include "companion_fuzz_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const scaratwin::RobotModel robot = scaratwin::paper_robot();
  const std::string violation = scaratwin::fuzz::check_companion(data, size, robot);
  if (!violation.empty()) {
    std::fprintf(stderr, "invariant violated: %s\n", violation.c_str());
    std::abort();
  }
  return 0;
}
