// The simulation of a workcell of two robots (config/two_arms.toml): each robot is addressed by
// its index and moves alone, with its own mode and gripper; a cube one robot holds is not the
// other's to take; a robot index the workcell does not have is refused and changes nothing.
// Expected positions are worked out by hand from the two bases and the paper's link lengths:
// the shoulder axis 67 mm ahead of the base axis, then 92 + 95 = 187 mm to the tool (254 mm
// from the base axis with the arm stretched); the tool 67 mm under the carriage's d1.
#include <array>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>
#include <utility>

#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {
namespace {

namespace fs = std::filesystem;

const fs::path kTwoArms = fs::path(SCARATWIN_CONFIG_FILE).parent_path() / "two_arms.toml";
constexpr double kShoulderM = 0.067;            // base axis to shoulder axis
constexpr double kArmM = 0.187;                 // shoulder axis to tool
constexpr double kReachM = kShoulderM + kArmM;  // base axis to tool, arm stretched
constexpr double kToolBelowM = 0.067;           // tool under the carriage's d1

void expect_at(const std::array<double, 3>& got, const std::array<double, 3>& want,
               const char* what) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[i], want[i], 1e-9) << what << " axis " << i;
}

class WorkcellSim : public ::testing::Test {
 protected:
  void SetUp() override {
    auto cell = load_workcell_config(kTwoArms);
    ASSERT_TRUE(cell.ok()) << cell.error().message;
    cell_ = *cell;
    auto s = Simulation::create(cell_);
    ASSERT_TRUE(s.ok()) << s.error().message;
    sim_ = std::move(*s);
  }
  Workcell cell_;
  std::unique_ptr<Simulation> sim_;
};

TEST_F(WorkcellSim, EachRobotIsAtItsBaseAndMovesAlone) {
  ASSERT_EQ(sim_->robot_count(), 2);
  EXPECT_EQ(sim_->robot_name(0), "left");
  EXPECT_EQ(sim_->robot_name(1), "right");
  // both at home (d1 120 mm, stretched along the base's x): left at the origin facing +x,
  // right at (400, 200) mm facing -x
  expect_at(sim_->tool_site_pos(0), {kReachM, 0.0, 0.12 - kToolBelowM}, "left at home");
  expect_at(sim_->tool_site_pos(1), {0.4 - kReachM, 0.2, 0.12 - kToolBelowM}, "right at home");

  // the right robot turns its shoulder by 90 degrees and lowers to 50 mm: its arm swings about
  // its shoulder (67 mm ahead of its base, along -x of W) to point along -y of W (its base
  // faces -x, turned +90 it faces -y); the left one stays
  const JointVector q{0.05, deg_to_rad(90.0), 0.0, 0.0};
  auto w = sim_->set_joints(q, 1);
  ASSERT_TRUE(w.ok()) << w.error().message;
  EXPECT_TRUE(w->empty());
  expect_at(sim_->tool_site_pos(1), {0.4 - kShoulderM, 0.2 - kArmM, 0.05 - kToolBelowM},
            "right turned");
  expect_at(sim_->tool_site_pos(0), {kReachM, 0.0, 0.12 - kToolBelowM}, "left unmoved");
  EXPECT_EQ(sim_->joints(0), cell_.robots[0].model.home);
  EXPECT_EQ(sim_->joints(1), q);
  // and it stays there through physics steps (mirror mode holds it)
  ASSERT_TRUE(sim_->step(50).ok());
  expect_at(sim_->tool_site_pos(1), {0.4 - kShoulderM, 0.2 - kArmM, 0.05 - kToolBelowM},
            "right after steps");
  // each robot's tool path is its own
  const auto path0 = sim_->tool_path(0), path1 = sim_->tool_path(1);
  ASSERT_FALSE(path0.empty());
  ASSERT_FALSE(path1.empty());
  EXPECT_NEAR(path0.back().pos_m[0], kReachM, 1e-9);
  EXPECT_NEAR(path1.back().pos_m[1], 0.2 - kArmM, 1e-9);
}

