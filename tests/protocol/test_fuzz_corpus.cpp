// Replays the saved libFuzzer corpus (fuzz/corpus/<decoder>/) through the same invariant
// checks as the fuzzers, so that CI exercises them without clang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "protocol_fuzz_checks.hpp"

namespace scaratwin::protocol {
namespace {

using CheckFn = std::string (*)(const std::uint8_t*, std::size_t);

void replay(const std::string& decoder, CheckFn check) {
  const std::filesystem::path dir = std::filesystem::path(SCARATWIN_FUZZ_CORPUS_DIR) / decoder;
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    const std::string violation =
        check(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    EXPECT_TRUE(violation.empty()) << entry.path().filename() << ": " << violation;
    ++files;
  }
  EXPECT_GT(files, 0) << dir;
}

TEST(ProtocolFuzzCorpus, CodecCore) { replay("codec_core", &fuzz::check_core); }
TEST(ProtocolFuzzCorpus, SerialToDevice) {
  replay("serial_to_device", &fuzz::check_typed<SerialToDevice>);
}
TEST(ProtocolFuzzCorpus, SerialFromDevice) {
  replay("serial_from_device", &fuzz::check_typed<SerialFromDevice>);
}
TEST(ProtocolFuzzCorpus, TcpToSim) { replay("tcp_to_sim", &fuzz::check_typed<TcpToSim>); }
TEST(ProtocolFuzzCorpus, TcpFromSim) { replay("tcp_from_sim", &fuzz::check_typed<TcpFromSim>); }

}  // namespace
}  // namespace scaratwin::protocol
