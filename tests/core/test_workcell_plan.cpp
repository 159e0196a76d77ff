// Two arms sorting together (trajectory/workcell_plan.hpp): who takes what, worked out by hand
// from the arms' reach; and the plan's timelines against an oracle of their own: the paper's
// closed-form arm (DESIGN.md) looked at every millisecond for the clearance, and the tool over
// each pick when the gripper closes and over each place when it opens.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "arm_oracle.hpp"
#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/trajectory/workcell_plan.hpp"

namespace scaratwin {
namespace {

using test::oracle_distance;
using test::oracle_tool;

// config/two_arms.toml's layout: "left" at the origin, "right" at (400, 200) mm turned 180 deg.
Workcell two_arms() { return test::two_robots(400.0, 200.0, 180.0); }

WorkcellTask task(const char* what, double px, double py, double qx, double qy) {
  return WorkcellTask{what, ToolPose{px / 1000, py / 1000, -0.02, 0.0},
                      ToolPose{qx / 1000, qy / 1000, -0.02, 0.0}};
}

// Checks a plan against the oracle: the clearance every millisecond, each task's grip over its
// pick and release over its place, and each task on the robot it was given to.
void expect_plan_keeps_its_promises(const Workcell& w, const std::vector<WorkcellTask>& tasks,
                                    const WorkcellPlan& plan, double clearance_m) {
  ASSERT_EQ(plan.timeline.size(), 2u);
  double least = INFINITY;
  for (double t = 0.0; t <= plan.makespan_s + 1e-9; t += 0.001) {
    least = std::min(
        least, oracle_distance(w, sample_at(plan.timeline[0], t), sample_at(plan.timeline[1], t)));
  }
  EXPECT_GE(least, clearance_m) << "the arms came " << least * 1e3 << " mm close";
  EXPECT_FALSE(plan.clearance.first.has_value());
  ASSERT_EQ(plan.tasks.size(), tasks.size());
  for (const PlannedTask& pt : plan.tasks) {
    const BasePose& b = w.robots[pt.robot].base;
    ASSERT_EQ(pt.trajectory.events.size(), 2u) << tasks[pt.task].what;
    const auto grip = oracle_tool(b, sample_at(pt.trajectory, pt.trajectory.events[0].t_s));
    const auto release = oracle_tool(b, sample_at(pt.trajectory, pt.trajectory.events[1].t_s));
    const ToolPose& pick = tasks[pt.task].pick_W;
    const ToolPose& place = tasks[pt.task].place_W;
    EXPECT_NEAR(grip[0], pick.x_m, 1e-4) << tasks[pt.task].what;
    EXPECT_NEAR(grip[1], pick.y_m, 1e-4) << tasks[pt.task].what;
    EXPECT_NEAR(grip[2], pick.z_m, 1e-4) << tasks[pt.task].what;
    EXPECT_NEAR(release[0], place.x_m, 1e-4) << tasks[pt.task].what;
    EXPECT_NEAR(release[1], place.y_m, 1e-4) << tasks[pt.task].what;
    // and the robot's timeline holds the task where it was scheduled
    const JointVector on_timeline =
        sample_at(plan.timeline[pt.robot], pt.start_s + pt.trajectory.events[0].t_s);
    const JointVector in_task = sample_at(pt.trajectory, pt.trajectory.events[0].t_s);
    for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR(on_timeline[j], in_task[j], 1e-9);
    EXPECT_EQ(pt.robot, plan.robot_of_task[pt.task]);
  }
}

// Reach from each shoulder ((67, 0) mm for left, (333, 200) mm for right) at most 187 mm:
// A and C only left's (C's pick both's, its place only left's), B only right's, D both's (the
// fewest tasks so far then: right). Without the reach, C would go to right (fewer tasks).
TEST(WorkcellPlan, EachTaskGoesToARobotThatReachesIt) {
  const Workcell w = two_arms();
  const std::vector<WorkcellTask> tasks = {
      task("A", 180, 60, 150, -80), task("C", 200, 100, 130, 60), task("B", 230, 140, 260, 280),
      task("D", 200, 100, 190, 90)};
  auto got = assign_by_reach(w, tasks);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_EQ(*got, (std::vector<int>{0, 0, 1, 1}));
}

TEST(WorkcellPlan, TwoArmsWorkAtOnceAndKeepApart) {
  const Workcell w = two_arms();
  const std::vector<WorkcellTask> tasks = {
      task("A", 180, 60, 150, -80), task("B", 230, 140, 260, 280), task("C", 200, 100, 130, 60),
      task("D", 200, 100, 190, 90)};
  WorkcellPlanOptions o;
  auto plan = plan_workcell_sort(w, tasks, {paper_robot().home, paper_robot().home}, o);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  expect_plan_keeps_its_promises(w, tasks, *plan, o.clearance.clearance_m);
  // A and B at the same time: both start at 0
  EXPECT_EQ(plan->tasks[0].start_s, 0.0);
  EXPECT_EQ(plan->tasks[1].start_s, 0.0);
  double serial = 0.0;
  for (const PlannedTask& pt : plan->tasks) serial += pt.trajectory.duration_s();
  EXPECT_LT(plan->makespan_s, serial);
  // both end at home
  for (int r = 0; r < 2; ++r) {
    const JointVector end = plan->timeline[r].samples.back().q;
    for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR(end[j], paper_robot().home[j], 1e-9);
  }
}

// Both arms into the gap between them at once: the second waits until the first is out.
TEST(WorkcellPlan, AnArmThatWouldMeetTheOtherWaits) {
  const Workcell w = two_arms();
  // picks 14 mm apart in the gap, places each arm's own
  const std::vector<WorkcellTask> tasks = {task("into the gap (left)", 205, 95, 150, -80),
                                           task("into the gap (right)", 195, 105, 260, 280)};
  WorkcellPlanOptions o;
  auto plan = plan_workcell_sort(w, tasks, {paper_robot().home, paper_robot().home}, o);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_EQ(plan->robot_of_task, (std::vector<int>{0, 1}));
  expect_plan_keeps_its_promises(w, tasks, *plan, o.clearance.clearance_m);
  // at once they would meet (the oracle says so), so the right arm starts later
  double least = INFINITY;
  const PlannedTask& a = plan->tasks[0];
  const PlannedTask& b = plan->tasks[1];
  for (double t = 0.0; t <= std::max(a.trajectory.duration_s(), b.trajectory.duration_s());
       t += 0.001) {
    least =
        std::min(least, oracle_distance(w, sample_at(a.trajectory, t), sample_at(b.trajectory, t)));
  }
  EXPECT_LT(least, o.clearance.clearance_m);
  EXPECT_EQ(a.start_s, 0.0);
  EXPECT_GT(b.start_s, 0.0);
}

// The right arm stands in the gap (its start pose) and has nothing to do, so it never leaves:
// the left arm's task there cannot start within the most delay and is refused, naming both.
TEST(WorkcellPlan, AnArmStandingInTheWayIsRefusedAfterTheMostDelay) {
  const Workcell w = two_arms();
  JointVector in_the_gap = paper_robot().home;
  in_the_gap[1] = deg_to_rad(45.0);  // forearm (268, 135) -> (201, 68) mm
  WorkcellPlanOptions o;
  o.max_delay_s = 1.0;
  auto plan = plan_workcell_sort(w, {task("red cube 0", 205, 95, 150, -80)},
                                 {paper_robot().home, in_the_gap}, o);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, static_cast<int>(PlanError::kCollision));
  EXPECT_EQ(plan.error().message.rfind("red cube 0 (robot 'left'): no start within 1.0 s of "
                                       "waiting keeps the arms apart: robots 'left' and 'right' "
                                       "would come closer than the clearance of 20.0 mm at ",
                                       0),
            0u)
      << plan.error().message;
  o.delay_step_s = 0.0;
  auto bad = plan_workcell_sort(w, {}, {paper_robot().home, paper_robot().home}, o);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, static_cast<int>(PlanError::kBadArgument));
}

