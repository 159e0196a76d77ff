// libFuzzer target for the serial to device decoder: see protocol_fuzz_checks.hpp for the
// invariants.
#include <cstdio>
#include <cstdlib>

#include "protocol_fuzz_checks.hpp"

using namespace scaratwin::protocol;        // NOLINT
using namespace scaratwin::protocol::fuzz;  // NOLINT

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string violation = check_typed<SerialToDevice>(data, size);
  if (!violation.empty()) {
    std::fprintf(stderr, "invariant violated: %s\n", violation.c_str());
    std::abort();
  }
  return 0;
}
