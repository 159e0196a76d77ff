// The serial rate (CF key 11) through the emulator: the firmware switches once its reply has
// left, and the rate decides what the line carries. The oracle is the byte count per emulated
// second (the reports' own device timestamps): no more than baud / 10 (8N1) can arrive.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "robot_harness.hpp"

namespace scaratwin::test {
namespace {

struct Window {
  std::vector<Report> reports;
  std::size_t bytes = 0;  // report bytes between the first and the last report
  double span_s = 0.0;    // device time between them
};

// Reports over `seconds` of device time (after the first one).
Window collect(Robot& r, double seconds) {
  Window w;
  while (true) {
    auto l = r.line(20.0, true);
    EXPECT_TRUE(l);
    if (!l) return w;
    auto rep = parse_report(*l);
    if (!rep) continue;
    if (!w.reports.empty()) w.bytes += l->size() + 1;
    w.reports.push_back(*rep);
    w.span_s = static_cast<std::uint32_t>(rep->t_us() - w.reports.front().t_us()) / 1e6;
    if (w.span_s >= seconds) return w;
  }
}

int gaps(const Window& w) {
  int g = 0;
  for (std::size_t k = 1; k < w.reports.size(); ++k) {
    g += static_cast<int>((w.reports[k].seq() - w.reports[k - 1].seq() + 65536) % 65536 - 1);
  }
  return g;
}

TEST(RobotBaud, TheRateSwitchesAfterItsReplyAndBoundsWhatTheLineCarries) {
  Robot r;  // unpaced: every time below is the device's
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r.request("CF=11=1000=\n").value_or(""), "ER=11=1=") << "100000 is not a listed rate";
  EXPECT_EQ(r.request("CF=11=\n").value_or(""), "AK=CF=1152=");

  // 1,000,000 baud: 500 reports a second (about 20 kB/s, more than 115200 baud carries), none
  // lost
  ASSERT_EQ(r.request("CF=11=10000=\n").value_or(""), "AK=CF=10000=");
  ASSERT_EQ(r.request("SR=500=\n").value_or(""), "AK=SR=500=");
  const Window fast = collect(r, 1.0);
  EXPECT_EQ(gaps(fast), 0);
  EXPECT_NEAR(static_cast<double>(fast.reports.size() - 1) / fast.span_s, 500.0, 5.0);
  EXPECT_GT(static_cast<double>(fast.bytes) / fast.span_s, 117647.0 / 10.0)
      << "no more than 115200 baud would carry";

  // 9600 baud: at most 960 bytes a second get through, so most of the 200 reports are lost
  // (their numbers used up: the gaps show it)
  ASSERT_EQ(r.request("CF=11=96=\n").value_or(""), "AK=CF=96=");
  const Window slow = collect(r, 2.0);
  const double bytes_per_s = static_cast<double>(slow.bytes) / slow.span_s;
  EXPECT_LE(bytes_per_s, 9615.0 / 10.0 * 1.01) << "more than the wire carries";
  EXPECT_GE(bytes_per_s, 9615.0 / 10.0 * 0.5) << "the line should be busy";
  EXPECT_GT(gaps(slow), 200) << "reports beyond the rate must be lost, and counted";
  // commands are still served at the slow rate
  EXPECT_EQ(r.request("PI=8=\n", 20.0).value_or(""), "AK=PI=8=");
}

}  // namespace
}  // namespace scaratwin::test