// config/two_arms_trays.toml's layout (the two-arm demo's): "right" at (310, -230) mm turned
// -150 deg, its shoulder at (252, -263.5) mm.
Workcell two_arms_trays() { return test::two_robots(310.0, -230.0, -150.0); }

// With home_after_each every task ends at its robot's home, so an arm waiting for its next task
// stands at home: the demo's layout (its shoulders' reach worked out by hand: the red and the
// blue cube only left's, the green one only right's) keeps 70 mm everywhere.
TEST(WorkcellPlan, EachTaskEndsAtHomeWhenAsked) {
  const Workcell w = two_arms_trays();
  const std::vector<WorkcellTask> tasks = {task("red cube 0", 91, 149, 130, -136),
                                           task("green cube 0", 146, -233, 182, -96),
                                           task("blue cube 0", 98, 89, 212, -39)};
  WorkcellPlanOptions o;
  o.home_after_each = true;
  o.clearance.clearance_m = 0.070;
  auto plan = plan_workcell_sort(w, tasks, {paper_robot().home, paper_robot().home}, o);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->robot_of_task, (std::vector<int>{0, 1, 0}));
  expect_plan_keeps_its_promises(w, tasks, *plan, o.clearance.clearance_m);
  for (const PlannedTask& pt : plan->tasks) {
    const JointVector end =
        sample_at(plan->timeline[pt.robot], pt.start_s + pt.trajectory.duration_s());
    for (int j = 0; j < kNumJoints; ++j) {
      EXPECT_NEAR(end[j], paper_robot().home[j], 1e-9) << tasks[pt.task].what << " joint " << j;
    }
  }
  // without it, left stands over the red tray after its first task and the green one cannot
  // be started by right (which alone reaches it) within the most delay
  o.home_after_each = false;
  o.max_delay_s = 10.0;
  auto without = plan_workcell_sort(w, tasks, {paper_robot().home, paper_robot().home}, o);
  ASSERT_FALSE(without.ok());
  EXPECT_EQ(without.error().code, static_cast<int>(PlanError::kCollision));
  EXPECT_EQ(
      without.error().message.rfind("green cube 0 (robot 'right'): no start within 10.0 s", 0), 0u)
      << without.error().message;
}

