// The companion dialect fuzzer's saved corpus (fuzz/corpus/companion/), replayed through the
// fuzzer's own checks (fuzz/companion_fuzz_checks.hpp) so that a crasher, once fixed, stays
// fixed without clang; and the checks themselves, shown to catch what they guard.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "companion_fuzz_checks.hpp"

namespace scaratwin {
namespace {

std::string check(std::string_view bytes) {
  return fuzz::check_companion(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(),
                               paper_robot());
}

TEST(CompanionFuzzCorpus, EveryFileKeepsTheDialectsInvariants) {
  const std::filesystem::path dir = std::filesystem::path(SCARATWIN_FUZZ_CORPUS_DIR) / "companion";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(check(bytes), "") << entry.path().filename();
    ++files;
  }
  EXPECT_GE(files, 19) << dir;
}

// The oracle is the docs' grammar, so a number with two signs is refused by both.
TEST(CompanionFuzzCorpus, TheOracleAndTheDecoderAgreeOnSigns) {
  const std::string frame = "ModRobot:0.1,+-5,0,0";
  EXPECT_EQ(check(std::string(1, static_cast<char>(frame.size())) + frame), "");
  EXPECT_FALSE(sim::parse_companion(frame, paper_robot()));
}

}  // namespace
}  // namespace scaratwin
