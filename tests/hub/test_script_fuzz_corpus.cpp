// Replays the script parser's saved libFuzzer corpus (fuzz/corpus/script/) through the
// fuzzer's invariant checks (fuzz/script_fuzz_checks.hpp), so that CI exercises them without
// clang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "script_fuzz_checks.hpp"

namespace scaratwin {
namespace {

TEST(ScriptFuzzCorpus, EveryFileKeepsTheParsersInvariants) {
  const std::filesystem::path dir = std::filesystem::path(SCARATWIN_FUZZ_CORPUS_DIR) / "script";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    EXPECT_EQ(fuzz::check_script(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()),
              "")
        << entry.path().filename();
    ++files;
  }
  EXPECT_GT(files, 0) << dir;
}

}  // namespace
}  // namespace scaratwin
