// The physical robot as built: what its description does not say about the machine on the
// table. Two parts, both read from the robot description (`[drive]` and `[as_built]`):
//  - DriveModel: the stepper motors and their driver (a NEMA 17 on an A4988 at 12 V by
//    default; docs/physical.md gives the source of each figure), the belts and the lead screw;
//  - AsBuiltProfile: how far each built dimension may differ from the description (a
//    tolerance per parameter) and the seed of the draw, or explicit values.
// Only the emulated physical robot (the plant) uses these; the twin's own logic never does,
// because a real robot does not tell its owner how it was built. SI units inside.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace scaratwin {

// One hybrid stepper motor and its chopper driver.
struct StepperDrive {
  double holding_torque_nm = 0.40;     // at the rated current, both phases on
  double rated_current_a = 1.7;        // per phase
  double current_a = 1.2;              // the driver's current limit (A4988 Vref setting)
  double resistance_ohm = 1.5;         // per phase
  double inductance_h = 0.0028;        // per phase
  double rotor_inertia_kgm2 = 5.4e-6;  // 54 g cm^2
  double detent_torque_nm = 0.015;
  double friction_nm = 0.004;    // Coulomb friction of the rotor and its bearings
  double viscous_nms = 2.0e-4;   // viscous loss (eddy currents, driver damping)
  int full_steps_per_rev = 200;  // 1.8 deg motor
  int microsteps = 8;            // A4988 MS1 = MS2 = high
};

// The drive train of Z, J2 and J3: one motor type, the supply, and per axis the stiffness and
// damping of the belt (J2, J3: N m/rad at the joint) or of the lead screw and nut (Z: N/m).
struct DriveModel {
  StepperDrive motor;
  double supply_v = 12.0;
  std::array<double, 3> stiffness{2.0e5, 40.0, 25.0};  // Z N/m, J2 and J3 N m/rad
  std::array<double, 3> damping{300.0, 0.25, 0.12};    // Z N s/m, J2 and J3 N m s/rad
};

// Built deviations from the description, one number each (SI: m, rad, or a fraction).
enum class AsBuiltParam : int {
  kA2 = 0,       // link 2 length (DH a2) error, m
  kA3,           // link 3 length (DH a3) error, m
  kZZero,        // where the Z endstop really closes minus where the description says, m
  kJ2Zero,       // the same for J2, rad
  kJ3Zero,       // the same for J3, rad
  kZLead,        // relative error of the Z lead screw (true metres per step = (1 + e) x)
  kWristOffset,  // wrist servo horn offset on its spline, rad
  kWristGain,    // relative gain error of the wrist servo (pulse -> angle)
  kGripperGain,  // relative gain error of the gripper servo
  kJawOffset,    // gripper's grasp centre off the wrist axis, along the wrist x, m
  kCameraX,      // camera mount position error, m
  kCameraY,
  kCameraZ,
  kCameraTiltX,    // camera mount rotation error about the camera's x axis, rad
  kCameraTiltY,    // ... about its y axis, rad
  kCameraRoll,     // ... about its optical axis, rad
  kZBacklash,      // dead band of the Z nut, m (drawn in [tol/2, tol])
  kJ2Backlash,     // dead band of the J2 belt drive, rad (drawn in [tol/2, tol])
  kJ3Backlash,     // dead band of the J3 belt drive, rad (drawn in [tol/2, tol])
  kServoDeadband,  // dead band of the hobby servos, rad (drawn in [tol/2, tol])
  kCount
};
inline constexpr int kAsBuiltCount = static_cast<int>(AsBuiltParam::kCount);

// Description key, unit scale (key unit -> SI), default tolerance (in the key's unit) and
// whether the parameter is a non-negative size drawn in [tol/2, tol] (else in [-tol, tol]).
struct AsBuiltKey {
  std::string_view key;
  double to_si;
  double default_tolerance;
  bool magnitude;
};
const std::array<AsBuiltKey, kAsBuiltCount>& as_built_keys();

// The tolerance profile of `[as_built]`: a bound per parameter, the seed of the draw, and
// explicit values that replace the draw where given.
struct AsBuiltProfile {
  std::uint64_t seed = 1;
  std::array<double, kAsBuiltCount> tolerance{};  // SI; filled with the defaults
  std::array<double, kAsBuiltCount> value{};      // SI; used where `fixed`
  std::array<bool, kAsBuiltCount> fixed{};
  AsBuiltProfile();
};

// One drawn robot: the deviation of every parameter (SI).
struct AsBuilt {
  std::array<double, kAsBuiltCount> v{};
  double operator[](AsBuiltParam p) const { return v[static_cast<int>(p)]; }
};

// Draws the robot as built from its profile: the same seed gives the same robot on every
// machine (the draw uses its own integer-to-double mapping, not a library distribution).
AsBuilt draw_as_built(const AsBuiltProfile& profile);

// A robot exactly as described (every deviation zero): the ideal plant.
inline AsBuilt ideal_as_built() { return AsBuilt{}; }

struct PhysicalModel {
  DriveModel drive;
  AsBuiltProfile as_built;
};

}  // namespace scaratwin
