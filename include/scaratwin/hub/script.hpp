// The statement language of `scaratwin run FILE` and of the CLI one-liners: one control
// statement per line, the paper's "one-line control statements". Pure parsing; the hub runs
// the parsed statements. Lengths in metres, angles in degrees (as at the CLI).
//
//   # comment                      blank lines are ignored
//   home                           home the physical robot
//   stop                           stop the physical robot at once (it is then halted)
//   move X Y Z [YAW]               tool to a pose (IK, nearest elbow, planned in joint space)
//   line X Y Z [YAW]               tool in a straight line
//   movej D1 Q2 Q3 Q4              joints (m, deg)
//   grip | release                 gripper
//   shoot [FILE]                   camera picture (PNG), optionally saved
//   spawn red|green|blue X Y       a cube on the table
//   reset                          remove all cubes
//   pick ID                        pick-and-place cube ID into the tray of its colour
//   sort                           shoot, recognise colours, sort every cube into its tray
//   wait SECONDS                   pause
//   mirror SECONDS                 mirror the physical robot for a while
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

enum class StatementKind {
  kHome,
  kMove,
  kLine,
  kMoveJoints,
  kGrip,
  kRelease,
  kShoot,
  kSpawn,
  kReset,
  kPick,
  kSort,
  kWait,
  kMirror,
  kStop,
};

struct Statement {
  int line = 0;  // 1-based line in the script (0 for a one-liner)
  StatementKind kind = StatementKind::kHome;
  std::vector<double> numbers;  // SI: m, rad, s (converted from the script's m, deg, s)
  std::string text;             // file name (shoot), colour (spawn)
  bool has_yaw = false;         // move/line: a yaw was given
  std::string source;           // the statement as written
};

// Parses one statement (no comment handling). `line` is used in error messages.
Result<Statement> parse_statement(std::string_view text, int line);

// Parses a whole script; the error names the line: "script.txt:3: move needs ...".
Result<std::vector<Statement>> parse_script(std::string_view text, std::string_view name);

}  // namespace scaratwin
