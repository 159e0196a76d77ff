// Forward and inverse kinematics with an installed scaratwin (scaratwin::kinematics and
// scaratwin::config): loads the installed robot description, takes the tool pose of a joint
// vector, solves it back with IK and checks the round trip.
//
//   fk_ik [DESCRIPTION.toml]
#include <cmath>
#include <cstdio>
#include <numbers>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/kinematics.hpp"

int main(int argc, char** argv) {
  using namespace scaratwin;
  const char* path = argc > 1 ? argv[1] : SCARATWIN_DESCRIPTION;
  const Result<RobotModel> model = load_robot_config(path);
  if (!model) {
    std::fprintf(stderr, "fk_ik: %s\n", model.error().message.c_str());
    return 2;
  }
  constexpr double kDeg = std::numbers::pi / 180.0;
  const JointVector q{0.10, 30.0 * kDeg, 45.0 * kDeg, 10.0 * kDeg};  // d1 (m), q2, q3, q4
  const ToolPose pose = forward(*model, q);
  std::printf("robot %s\n", model->name.c_str());
  std::printf("fk: x %.4f m  y %.4f m  z %.4f m  yaw %.2f deg\n", pose.x_m, pose.y_m, pose.z_m,
              pose.yaw_rad / kDeg);
  const Result<JointVector> back = inverse(*model, pose, q);
  if (!back) {
    std::fprintf(stderr, "fk_ik: ik failed: %s\n", back.error().message.c_str());
    return 1;
  }
  std::printf("ik: d1 %.4f m  q2 %.2f deg  q3 %.2f deg  q4 %.2f deg\n", (*back)[0],
              (*back)[1] / kDeg, (*back)[2] / kDeg, (*back)[3] / kDeg);
  double worst = 0.0;
  for (int i = 0; i < 4; ++i) worst = std::fmax(worst, std::fabs((*back)[i] - q[i]));
  if (worst > 1e-9) {
    std::fprintf(stderr, "fk_ik: round trip off by %g\n", worst);
    return 1;
  }
  std::printf("round trip ok\n");
  return 0;
}
