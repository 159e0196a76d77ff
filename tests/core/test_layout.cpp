// The layering of the tree, checked on its sources (docs/architecture.md): the command line's
// folder holds argument parsing and printing only (no file over 300 lines, no sleep_for, no
// reading of another process's output), and no program the project starts is found by reading
// its text (the ready descriptor says where it serves).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kSource = SCARATWIN_SOURCE_DIR;

std::vector<std::string> lines_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  EXPECT_TRUE(in) << "cannot read " << p;
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::vector<fs::path> sources(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".cpp" || ext == ".hpp" || ext == ".h") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Layout, TheCommandLineHoldsParsingAndPrintingOnly) {
  const auto files = sources(kSource / "apps" / "scaratwin");
  ASSERT_GT(files.size(), 10u);
  for (const fs::path& f : files) {
    const auto lines = lines_of(f);
    const std::string name = fs::relative(f, kSource).string();
    EXPECT_LE(lines.size(), 300u) << name << ": a procedure belongs in src/session";
    for (std::size_t n = 0; n < lines.size(); ++n) {
      for (const char* banned : {"sleep_for", "sleep_until", "wait_for_line", "ChildProcess"}) {
        EXPECT_EQ(lines[n].find(banned), std::string::npos)
            << name << ":" << n + 1 << ": " << lines[n];
      }
    }
  }
}

// Our own programs are started through their ready descriptor: no product code waits for a
// line of their text ("pty: ", "listening on", "side channel: ").
TEST(Layout, NoProductCodeReadsTheTextOfOurPrograms) {
  int files = 0;
  for (const char* dir : {"src", "apps", "python/src"}) {
    for (const fs::path& f : sources(kSource / dir)) {
      ++files;
      const auto lines = lines_of(f);
      for (std::size_t n = 0; n < lines.size(); ++n) {
        for (const char* banned :
             {"wait_for_line(\"pty", "wait_for_line(\"listening", "wait_for_line(\"side channel",
              "wait_for_line(\"camera", "wait_for_line(\"http"}) {
          EXPECT_EQ(lines[n].find(banned), std::string::npos)
              << fs::relative(f, kSource).string() << ":" << n + 1 << ": " << lines[n];
        }
      }
    }
  }
  EXPECT_GT(files, 100);
}

}  // namespace
