// scaratwin-robot: the real camera over the physical table (as-built only), served on a thread
// of its own. A webcam is not the Arduino: the firmware's emulation must never stand still
// while a picture is rendered, spoilt or sent to a client that is slow to read it. The
// emulator's loop only copies the table's poses, between two of its passes, when the camera's
// thread asks for them (serve()); everything else happens on that thread.
//
// The port (TCP on 127.0.0.1, one request per line): "grab <w> <h>" is answered
// "FRAME <n> <sim_us> <w> <h> <bytes>\n", that many bytes of RGB (row 0 at the top), then a
// newline. <n> counts the pictures taken; <sim_us> is the emulated time at which the poses
// were taken. Anything else is answered "ERR <reason>". A client that does not read its
// picture within 2 s is disconnected.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator (GPL-3.0-or-later because it links libsimavr).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "scaratwin/core/result.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/plant/plant_camera.hpp"
#include "side_channel.hpp"

namespace scaratwin::robot {

class CameraServer {
 public:
  // Listens on 127.0.0.1:port (0: any free port) and starts the camera's thread. `plant` must
  // outlive the server; `lens` is this webcam's own.
  static Result<std::unique_ptr<CameraServer>> start(std::uint16_t port, const plant::Plant& plant,
                                                     const plant::LensModel& lens);
  ~CameraServer();  // answers a waiting request with ERR and joins the thread
  CameraServer(const CameraServer&) = delete;
  CameraServer& operator=(const CameraServer&) = delete;

  std::uint16_t port() const { return port_; }

  // The emulator's loop, between two passes (the plant stands still meanwhile): when the
  // camera's thread waits for the table's poses, copies them, stamped `sim_us`; when it is
  // about to make its renderer, lends it the plant's model (take_model_back()). Costs one
  // atomic load when nothing waits.
  void serve(std::uint64_t sim_us);
  // The loop, before it changes the plant's model (a payload, the pattern): waits while the
  // camera's thread reads the model to make its renderer (a fraction of a second, once, when
  // the first client connects; the loop runs the firmware and the plant on meanwhile). Made at
  // start instead, the renderer would cost every emulated robot 0.6 s and 165 MB in the
  // sanitizer build, camera used or not.
  void take_model_back();

 private:
  CameraServer(const plant::Plant& plant, const plant::LensModel& lens, SideChannel channel);
  // the camera's thread
  void run();
  void serve_clients();  // until stopped
  std::string answer(const std::string& request);
  std::string make_renderer();  // with the model lent by the loop; "" or the error

  const plant::Plant& plant_;
  plant::LensModel lens_;
  SideChannel channel_;  // used by the camera's thread only, once started
  std::uint16_t port_ = 0;
  int stop_fd_ = -1;  // eventfd: wakes the camera's thread to stop
  std::thread thread_;

  static constexpr int kNice = 10;  // the camera's thread's niceness (the loop's is 0)
  // what the camera's thread wants of the emulator's loop (bits, set under mu_): the model
  // lent while the renderer is made, the poses captured
  static constexpr unsigned kLend = 1, kCapture = 2;
  std::atomic<unsigned> wanted_{0};
  std::atomic<bool> model_lent_{false};
  bool first_client_seen_ = false;  // the camera's thread only
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;  // under mu_
  bool lent_ = false;      // under mu_: the model is lent to the camera's thread
  bool captured_ = false;  // under mu_
  std::string capture_error_;
  std::uint64_t capture_sim_us_ = 0;
  // the renderer (GL context and scene): made and drawn on the camera's thread, the poses
  // captured into its scene by the loop
  std::unique_ptr<plant::PlantCamera> camera_;
};

}  // namespace scaratwin::robot
