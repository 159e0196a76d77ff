// The firmware's command handling built for the host (fuzz/firmware_host/firmware_host.hpp):
// the replay of its fuzzer's saved corpus (fuzz/corpus/firmware_commands/) through the
// fuzzer's invariant checks, and that the host build behaves as the firmware does on the
// emulated robot (it homes, runs a trajectory, answers each line). Built with the normal
// compiler, the firmware starts from reset once per process: each input runs in a child.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "firmware_host/firmware_host.hpp"

namespace scaratwin {
namespace {

const std::filesystem::path kCorpus =
    std::filesystem::path(SCARATWIN_FUZZ_CORPUS_DIR) / "firmware_commands";

std::vector<std::uint8_t> read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs `fn` on a firmware fresh from reset, in a child process; returns what it returned.
template <typename Fn>
std::string in_child(Fn fn) {
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const std::string r = fn();
    std::size_t at = 0;
    while (at < r.size()) {
      const ssize_t n = ::write(fds[1], r.data() + at, r.size() - at);
      if (n <= 0) break;
      at += static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string out;
  char buf[4096];
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "the child died: " + out;
  return out;
}

TEST(FirmwareFuzzCorpus, EveryFileKeepsTheInvariants) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kCorpus)) {
    const auto bytes = read_file(entry.path());
    EXPECT_EQ(in_child([&] { return fuzz::check_firmware_commands(bytes.data(), bytes.size()); }),
              "")
        << entry.path().filename();
    ++files;
  }
  EXPECT_GT(files, 0) << kCorpus;
}

// The seed that homes and runs a two-point trajectory: on the host the firmware says hello,
// answers each line once and in order, homes (the mechanics close its switches) and runs the
// trajectory to its end, as on the emulated robot (tests/robot).
TEST(FirmwareHost, HomesAndRunsATrajectoryAsOnTheEmulatedRobot) {
  const auto bytes = read_file(kCorpus / "seed_home_trajectory");
  const std::string out =
      in_child([&] { return fuzz::run_firmware(bytes.data(), bytes.size()); });
  EXPECT_EQ(out.rfind("HI=1=scara-uno=", 0), 0u) << out;
  const auto homed = out.find("EV=1=\n");
  const auto begun = out.find("AK=TB=");
  const auto done = out.find("EV=3=2=\n");
  EXPECT_NE(out.find("AK=HM=\n"), std::string::npos) << out;
  ASSERT_NE(homed, std::string::npos) << out;
  ASSERT_NE(begun, std::string::npos) << out;
  ASSERT_NE(done, std::string::npos) << out;
  EXPECT_LT(homed, begun) << out;
  EXPECT_LT(begun, done) << out;
  EXPECT_EQ(out.find("ER="), std::string::npos) << out;
}

}  // namespace
}  // namespace scaratwin
