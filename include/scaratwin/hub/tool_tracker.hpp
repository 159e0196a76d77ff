// The twin watching its robot through a camera: a webcam over the table follows the marker on
// the robot's wrist at >= 20 frames/s while the robot moves, and the tracker compares where
// the camera sees it with where the virtual robot puts it (the robot's reported joints at the
// frame's instant). A robot without encoders cannot see a lost step any other way while it
// happens. More than `threshold_m` off for `persist` frames running raises a desync alarm
// (an event in the twin database and a count).
//
// The camera: the emulated robot's (`scaratwin-robot --camera-port`: "grab w h" answered with a
// raw RGB frame and its time on the robot's clock); a real robot's webcam has the same shape.
// The camera is not calibrated here (that is the calibration statement's job): the tracker
// learns a cubic correction from the nominal camera model's picture to the table while the
// robot is trusted (learn), then tracks against it.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin {

// One frame of a network webcam.
struct CameraFrame {
  std::uint64_t number = 0;
  std::uint64_t device_us = 0;  // the robot's clock when it was taken (the emulator's)
  RgbImage image;
};

// A webcam on a TCP port (the emulated robot's camera).
class NetCamera {
 public:
  static Result<std::unique_ptr<NetCamera>> connect(const std::string& host, std::uint16_t port);
  ~NetCamera();
  Result<CameraFrame> grab(int width_px, int height_px);

 private:
  NetCamera() = default;
  int fd_ = -1;
  std::string buf_;
};

// A cubic map from a first guess (the nominal camera model's point on the marker's plane) to
// the table, fitted by least squares. Pure.
class PlaneCorrection {
 public:
  void add(const std::array<double, 2>& guess, const std::array<double, 2>& truth);
  std::size_t samples() const { return guess_.size(); }
  // Needs >= 20 samples; the cubic terms are fitted only when the samples cover an area (2 cm
  // both ways), else an offset and a linear map.
  Status fit();
  bool fitted() const { return fitted_; }
  std::array<double, 2> apply(const std::array<double, 2>& guess) const;

 private:
  std::vector<std::array<double, 2>> guess_, truth_;
  std::array<double, 10> cx_{}, cy_{};
  bool fitted_ = false;
};

struct TrackerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;
  int width_px = 480;  // a reduced picture: the marker is about 11 px across
  int height_px = 360;
  double fps = 20.0;
  double threshold_m = 0.002;
  int persist = 2;
};

class ToolTracker {
 public:
  struct Sample {
    std::uint64_t mono_us = 0;    // when the frame arrived (CLOCK_MONOTONIC)
    std::uint64_t device_us = 0;  // the frame's time on the robot's clock
    bool seen = false;            // the marker was found
    double offset_m = 0.0;        // seen vs virtual (after the correction)
  };

  static Result<std::unique_ptr<ToolTracker>> start(Hub& hub, const TrackerOptions& options);
  ~ToolTracker();

  // While learning, each frame adds a sample to the correction instead of being judged.
  void set_learning(bool on);
  // Fits the correction from what was learnt; then frames are judged.
  Status fit();
  int alarms() const { return alarms_.load(); }
  std::optional<std::uint64_t> first_alarm_mono_us() const;
  std::vector<Sample> samples() const;
  std::uint64_t frames() const { return frames_.load(); }

 private:
  ToolTracker(Hub& hub, const TrackerOptions& o) : hub_(hub), options_(o) {}
  void watch_reports();
  void track();
  std::optional<JointVector> joints_at(std::uint64_t device_us) const;

  Hub& hub_;
  TrackerOptions options_;
  std::unique_ptr<NetCamera> camera_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> learning_{false};
  std::atomic<int> alarms_{0};
  std::atomic<std::uint64_t> frames_{0};
  mutable std::mutex mu_;
  std::deque<std::pair<std::uint32_t, JointVector>> reports_;  // (device t_us, joints)
  PlaneCorrection correction_;
  std::vector<Sample> samples_;
  std::optional<std::uint64_t> first_alarm_us_;
  int streak_ = 0;
  std::thread reports_thread_, camera_thread_;
};

}  // namespace scaratwin
