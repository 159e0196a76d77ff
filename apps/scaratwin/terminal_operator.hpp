// The operator of `scaratwin calibrate` at a real robot: a person at this terminal, who lays
// the pattern and jogs the tool onto each mark.
#pragma once

#include <array>
#include <string>

#include "scaratwin/hub/calibrate.hpp"

namespace scaratwin::cli {

class TerminalOperator : public CalibrationOperator {
 public:
  Status pattern(bool on) override;
  Status touch_off(Hub& hub, const std::string& name, const std::array<double, 3>& mark_B) override;
};

}  // namespace scaratwin::cli
