// Soak test (ctest label `soak`, run alone): state reports at the default 100 Hz for 60 s of
// real time, paced to the wall clock, through the pty: no sequence gap and the rate right in
// the device's time. The rate in the host's wall-clock time depends on how loaded the machine
// is: it is printed, not judged (bench_robot measures the link's speed).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "robot_harness.hpp"

namespace scaratwin::test {
namespace {

TEST(RobotSoak, ReportsAtOneHundredHertzWithoutAGapForSixtySeconds) {
  Robot robot({"--speed", "1"});
  ASSERT_TRUE(robot.ok()) << robot.error();
  ASSERT_EQ(robot.request("SR=100=\n").value_or(""), "AK=SR=100=");
  const auto start = std::chrono::steady_clock::now();
  std::vector<Report> reps;
  int gaps = 0;
  while (std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
    auto l = robot.line(5.0, true);
    ASSERT_TRUE(l) << "reports stopped";
    auto r = parse_report(*l);
    if (!r) continue;
    if (!reps.empty() && (r->seq() - reps.back().seq() + 65536) % 65536 != 1) ++gaps;
    reps.push_back(*r);
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(gaps, 0);
  ASSERT_GT(reps.size(), 100u);
  const double dev_s = static_cast<std::uint32_t>(reps.back().t_us() - reps.front().t_us()) / 1e6;
  EXPECT_NEAR(static_cast<double>(reps.size() - 1) / dev_s, 100.0, 0.5) << "device time";
  std::printf("%zu reports in %.2f s of device time, %.2f s of wall-clock time (%.1f Hz)\n",
              reps.size(), dev_s, wall_s, static_cast<double>(reps.size()) / wall_s);
}

}  // namespace
}  // namespace scaratwin::test
