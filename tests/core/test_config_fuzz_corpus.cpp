// Replays the robot description loader's saved libFuzzer corpus (fuzz/corpus/robot_config/)
// through the fuzzer's invariant checks (fuzz/robot_config_fuzz_checks.hpp), so that CI
// exercises them without clang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "robot_config_fuzz_checks.hpp"

namespace scaratwin {
namespace {

TEST(RobotConfigFuzzCorpus, EveryFileKeepsTheLoadersInvariants) {
  const std::filesystem::path dir =
      std::filesystem::path(SCARATWIN_FUZZ_CORPUS_DIR) / "robot_config";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    EXPECT_EQ(fuzz::check_robot_config(reinterpret_cast<const std::uint8_t*>(bytes.data()),
                                       bytes.size()),
              "")
        << entry.path().filename();
    ++files;
  }
  EXPECT_GT(files, 0) << dir;
}

}  // namespace
}  // namespace scaratwin
