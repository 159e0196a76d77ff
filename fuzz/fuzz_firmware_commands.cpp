// libFuzzer target for the firmware's command handling built for the host: see
// firmware_host/firmware_host.hpp for what runs and the invariants.
#include <cstdio>
#include <cstdlib>

#include "firmware_host/firmware_host.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string violation = scaratwin::fuzz::check_firmware_commands(data, size);
  if (!violation.empty()) {
    std::fprintf(stderr, "invariant violated: %s\n", violation.c_str());
    std::abort();
  }
  return 0;
}