TEST_F(WorkcellSim, ModesAreEachRobotsOwn) {
  sim_->set_mode(Mode::kSimulate, 1);
  EXPECT_EQ(sim_->mode(0), Mode::kMirror);
  EXPECT_EQ(sim_->mode(1), Mode::kSimulate);
  // joint data are a mirror command: refused for the right robot, applied to the left one
  auto refused = sim_->set_joints({0.1, 0.3, 0.0, 0.0}, 1);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, error_code(SimError::kWrongMode));
  ASSERT_TRUE(sim_->set_joints({0.1, 0.3, 0.0, 0.0}, 0).ok());
  // the right robot follows a trajectory with its servos (1 s to q2 = -30 deg)
  JointTrajectory t;
  const JointVector home = cell_.robots[1].model.home;
  JointVector to = home;
  to[1] = deg_to_rad(-30.0);
  t.samples = {JointSample{0.0, home, {}, {}}, JointSample{1.0, to, {}, {}}};
  ASSERT_TRUE(sim_->follow(t, 1).ok());
  EXPECT_TRUE(sim_->trajectory_active(1));
  EXPECT_FALSE(sim_->trajectory_active(0));
  ASSERT_TRUE(sim_->step_until(1.5).ok());
  EXPECT_FALSE(sim_->trajectory_active(1));
  EXPECT_NEAR(sim_->joints(1)[1], deg_to_rad(-30.0), deg_to_rad(0.5));
  EXPECT_NEAR(sim_->joints(0)[1], 0.3, 1e-12);  // the left one held its mirrored pose
  // a trajectory is a simulate command: refused for the left robot
  auto follow0 = sim_->follow(t, 0);
  ASSERT_FALSE(follow0.ok());
  EXPECT_EQ(follow0.error().code, error_code(SimError::kWrongMode));
}

TEST_F(WorkcellSim, ACubeOneRobotHoldsIsNotTheOthersToTake) {
  // a cube halfway between the bases, 224 mm from each: both tools reach it
  const std::array<double, 3> at{0.2, 0.1, cell_.scene.table_z_m + 0.5 * cell_.scene.cube_size_m};
  auto cube = sim_->spawn_cube(CubeColor::kGreen, at[0], at[1]);
  ASSERT_TRUE(cube.ok()) << cube.error().message;
  ASSERT_TRUE(sim_->step(100).ok());  // it settles on the table
  for (int r : {1, 0}) {
    const std::array<double, 3> p_B = world_to_base(cell_.robots[r].base, at);
    // a tool heading the wrist's limits allow (each robot's j4 turns 0..180 degrees)
    Result<JointVector> q = Error{0, "no heading tried"};
    for (double yaw_deg : {0.0, 90.0, 180.0, -90.0}) {
      q = inverse(sim_->robot(r), ToolPose{p_B[0], p_B[1], p_B[2], deg_to_rad(yaw_deg)},
                  cell_.robots[r].model.home);
      if (q.ok()) break;
    }
    ASSERT_TRUE(q.ok()) << q.error().message;
    ASSERT_TRUE(sim_->set_joints(*q, r).ok());
    for (int i = 0; i < 3; ++i) ASSERT_NEAR(sim_->tool_site_pos(r)[i], at[i], 2e-3) << r;
  }
  EXPECT_EQ(sim_->cube_between_fingers(0), cube->id);
  EXPECT_EQ(sim_->cube_between_fingers(1), cube->id);
  const GraspResult right = sim_->grip(1);
  EXPECT_TRUE(right.holding);
  EXPECT_EQ(right.cube_id, cube->id);
  // the left robot closes on it: it is the right one's
  EXPECT_EQ(sim_->cube_between_fingers(0), -1);
  const GraspResult left = sim_->grip(0);
  EXPECT_FALSE(left.holding);
  EXPECT_TRUE(sim_->gripper_closed(0));
  EXPECT_EQ(sim_->held_cube(0), -1);
  EXPECT_EQ(sim_->held_cube(1), cube->id);
  // the right robot lifts it; the left one's release changes nothing of it
  sim_->release(0);
  auto up = sim_->joints(1);
  up[0] += 0.05;
  ASSERT_TRUE(sim_->set_joints(up, 1).ok());
  ASSERT_TRUE(sim_->step(50).ok());
  auto held = sim_->cube(cube->id);
  ASSERT_TRUE(held.ok());
  EXPECT_TRUE(held->held);
  EXPECT_NEAR(held->pos_m[2], at[2] + 0.05, 2e-3);
  // a reset of the scene lets go of it
  sim_->reset_scene();
  EXPECT_EQ(sim_->held_cube(1), -1);
  EXPECT_FALSE(sim_->gripper_closed(1));
}

TEST_F(WorkcellSim, ALimitWarningNamesItsRobot) {
  // d1 200 mm: above the 120 mm limit, within the plausible band
  auto w = sim_->set_joints({0.2, 0.0, 0.0, 0.0}, 1);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_EQ(w->size(), 1u);
  EXPECT_EQ((*w)[0].robot, 1);
  EXPECT_EQ((*w)[0].joint, 0);
  ASSERT_EQ(sim_->recent_warnings().size(), 1u);
  EXPECT_EQ(sim_->recent_warnings().back().robot, 1);
}

