#include "terminal_operator.hpp"

#include <cstdio>
#include <iostream>

#include <fmt/format.h>

namespace scaratwin::cli {

Status TerminalOperator::pattern(bool on) {
  std::fputs(on ? "    lay the printed pattern on the table (registered to the robot's base) "
                  "and press Enter: "
                : "    take the pattern away and press Enter: ",
             stdout);
  std::fflush(stdout);
  std::string line;
  if (!std::getline(std::cin, line))
    return Error{CalibrationError::kNoOperator, "calibration: no operator at the terminal"};
  return Ok{};
}

Status TerminalOperator::touch_off(Hub& hub, const std::string& name,
                                   const std::array<double, 3>& mark) {
  fmt::print(
      "    touch-off {} at ({:.1f}, {:.1f}, {:.1f}) mm: jog with x+ x- y+ y- z+ z- and a step "
      "in steps (e.g. `y+ 3`), Enter alone when the tool is on the mark\n",
      name, mark[0] * 1e3, mark[1] * 1e3, mark[2] * 1e3);
  for (;;) {
    fmt::print("    > ");
    std::fflush(stdout);
    std::string line;
    if (!std::getline(std::cin, line))
      return Error{CalibrationError::kNoOperator, "calibration: no operator at the terminal"};
    if (line.empty()) return Ok{};
    char axis = 0, sign = 0;
    int steps = 1;
    if (std::sscanf(line.c_str(), " %c%c %d", &axis, &sign, &steps) < 2 ||
        (sign != '+' && sign != '-') || steps < 1 || steps > 200) {
      fmt::print("    expected e.g. `z- 5`\n");
      continue;
    }
    const protocol::Axis a = axis == 'z'   ? protocol::Axis::kZ
                             : axis == 'y' ? protocol::Axis::kJ2
                                           : protocol::Axis::kJ3;
    if (Status s = hub.jog(a, sign == '+' ? steps : -steps); !s) return s;
    (void)hub.wait_idle(10.0);
  }
}

}  // namespace scaratwin::cli
