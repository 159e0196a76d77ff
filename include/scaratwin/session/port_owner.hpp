// The owner of a robot's serial port, and its clients. A Uno resets whenever its port is opened
// (the USB chip pulses RESET through DTR) and comes back un-homed, so a robot can only stay
// homed across statements if one long-running program keeps its port open: `scaratwin hub`.
// It claims the port here (one owner per port: a second is refused, a dead one's claim is
// free again at once) and listens on a local socket named after the port; every statement,
// `scaratwin run` and the other front ends that find it send their work there instead of
// opening the port themselves (docs/owner.md).
//
// The socket: a Unix stream socket in $XDG_RUNTIME_DIR/scaratwin (else /tmp/scaratwin-UID, made
// 0700), one per port, named after the port's real path (symlinks resolved), beside a lock file
// the owner holds with flock() for as long as it lives. One request per connection, one JSON
// object a line each way:
//   -> {"statement":"movej 0.05 30 45 0"}       or {"script":TEXT,"name":"pick.txt"}
//   <- {"line":"..."}  (any number: what the statement says, as it goes)
//   <- {"ok":true}     or {"ok":false,"code":N,"message":"..."}
// A client that goes away before the answer (Ctrl-C, kill) stops what it asked for.
#pragma once

#include <sys/types.h>

#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/script.hpp"
#include "scaratwin/session/links.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

// What a client asks the owner for: one statement, or a script (its text and its name).
struct OwnerRequest {
  std::string statement;
  std::string script;
  std::string name;  // the script's file, for its lines' messages
};

// Where the owner of the port `device` listens, and its lock file (`device` resolved to its
// real path; a device that does not exist is named as given).
std::filesystem::path owner_socket_path(const std::string& device);
std::filesystem::path owner_lock_path(const std::string& device);

// The one serial port `links` names for a single robot: --serial DEVICE (or NAME=DEVICE), else
// $SCARATWIN_SERIAL; nothing for several ports or none.
std::optional<std::string> single_serial_device(const LinkOptions& links);

class PortOwner {
 public:
  // Runs one request on the owner's robot: says its lines through `say`, returns how it ended.
  // `gone()` turns true once the client has gone away (then the work should stop).
  using Handler = std::function<Status(const OwnerRequest& request, const Say& say,
                                       const std::function<bool()>& gone)>;

  // Claims `device` before anything opens it: fails with SessionError::kPortOwned (naming the
  // owner's pid) when a live owner holds it. Requests wait until serve().
  static Result<std::unique_ptr<PortOwner>> claim(const std::string& device);
  ~PortOwner();  // stops listening, removes the socket, gives up the claim
  PortOwner(const PortOwner&) = delete;
  PortOwner& operator=(const PortOwner&) = delete;

  // Takes requests, each on a thread of its own, and runs `handler` for them.
  void serve(Handler handler);
  // Takes no more requests and waits for the handlers running (the socket stays claimed until
  // the destructor). The caller makes them end: a handler waiting for the hub is told it stopped.
  void stop();
  const std::filesystem::path& socket_path() const { return socket_path_; }

 private:
  PortOwner() = default;
  void accept_loop();
  void answer(int fd);

  std::filesystem::path socket_path_;
  std::filesystem::path lock_path_;
  int lock_fd_ = -1;
  int listen_fd_ = -1;
  int wake_[2] = {-1, -1};  // closes the accept loop
  Handler handler_;
  std::thread thread_;
  std::mutex mu_;
  std::condition_variable idle_;  // active_ fell to 0
  int active_ = 0;                // requests being answered (mu_)
};

// The line a statement's result is printed as: the result alone, or for a script's statement
// its line number and source before it (as `scaratwin run` prints them).
std::string statement_line(const Statement& statement, const std::string& result);

// Runs `request` on `hub` as the command line runs a statement or a script (a script is parsed
// whole first: a syntax error moves nothing), each result said through `say`.
Status run_request(Hub& hub, const OwnerRequest& request, const Say& say);

// Sends `request` to the owner of `device`. Nothing when no owner holds the port (no socket,
// or the claim of a dead one); else how the owner's work ended, its lines said through `say`.
// The owner's pid in `owner_pid` when it answers.
std::optional<Status> ask_owner(const std::string& device, const OwnerRequest& request,
                                const Say& say, pid_t* owner_pid = nullptr);

}  // namespace scaratwin::session