TEST_F(WorkcellSim, ARobotIndexItDoesNotHaveIsRefusedAndNothingMoves) {
  const auto before0 = sim_->joints(0), before1 = sim_->joints(1);
  for (int bad : {2, -1}) {
    auto st = sim_->check_robot(bad);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error().code, 47);
    EXPECT_NE(st.error().message.find("'left', 'right'"), std::string::npos) << st.error().message;
    auto w = sim_->set_joints({0.05, 0.5, 0.5, 0.0}, bad);
    ASSERT_FALSE(w.ok());
    EXPECT_EQ(w.error().code, 47);
    EXPECT_FALSE(sim_->reset_robot(bad).ok());
  }
  EXPECT_EQ(sim_->joints(0), before0);
  EXPECT_EQ(sim_->joints(1), before1);
}

// The paper's single robot is the workcell of one robot: the same model, index 0 only.
// issue 13: the simulator's contacts between arms. The oracle is the planner's arm distance
// seen from above (kinematics/workcell.hpp, from the link lengths, not from the MJCF): where it
// is 0 the arms cross at the same height and MuJoCo must report a touch; where it is more than
// both links' radii (18 mm each) and a margin, it must not. A touch counts once however long
// it lasts; an arm folded onto its own column, or down at the table, is no touch.
TEST_F(WorkcellSim, ArmsThatCrossTouchOnceAndOnlyThen) {
  const JointVector home = sim_->robot(0).home;
  // both shoulders turned: the left by a, the right by b (5 degree steps within the limits)
  using Pair = std::pair<JointVector, JointVector>;
  std::optional<Pair> cross, apart;
  for (int a = -90; a <= 90; a += 5) {
    for (int b = -90; b <= 90; b += 5) {
      JointVector qa = home, qb = sim_->robot(1).home;
      qa[1] = deg_to_rad(a);
      qb[1] = deg_to_rad(b);
      if (!sim_->robot(0).limits[1].contains(qa[1]) || !sim_->robot(1).limits[1].contains(qb[1])) {
        continue;
      }
      const double d = arm_distance(cell_, 0, qa, 1, qb);
      if (d == 0.0 && !cross) cross = Pair{qa, qb};
      if (d > 0.06 && d < 0.08 && !apart) apart = Pair{qa, qb};
    }
  }
  ASSERT_TRUE(cross && apart) << "two_arms.toml: no crossing or no near pose of the arms";

  auto settle = [&](const Pair& q) {
    ASSERT_TRUE(sim_->set_joints(q.first, 0).ok());
    ASSERT_TRUE(sim_->set_joints(q.second, 1).ok());
    ASSERT_TRUE(sim_->step(20).ok());
  };
  const Pair homes{home, sim_->robot(1).home};
  settle(homes);
  EXPECT_EQ(sim_->arm_contacts().count, 0) << "both at home";
  EXPECT_EQ(sim_->arm_contacts().robot_a, -1);
  settle(*apart);
  EXPECT_EQ(sim_->arm_contacts().count, 0)
      << "60..80 mm apart seen from above: q2 " << rad_to_deg(apart->first[1]) << " and "
      << rad_to_deg(apart->second[1]);
  const double before_s = sim_->time_s();
  settle(*cross);
  Simulation::ArmContacts c = sim_->arm_contacts();
  EXPECT_EQ(c.count, 1) << "crossing: q2 " << rad_to_deg(cross->first[1]) << " and "
                        << rad_to_deg(cross->second[1]);
  EXPECT_EQ(c.robot_a, 0);
  EXPECT_EQ(c.robot_b, 1);
  EXPECT_GT(c.t_s, before_s);
  ASSERT_TRUE(sim_->step(200).ok());
  EXPECT_EQ(sim_->arm_contacts().count, 1) << "one touch however long it lasts";
  settle(homes);
  settle(*cross);
  EXPECT_EQ(sim_->arm_contacts().count, 2) << "apart, then crossing again: a second touch";

  // an arm against itself, its column or the table is no touch between arms
  settle(homes);
  JointVector folded = home;
  folded[0] = sim_->robot(0).limits[0].min;
  folded[2] = sim_->robot(0).limits[2].max;
  settle(Pair{folded, sim_->robot(1).home});
  EXPECT_EQ(sim_->arm_contacts().count, 2);
}

TEST(WorkcellSimSingle, OneRobotIsTheRobotsOwnSimulation) {
  auto robot = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(robot.ok());
  auto alone = Simulation::create(*robot);
  auto cell = Simulation::create(single_robot_workcell(*robot));
  ASSERT_TRUE(alone.ok() && cell.ok());
  EXPECT_EQ((*alone)->mjcf(), (*cell)->mjcf());
  EXPECT_EQ((*alone)->robot_count(), 1);
  EXPECT_EQ((*alone)->robot_name(), "robot");
  EXPECT_EQ((*alone)->check_robot(1).error().code, 47);
}

}  // namespace
}  // namespace scaratwin::sim
