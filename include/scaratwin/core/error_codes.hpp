// The one table of error codes (Error::code). Each module owns a range of codes; every code a
// module returns is named here, in the module's enum, so no two modules share a number and no
// bare number is returned. docs/errors.md publishes the same table (a test keeps the two in
// step: tests/core/test_error_codes.cpp).
//
// The numbers the outside world sees keep their own tables: the wire error codes of the serial
// and TCP links (`ER=N=`, `ER,N,`: docs/protocol.md section 6, protocol/codec_core.h) are
// carried inside the host as protocol_error_code(N) = 200 + N; the CLI's exit statuses
// (0, 1, 2, 130) are the apps' own (apps/scaratwin/commands.hpp). The codes of IkError and
// PlanError are published by the Python package (docs/python.md) and never change.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>

namespace scaratwin {

// One module's codes: first..last, both included.
struct ErrorRange {
  std::string_view module;  // as in docs/errors.md
  std::string_view codes;   // the enum (or rule) that names its codes
  int first = 0;
  int last = 0;
};

// Sorted by `first`; the ranges do not overlap (static_assert below). Code 0 is no error.
inline constexpr std::array<ErrorRange, 16> kErrorRanges{{
    {"kinematics", "IkError", 1, 9},
    {"trajectory", "PlanError", 10, 19},
    {"config", "ConfigError", 20, 29},
    {"calibration", "CalibrationError", 30, 39},
    {"sim", "sim::SimError", 40, 49},
    {"script", "ScriptError", 50, 59},
    {"vision", "VisionError", 60, 69},
    {"web", "web::WebError", 70, 79},
    {"hub", "HubError", 80, 89},
    {"apps", "AppError", 90, 99},
    {"transport", "transport::TransportError", 100, 119},
    {"database", "DbError", 120, 129},
    {"emulator", "EmulatorError", 130, 139},
    {"plant", "PlantError", 140, 149},
    {"session", "session::SessionError", 150, 159},
    {"protocol", "protocol_error_code(N)", 201, 255},
}};
// The fleet's codes are in their own, wider range (they reach MQTT clients as "code").
inline constexpr ErrorRange kFleetErrorRange{"fleet", "fleet::FleetError", 1400, 1499};

// Inverse kinematics (kinematics/kinematics.hpp). Each failure has its own code.
enum class IkError : int {
  kNotFinite = 1,       // a coordinate is NaN or infinite
  kBeyondReach = 2,     // farther from the shoulder than both links stretched out
  kInsideDeadZone = 3,  // closer to the shoulder than |a2 - a3|
  kZOutOfTravel = 4,    // needs a d1 outside the Z travel
  kJ2Limit = 5,         // the shoulder would leave its limits on every elbow solution
  kJ3Limit = 6,         // the elbow would leave its limits on every elbow solution
  kJ4Limit = 7,         // the wrist would leave its limits on every elbow solution
};

// The planners (trajectory/trajectory.hpp).
enum class PlanError : int {
  kBadArgument = 10,    // a sample count, duration or step that makes no sense
  kJointLimit = 11,     // a start, goal or sample outside the joint limits
  kMotorLimit = 12,     // a requested duration too short for a motor's speed or acceleration
  kUnreachable = 13,    // a Cartesian sample has no IK solution (the message says which)
  kDiscontinuous = 14,  // a Cartesian path would need a jump of the joints (elbow flip, wrap)
  kCollision = 15,      // two arms of a workcell would come closer than the clearance
};

// The robot description (kinematics/robot_model.hpp, config/robot_config.hpp) and the workcell
// (kinematics/workcell.hpp, config/workcell_config.hpp).
enum class ConfigError : int {
  kInvalid = 20,        // a description that does not parse or fails validation (names the key)
  kNotFound = 21,       // no such description file, or it cannot be read
  kUnknownColour = 22,  // a cube colour name other than red, green or blue
  kUnknownRobot = 23,   // a robot name the workcell does not have (the message lists them)
};

// Calibration: the fit (calibration/calibration.hpp) and its routine (hub/calibrate.hpp, the
// operator's steps of `scaratwin calibrate`).
enum class CalibrationError : int {
  kNotEnoughData = 30,   // a parameter has no measurement that could determine it
  kInconsistent = 31,    // the measurements do not fit one robot (slipped belt, lost steps)
  kSolver = 32,          // the solver refused its input
  kNotDetermined = 33,   // a parameter is poorly determined by these measurements
  kCalibratedBase = 34,  // asked to calibrate a description that is already an overlay
  kMarkerNotFound = 35,  // the tool marker was not found in the pictures
  kUnreachable = 36,     // a calibration pose is out of the robot's reach
  kTouchOff = 37,        // a touch-off did not bring the tool onto its mark
  kNoOperator = 38,      // nobody answered at the terminal
  kWriteFailed = 39,     // the overlay could not be written
};

namespace sim {
// The simulator (sim/simulation.hpp, sim/mjcf.hpp).
enum class SimError : int {
  kMujoco = 40,         // MuJoCo reported an error (model compile, stack overflow, ...)
  kBadArgument = 41,    // a value that is not finite or out of its valid range, a bad option
  kPoolExhausted = 42,  // every cube of that colour is already in the scene
  kOccupied = 43,       // a spawn position overlaps a cube already there
  kNoSuchCube = 44,     // an id that names no cube in the scene
  kRender = 45,         // the camera could not render or encode
  kWrongMode = 46,      // a mirror command in simulate mode or the reverse
  kNoRobot = 47,        // a robot index the simulated workcell does not have
};
}  // namespace sim

// Control statements and scripts (hub/script.hpp, hub/runner.hpp).
enum class ScriptError : int {
  kLine = 50,              // a script line failed (the message names the line and the reason)
  kWriteFailed = 51,       // a picture could not be written
  kNoSuchCube = 52,        // a statement names a cube that is not in the scene
  kUnknownStatement = 53,  // a statement the runner does not know
};

// Vision (vision/vision.hpp, vision/webcam.hpp).
enum class VisionError : int {
  kBadImage = 60,          // not a PNG image, or it cannot be decoded
  kBadPattern = 61,        // a calibration pattern that cannot be drawn at that size
  kPictureTooSmall = 62,   // a webcam picture too small to calibrate with
  kTooFewTags = 63,        // too few pattern tags seen to calibrate the webcam
  kNoConvergence = 64,     // the webcam fit did not converge
  kResidualTooLarge = 65,  // the webcam fit leaves a residual above its limit
};

namespace web {
// The browser UI's server (web/feed.hpp, web/web_server.hpp).
enum class WebError : int {
  kBadCommand = 70,  // a page message that is not a valid command (names the field)
  kBind = 71,        // the HTTP port could not be bound
  kBadOption = 72,   // an option that cannot work (names the value)
};
}  // namespace web

// The hub (hub/hub.hpp and the pieces beside it).
enum class HubError : int {
  kFailed = 80,       // an operation of the hub failed (the message says which and why)
  kTask = 81,         // a task (sorting, pick and place) could not go on
  kStartFailed = 82,  // a helper program could not be started
  kNotReady = 83,     // a helper program did not say it was ready in time
  kExited = 84,       // a helper program exited before it was ready
  kCamera = 85,       // the tool tracker's camera link failed
  kBadOption = 86,    // a tool tracker option that cannot work
  kTracker = 87,      // the tool tracker could not learn the tool
  kInterrupted = 88,  // a stop or Ctrl-C ended the hub's serving loop
};

// The executables' own steps (apps/scaratwin).
enum class AppError : int {
  kDemoNoCube = 90,       // the demo's spawned cube is not in the scene
  kDemoRecognition = 91,  // the demo's colour recognition found the wrong number of cubes
  kDemoPrediction = 92,   // the demo's prediction did not sort every cube
  kRigStart = 93,         // the simulator or the emulator of a rig could not be started
  kBadOption = 94,        // a command-line option that cannot work (names it)
  kBench = 95,            // a benchmark step failed
  kWriteFailed = 96,      // a figure or a file could not be written
  kEmulatorChannel = 97,  // the emulator's side channel refused or did not answer
};

namespace transport {
// The transport (transport/link.hpp). Local failures; a peer's refusal is a protocol code.
enum class TransportError : int {
  kNotConnected = 100,     // send while the link has no peer / no open device
  kTimeout = 101,          // nothing arrived (or no connection came up) within the timeout
  kClosed = 102,           // the link was closed by its owner
  kBufferFull = 103,       // the transmit queue holds more than max_tx_queue_bytes
  kBadOption = 104,        // an option value that cannot work (names the value)
  kOpenFailed = 105,       // a device or address that cannot be opened / bound
  kPayloadTooLarge = 106,  // a binary payload above the link's max_payload_bytes
};
}  // namespace transport

// The twin database and the reports read from it (hub/twin_db.hpp, hub/report.hpp).
enum class DbError : int {
  kSqlite = 120,       // SQLite reported an error (the message has SQLite's)
  kNoRun = 121,        // no run with that id, or it cannot be read
  kNoTable = 122,      // no table of that name
  kWriteFailed = 123,  // an export or a report could not be written
  kNotFound = 124,     // no database file at that path
};

// The emulated robot (robot/: simavr, its pty, its side channel, scenarios).
enum class EmulatorError : int {
  kBadScenario = 130,  // a scenario file that cannot be read, or a bad line in it
  kSetup = 131,        // the physical world or the camera's port could not be set up
  kFirmware = 132,     // the firmware cannot be loaded, or it stopped or crashed
  kPty = 133,          // the pseudo-terminal could not be opened
  kSideChannel = 134,  // the side channel could not listen
  kBadOption = 135,    // an option that cannot work (names it)
};

// The physical world behind the emulated firmware (plant/plant.hpp).
enum class PlantError : int {
  kBadArgument = 140,   // a value out of its valid range (names it)
  kInvalidRobot = 141,  // the as-built robot is not a valid robot
};

namespace session {
// A twin session's own steps (session/): the owner of a robot's port and its clients.
enum class SessionError : int {
  kPortOwned = 150,    // another program owns the robot's port (the message names it)
  kOwnerSocket = 151,  // the owner's local socket cannot be made or bound
  kOwnerGone = 152,    // the port's owner ended the connection before it answered
  kOwnerReply = 153,   // a request or an answer on the owner's socket that is not valid
};
}  // namespace session

namespace fleet {
// The fleet's MQTT bridge (fleet/topics.hpp, fleet/mqtt_bridge.hpp). Unscoped: the bridge's
// replies carry them as plain numbers.
enum FleetError : int {
  kBadRobotName = 1401,
  kBadUrl = 1402,
  kOversized = 1403,
  kMalformed = 1404,
  kWrongRobot = 1405,
  kBusy = 1406,
  kNoCommands = 1407,
};
}  // namespace fleet

// A wire error code N of the serial and TCP links (protocol/codec_core.h, 1..55) as an
// Error::code: 200 + N. The wire keeps N (`ER,N,`); only the host's Error::code is offset, so a
// peer's refusal never reads as another module's code.
inline constexpr int kProtocolErrorBase = 200;
constexpr int protocol_error_code(int wire_code) { return kProtocolErrorBase + wire_code; }

// Error::code of an enum above.
template <typename E>
constexpr int error_code(E e) {
  return static_cast<int>(e);
}

namespace detail {
// Whether first..last (an enum's lowest and highest code) lie in the range of `codes`.
// Indices rather than pointers: GCC's sanitizers make pointer tests non-constant.
template <typename E>
constexpr bool fits(std::string_view codes, E first, E last) {
  const int lo = static_cast<int>(first);
  const int hi = static_cast<int>(last);
  if (kFleetErrorRange.codes == codes) {
    return kFleetErrorRange.first <= lo && hi <= kFleetErrorRange.last;
  }
  for (std::size_t i = 0; i < kErrorRanges.size(); ++i) {
    if (kErrorRanges[i].codes == codes) {
      return kErrorRanges[i].first <= lo && hi <= kErrorRanges[i].last;
    }
  }
  return false;
}
constexpr bool ranges_disjoint() {
  for (std::size_t i = 0; i < kErrorRanges.size(); ++i) {
    if (kErrorRanges[i].first > kErrorRanges[i].last) return false;
    if (i > 0 && kErrorRanges[i - 1].last >= kErrorRanges[i].first) return false;
  }
  return kErrorRanges.back().last < kFleetErrorRange.first &&
         kFleetErrorRange.first <= kFleetErrorRange.last;
}
}  // namespace detail

static_assert(detail::ranges_disjoint(), "error ranges must be sorted and disjoint");
static_assert(detail::fits("IkError", IkError::kNotFinite, IkError::kJ4Limit));
static_assert(detail::fits("PlanError", PlanError::kBadArgument, PlanError::kDiscontinuous));
static_assert(detail::fits("ConfigError", ConfigError::kInvalid, ConfigError::kUnknownRobot));
static_assert(detail::fits("CalibrationError", CalibrationError::kNotEnoughData,
                           CalibrationError::kWriteFailed));
static_assert(detail::fits("sim::SimError", sim::SimError::kMujoco, sim::SimError::kNoRobot));
static_assert(detail::fits("ScriptError", ScriptError::kLine, ScriptError::kUnknownStatement));
static_assert(detail::fits("VisionError", VisionError::kBadImage, VisionError::kResidualTooLarge));
static_assert(detail::fits("web::WebError", web::WebError::kBadCommand, web::WebError::kBadOption));
static_assert(detail::fits("HubError", HubError::kFailed, HubError::kInterrupted));
static_assert(detail::fits("AppError", AppError::kDemoNoCube, AppError::kEmulatorChannel));
static_assert(detail::fits("transport::TransportError", transport::TransportError::kNotConnected,
                           transport::TransportError::kPayloadTooLarge));
static_assert(detail::fits("DbError", DbError::kSqlite, DbError::kNotFound));
static_assert(detail::fits("EmulatorError", EmulatorError::kBadScenario,
                           EmulatorError::kBadOption));
static_assert(detail::fits("PlantError", PlantError::kBadArgument, PlantError::kInvalidRobot));
static_assert(detail::fits("session::SessionError", session::SessionError::kPortOwned,
                           session::SessionError::kOwnerReply));
static_assert(detail::fits("fleet::FleetError", fleet::kBadRobotName, fleet::kNoCommands));
// the wire codes are uint8 and documented up to 18 today; 1..55 fit
static_assert(protocol_error_code(55) == 255);

}  // namespace scaratwin