// A task whose robot cannot start it within the most delay goes to the next robot that reaches
// it: right stands over the shared pick (its start, with nothing to do), so left (assigned:
// fewer tasks, nearer base) never gets there; right, which reaches the pick and the red tray,
// takes it. Without the fallback the plan was refused (kCollision).
TEST(WorkcellPlan, ATaskItsRobotCannotStartGoesToAnotherThatReachesIt) {
  const Workcell w = two_arms_trays();
  const WorkcellTask shared = task("red cube 0", 150, -120, 130, -136);
  const auto in_right = world_to_base(w.robots[1].base, {0.150, -0.120, -0.02});
  auto standing = inverse(paper_robot(), ToolPose{in_right[0], in_right[1], in_right[2], 0.0},
                          paper_robot().home);
  ASSERT_TRUE(standing.ok()) << standing.error().message;
  WorkcellPlanOptions o;
  o.max_delay_s = 1.0;
  auto plan = plan_workcell_sort(w, {shared}, {paper_robot().home, *standing}, o);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->robot_of_task, std::vector<int>{1});
  ASSERT_EQ(plan->tasks.size(), 1u);
  EXPECT_EQ(plan->tasks[0].robot, 1);
  expect_plan_keeps_its_promises(w, {shared}, *plan, o.clearance.clearance_m);
  auto assigned = assign_by_reach(w, {shared});
  ASSERT_TRUE(assigned.ok());
  EXPECT_EQ(*assigned, std::vector<int>{0}) << "left was the robot it was assigned";
}

TEST(WorkcellPlan, RefusesWhatNoRobotReachesAndABadStart) {
  const Workcell w = two_arms();
  auto far = plan_workcell_sort(w, {task("blue cube 2", 600, -300, 150, -80)},
                                {paper_robot().home, paper_robot().home});
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.error().code, static_cast<int>(PlanError::kUnreachable));
  EXPECT_EQ(far.error().message,
            "blue cube 2: no robot reaches both its pick at (600.0, -300.0) mm and its place at "
            "(150.0, -80.0) mm (robots: 'left', 'right')");
  auto one = plan_workcell_sort(w, {}, {paper_robot().home});
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(one.error().code, static_cast<int>(PlanError::kBadArgument));
  EXPECT_EQ(one.error().message, "workcell plan: 1 start poses for a workcell of 2 robots");
}

}  // namespace
}  // namespace scaratwin
