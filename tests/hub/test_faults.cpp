// Faults, end to end as a user meets them (issue 17): the real executables, the firmware in
// the emulator (the exact robot, --plant ideal, paced in real time) behind its pty, the
// simulator over TCP. A hub that gives up, is interrupted (Ctrl-C) or killed, or loses its
// link mid-trajectory must leave a robot that stopped and takes the next command; the stop
// statement halts it; the simulator keeps serving when it runs out of file descriptors.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include "hub_test_support.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const fs::path kBin = SCARATWIN_BIN_DIR;
constexpr std::int64_t kHomeZ = 24667;  // Z motor count at the home pose (d1 = 0.12 m)

using test::fresh_dir;

int connect_loopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  timeval tv{0, 200000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  return fd;
}

// Reads what arrives on fd for up to `timeout`; returns it once it holds `needle`.
std::string read_until(int fd, const std::string& needle, std::chrono::milliseconds timeout) {
  std::string out;
  const auto end = std::chrono::steady_clock::now() + timeout;
  char buf[4096];
  while (std::chrono::steady_clock::now() < end && out.find(needle) == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n > 0) out.append(buf, static_cast<std::size_t>(n));
    if (n == 0) break;
  }
  return out;
}

// The emulator's side channel: truth queries and faults.
class Side {
 public:
  explicit Side(int port) : fd_(connect_loopback(port)) {
    EXPECT_EQ(command("rate 0").rfind("OK", 0), 0u);
  }
  ~Side() {
    if (fd_ >= 0) ::close(fd_);
  }
  std::string command(const std::string& c) {
    const std::string msg = c + "\n";
    if (::send(fd_, msg.data(), msg.size(), MSG_NOSIGNAL) < 0) return "ERR send";
    for (;;) {
      const auto nl = buf_.find('\n');
      if (nl != std::string::npos) {
        std::string l = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        if (l.rfind("TR ", 0) == 0 && c != "query") continue;
        return l;
      }
      const std::string more = read_until(fd_, "\n", 5000ms);
      if (more.empty()) return "ERR timeout";
      buf_ += more;
    }
  }
  // One truth value (a key of the TR line, e.g. "z", "j2").
  std::int64_t truth(const std::string& key) {
    std::istringstream in(command("query"));
    std::string tok;
    while (in >> tok) {
      if (tok.rfind(key + "=", 0) == 0) return std::stoll(tok.substr(key.size() + 1));
    }
    return INT64_MIN;
  }
  // Waits until the truth of `key` satisfies `pred`.
  bool wait(const std::string& key, const std::function<bool(std::int64_t)>& pred,
            std::chrono::seconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (pred(truth(key))) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  // True when Z, J2 and J3 do not move for 300 ms of the emulated robot's own time (its clock
  // must advance: a stalled emulator, whose motors also keep still, is not at rest). False when
  // the clock does not advance that far within 10 s of wall time.
  bool at_rest() {
    const std::int64_t from = truth("sim_us");
    const auto a = std::array{truth("z"), truth("j2"), truth("j3")};
    const auto end = std::chrono::steady_clock::now() + 10s;
    while (truth("sim_us") < from + 300000) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(20ms);
    }
    return a == std::array{truth("z"), truth("j2"), truth("j3")};
  }

 private:
  int fd_;
  std::string buf_;
};

// The emulated robot (pty at dir/robot.pty) and the simulator, ready. The faults are each a
// statement of its own, each opening the port on one robot state (a move left running by a
// killed hub, a halt): the board with its auto-reset cut, which a reset at every open would
// otherwise end (tests/hub/test_board.cpp has the board that resets).
struct Rig {
  std::unique_ptr<ChildProcess> robot, sim;
  fs::path dir, pty;
  std::string sim_port;
  int side_port = 0;

  void start(const fs::path& d) {
    dir = d;
    pty = dir / "robot.pty";
    auto r = ChildProcess::start(
        kBin / "scaratwin-robot",
        {"--pty-link", pty.string(), "--plant", "ideal", "--no-auto-reset"}, dir / "robot.log");
    ASSERT_TRUE(r) << r.error().message;
    robot = std::move(*r);
    auto s =
        ChildProcess::start(kBin / "scaratwin-sim",
                            {"--port", "0", "--http-port", "0", "--no-camera"}, dir / "sim.log");
    ASSERT_TRUE(s) << s.error().message;
    sim = std::move(*s);
    auto side = robot->wait_for_line("side channel: ", 60s);
    ASSERT_TRUE(side) << side.error().message;
    side_port = std::stoi(side->substr(side->rfind(':') + 1));
    auto listening = sim->wait_for_line("listening on", 60s);
    ASSERT_TRUE(listening) << listening.error().message;
    const size_t paren = listening->find(" (");
    const size_t colon = listening->rfind(':', paren);
    sim_port = listening->substr(colon + 1, paren - colon - 1);
  }

  // `scaratwin <args> --serial PTY --sim ADDR --db dir/twin.db`, started.
  std::unique_ptr<ChildProcess> cli(std::vector<std::string> args, const std::string& log) {
    args.insert(args.end(), {"--serial", pty.string(), "--sim", "127.0.0.1:" + sim_port, "--db",
                             (dir / "twin.db").string()});
    auto p = ChildProcess::start(kBin / "scaratwin", args, dir / log);
    EXPECT_TRUE(p) << p.error().message;
    return p ? std::move(*p) : nullptr;
  }
  // Runs `scaratwin <args>` to its end; returns its exit status.
  int run(const std::vector<std::string>& args, const std::string& log,
          std::chrono::seconds timeout = 300s) {
    auto p = cli(args, log);
    if (!p) return -1000;
    const int status = p->wait_exit(timeout);
    if (status != 0) ADD_FAILURE() << "scaratwin " << args[0] << ":\n" << p->output_tail();
    return status;
  }
};

std::string tail_of(ChildProcess& p) { return p.output_tail(40); }

// After a fault: a move to d1 = 0.10 m works and ends there by the truth (Z steps per metre).
void expect_next_move_works(Rig& rig, Side& side) {
  ASSERT_EQ(rig.run({"movej", "0.10", "0", "0", "0"}, "next.log"), 0);
  EXPECT_NEAR(static_cast<double>(side.truth("z")), 0.10 * 205560.0, 200.0);
}

// Ctrl-C during a move stops the robot at once (not at the end of its queue), exits with
// 130, and the next move works (before: the process died, the robot ran out its queue and
// kept the trajectory, and every later command was refused as busy).
TEST(Faults, CtrlCDuringAMoveStopsTheRobotAndTheNextMoveWorks) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("ctrlc")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  // Z down 10 cm: about 9 s at the motor limits
  auto move = rig.cli({"movej", "0.02", "0", "0", "0"}, "move.log");
  ASSERT_TRUE(move);
  ASSERT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 2000; }, 60s))
      << tail_of(*move);
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(::kill(move->pid(), SIGINT), 0);
  const int status = move->wait_exit(10s);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(status, 130) << tail_of(*move);
  EXPECT_LT(took, 3s) << "the interrupted statement ends at once";
  EXPECT_NE(tail_of(*move).find("interrupted"), std::string::npos) << tail_of(*move);
  EXPECT_TRUE(side.at_rest()) << "the robot stopped";
  const std::int64_t z_stopped = side.truth("z");
  EXPECT_GT(z_stopped, 4111 + 5000) << "stopped on the way, not at the end of the move";
  // the next move works (the halt is cleared) and ends where planned
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
  ASSERT_EQ(rig.run({"home"}, "home2.log"), 0);
}

// A hub killed mid-move (kill -9: nothing stops the robot) leaves the robot running out its
// queue; `scaratwin stop` stops it and says so, and the next move and home work.
TEST(Faults, StopStatementAfterAKilledHubAndTheNextMoveWorks) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("stop")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  auto move = rig.cli({"movej", "0.02", "0", "0", "0"}, "move.log");
  ASSERT_TRUE(move);
  ASSERT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 2000; }, 60s));
  ASSERT_EQ(::kill(move->pid(), SIGKILL), 0);
  (void)move->wait_exit(10s);
  auto stop = rig.cli({"stop"}, "stop.log");
  ASSERT_TRUE(stop);
  EXPECT_EQ(stop->wait_exit(60s), 0) << tail_of(*stop);
  EXPECT_NE(tail_of(*stop).find("stopped"), std::string::npos) << tail_of(*stop);
  EXPECT_TRUE(side.at_rest());
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
  ASSERT_EQ(rig.run({"home"}, "home2.log"), 0);
}

// One number from the twin database, read with SQLite itself (read-only, not through the
// hub's TwinDb): -1 when the query fails (no such file yet, no row).
std::int64_t db_number(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  std::int64_t out = -1;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_busy_timeout(h, 2000);
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, sql.c_str(), -1, &st, nullptr) == SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW && sqlite3_column_type(st, 0) != SQLITE_NULL) {
      out = sqlite3_column_int64(st, 0);
    }
    sqlite3_finalize(st);
  }
  sqlite3_close(h);
  return out;
}

// A hub killed (kill -9) while it records `mirror` into its twin database: every sample it had
// committed is still there, whole and in the robot's order (the report sequence numbers run on
// without a hole); the database passes SQLite's integrity check; the next command works and
// from then on the killed run reads 'aborted' (not 'running' for ever).
TEST(Faults, HubKilledWhileRecordingKeepsWhatItCommittedAndTheNextCommandWorks) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("killrec")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  const fs::path db = rig.dir / "twin.db";
  auto mirror = rig.cli({"mirror", "--seconds", "120"}, "mirror.log");
  ASSERT_TRUE(mirror);
  // the mirror's run, once its first batch of samples is committed
  const std::string run_sql = "SELECT max(id) FROM runs WHERE kind = 'mirror'";
  const std::string count_sql =
      "SELECT count(*) FROM samples WHERE source = 'physical' AND run = (" + run_sql + ")";
  std::int64_t committed = 0;
  const auto end = std::chrono::steady_clock::now() + 90s;
  while (committed <= 0 && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(100ms);
    committed = db_number(db, count_sql);
  }
  ASSERT_GT(committed, 0) << "no sample committed in 90 s\n" << tail_of(*mirror);
  const std::int64_t run = db_number(db, run_sql);
  ASSERT_EQ(::kill(mirror->pid(), SIGKILL), 0);
  (void)mirror->wait_exit(10s);
  // nothing committed is lost, and it is whole: consecutive report numbers
  const std::string of_run =
      fmt::format(" FROM samples WHERE source = 'physical' AND run = {}", run);
  const std::int64_t kept = db_number(db, "SELECT count(*)" + of_run);
  EXPECT_GE(kept, committed);
  EXPECT_EQ(db_number(db, "SELECT max(seq) - min(seq) + 1" + of_run), kept)
      << "a hole in the robot's report numbers";
  EXPECT_EQ(
      db_number(db, "SELECT count(*) FROM pragma_integrity_check WHERE integrity_check = 'ok'"), 1);
  // the next command works, and marks the killed run
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
  EXPECT_EQ(db_number(db, fmt::format("SELECT count(*) FROM runs WHERE id = {} AND status = "
                                      "'aborted'",
                                      run)),
            1);
  EXPECT_EQ(db_number(db, "SELECT count(*)" + of_run), kept);
}

// A script that homes and starts a long Z move, cut on the serial link for `cut_ms` (in the
// robot's time) once the move is under way (`how`: "" or " splice", the emulator's side
// channel); returns the script's process, already ended, and sets `cut_at` to when the cut
// was asked for.
std::unique_ptr<ChildProcess> cut_mid_move(Rig& rig, Side& side, int cut_ms,
                                           std::chrono::steady_clock::time_point& cut_at,
                                           const std::string& how = "") {
  {
    std::ofstream s(rig.dir / "move.txt");
    s << "home\nmovej 0.02 0 0 0\n";
  }
  auto run = rig.cli({"run", (rig.dir / "move.txt").string()}, "run.log");
  if (!run) return nullptr;
  EXPECT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 1000; }, 120s))
      << tail_of(*run);
  EXPECT_EQ(side.command(fmt::format("cut {}{}", cut_ms, how)),
            fmt::format("OK cut {}{}", cut_ms, how));
  cut_at = std::chrono::steady_clock::now();
  EXPECT_EQ(run->wait_exit(60s), 1) << tail_of(*run);
  return run;
}

// A serial cut (the robot's USB gone quiet) of 0.5 s mid-trajectory, `how` as for
// cut_mid_move: the firmware reports 100 times a second, so the hub says after 150 ms without
// a report that the link is cut or the robot stalled; the reports after it show the robot's
// clock ran on through the silence (a cut: an emulator that stalls on a busy host stops its
// clock too), so the hub stops the robot and fails the move, the stop confirmed (EV 6); the
// robot rests on the way and the next move works.
void expect_short_cut_stops_the_robot(const char* name, const std::string& how) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir(name)));
  Side side(rig.side_port);
  std::chrono::steady_clock::time_point cut_at;
  auto run = cut_mid_move(rig, side, 500, cut_at, how);
  ASSERT_TRUE(run);
  const std::string out = tail_of(*run);
  EXPECT_NE(out.find("move.txt:2"), std::string::npos) << out;
  EXPECT_NE(out.find("no state report from the robot for "), std::string::npos) << out;
  EXPECT_NE(out.find("the robot link is back after "), std::string::npos) << out;
  EXPECT_LT(out.find("no state report"), out.find("is back after")) << out;
  EXPECT_NE(out.find("cut or unplugged): stopping the robot"), std::string::npos) << out;
  EXPECT_NE(out.find("movej 0.02 0 0 0: the robot link was cut for "), std::string::npos) << out;
  EXPECT_NE(out.find("cut or unplugged); the robot was stopped"), std::string::npos)
      << "the stop is confirmed once the link is back: " << out;
  // the cut's silence is not said to be a stall (short stalls before it are, on a busy host)
  const std::size_t back = out.find("the robot link is back after ");
  const std::size_t silent = out.rfind("no state report from the robot for ", back);
  const std::size_t stalled = out.find("the robot stalled, not the link", silent);
  EXPECT_TRUE(stalled == std::string::npos || stalled > back) << "a cut taken for a stall: " << out;
  EXPECT_TRUE(side.at_rest()) << "the robot stopped";
  EXPECT_GT(side.truth("z"), 4111 + 2000) << "stopped on the way, not at the end of the move";
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
}

// Before: the hub noticed nothing for 3 s ("no progress"). With the watchdog off
// (robot_silence_s 0) this fails: no word of the cut, the move rides on.
TEST(Faults, SerialCutOfHalfASecondMidTrajectoryStopsTheRobotCleanly) {
  expect_short_cut_stops_the_robot("cut05", "");
}

// The same cut, starting and ending inside a state report (after its t_us field): the first
// line after it decodes as a report with the clock of the one before the cut, one period on,
// and the positions of one after it. The hub took that for a stalled robot and let the move
// go on (seen once on a loaded machine as a random cut that fell so; the emulator's `splice`
// makes it happen every time); the next report's clock jump shows the cut.
TEST(Faults, SerialCutInsideTwoReportsIsNotTakenForAStall) {
  expect_short_cut_stops_the_robot("cutsplice", " splice");
}

// A serial cut of 5 s mid-trajectory (issue 17's reproduction was 4 s): said after 150 ms;
// after the reply timeout's 3 s of silence (longer than the robot's queue lasts) the hub ends
// the move, sends
// the stop into the silence and says the stop was not confirmed (it ends while the link is
// still cut); the robot, hearing nothing, stopped by itself when its queued points ran out;
// once the link is back, home and the next move work (before: "HM refused: busy (9)").
TEST(Faults, SerialCutOfFiveSecondsMidTrajectoryIsReportedAndHomeWorksAfter) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("cut5")));
  Side side(rig.side_port);
  std::chrono::steady_clock::time_point cut_at;
  auto run = cut_mid_move(rig, side, 5000, cut_at);
  ASSERT_TRUE(run);
  const std::string out = tail_of(*run);
  EXPECT_NE(out.find("move.txt:2"), std::string::npos) << out;
  EXPECT_NE(out.find("no state report from the robot for "), std::string::npos) << out;
  EXPECT_NE(out.find("the robot link is silent for "), std::string::npos) << out;
  EXPECT_NE(out.find("cut or unplugged) during a move: stopping the robot"), std::string::npos)
      << out;
  EXPECT_NE(out.find("robot stop: not confirmed within 0.5 s"), std::string::npos) << out;
  EXPECT_EQ(out.find("the robot link is back"), std::string::npos)
      << "the statement ended while the link was still cut: " << out;
  std::this_thread::sleep_until(cut_at + 5500ms);
  EXPECT_TRUE(side.at_rest()) << "the robot stopped by itself";
  EXPECT_GT(side.truth("z"), 4111 + 2000) << "not at the end of the move";
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
}

// The simulator's port, from its "listening on 127.0.0.1:PORT (" line.
std::string sim_port_of(ChildProcess& sim) {
  auto listening = sim.wait_for_line("listening on", 60s);
  if (!listening) return {};
  const size_t paren = listening->find(" (");
  const size_t colon = listening->rfind(':', paren);
  return listening->substr(colon + 1, paren - colon - 1);
}

// The simulator killed (kill -9) during a move (issue 17: noticed only when the statement
// ended, 1.75 s later, the robot finishing its move unmirrored): the hub sees the link end,
// stops the robot at once and the move fails saying why; once a simulator is back on the
// port the next move works and ends where planned.
TEST(Faults, SimulatorKilledMidMoveTheRobotStopsAndTheNextMoveWorks) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("simkill")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  auto move = rig.cli({"movej", "0.02", "0", "0", "0"}, "move.log");
  ASSERT_TRUE(move);
  ASSERT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 3000; }, 60s))
      << tail_of(*move);
  const std::int64_t z_killed = side.truth("z");
  ASSERT_EQ(::kill(rig.sim->pid(), SIGKILL), 0);
  EXPECT_EQ(move->wait_exit(30s), 1) << tail_of(*move);
  const std::string out = tail_of(*move);
  EXPECT_NE(out.find("the simulator link was lost during a move: stopping the robot"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("the virtual robot no longer follows); the robot was stopped"),
            std::string::npos)
      << out;
  EXPECT_TRUE(side.at_rest()) << "the robot stopped";
  const std::int64_t z_stopped = side.truth("z");
  fmt::print("simulator killed at Z {} steps; the robot came to rest at {} ({} steps on)\n",
             z_killed, z_stopped, z_killed - z_stopped);
  // Z runs at most 5,000 steps/s: 200 ms are at most 1,000 steps (the robot's own clock)
  EXPECT_LT(z_killed - z_stopped, 1000)
      << "stopped " << z_killed - z_stopped << " steps after the simulator died";
  EXPECT_GT(z_stopped, 4111 + 5000) << "stopped on the way, not at the end of the move";
  // a simulator back on the same port: the next move works
  auto sim = ChildProcess::start(kBin / "scaratwin-sim",
                                 {"--port", rig.sim_port, "--http-port", "0", "--no-camera"},
                                 rig.dir / "sim2.log");
  ASSERT_TRUE(sim) << sim.error().message;
  ASSERT_EQ(sim_port_of(**sim), rig.sim_port);
  rig.sim = std::move(*sim);
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
}

// The simulator killed and restarted during `mirror` (issue 17: a takeover during mirror was
// reported as "795 frames mirrored, 0 lost"): the hub reconnects by itself, says so, mirrors
// on into the new simulator, and the statement reports the frames lost and the interruption.
TEST(Faults, SimulatorRestartDuringMirrorIsReportedAsLossAndMirroringResumes) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("simback")));
  auto mirror = rig.cli({"mirror", "--seconds", "8"}, "mirror.log");
  ASSERT_TRUE(mirror);
  std::this_thread::sleep_for(3s);
  ASSERT_EQ(::kill(rig.sim->pid(), SIGKILL), 0);
  (void)rig.sim->wait_exit(10s);
  std::this_thread::sleep_for(1s);
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim",
      {"--port", rig.sim_port, "--http-port", "0", "--no-camera", "--status", "1"},
      rig.dir / "sim2.log");
  ASSERT_TRUE(sim) << sim.error().message;
  ASSERT_EQ(sim_port_of(**sim), rig.sim_port);
  EXPECT_EQ(mirror->wait_exit(60s), 0) << tail_of(*mirror);
  const std::string out = tail_of(*mirror);
  EXPECT_NE(out.find("the simulator link was lost; reconnecting"), std::string::npos) << out;
  EXPECT_NE(out.find("the simulator link is back"), std::string::npos) << out;
  EXPECT_NE(out.find("interrupted: the simulator link was lost 1 time and came back"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find(", 0 lost"), std::string::npos) << out;
  EXPECT_NE(out.find("frames not applied by the simulator"), std::string::npos) << out;
  // the new simulator received the mirror's frames (its status line counts the packets: at
  // 100 reports a second, a few hundred in the 3 s left)
  const std::string sim_log = (*sim)->output_tail(40);
  const size_t at = sim_log.rfind("packets ");
  ASSERT_NE(at, std::string::npos) << sim_log;
  EXPECT_GT(std::stoll(sim_log.substr(at + 8)), 50) << sim_log;
}

// Resumes a stopped process when the test ends, whatever happened.
struct Resume {
  pid_t pid;
  ~Resume() { ::kill(pid, SIGCONT); }
};

// The simulator hangs with its socket open (SIGSTOP) during a move: no end of stream comes,
// but the heartbeat finds it silent within about a second; the hub stops the robot at once
// and the move fails saying why. Without the heartbeat (ChannelOptions::heartbeat 0 in the
// hub) this fails: the move runs to its end unmirrored and exits 0.
TEST(Faults, SimulatorHungMidMoveTheRobotStopsAndTheNextMoveWorksWhenItResumes) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("simhang")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  auto move = rig.cli({"movej", "0.02", "0", "0", "0"}, "move.log");
  ASSERT_TRUE(move);
  ASSERT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 3000; }, 60s))
      << tail_of(*move);
  const std::int64_t z_hung = side.truth("z");
  ASSERT_EQ(::kill(rig.sim->pid(), SIGSTOP), 0);
  Resume resume{rig.sim->pid()};
  EXPECT_EQ(move->wait_exit(30s), 1) << tail_of(*move);
  const std::string out = tail_of(*move);
  EXPECT_NE(out.find("the simulator stopped answering (no reply to "), std::string::npos) << out;
  EXPECT_NE(out.find("during a move: stopping the robot"), std::string::npos) << out;
  EXPECT_NE(out.find("the simulator stopped answering (the virtual robot no longer follows); "
                     "the robot was stopped"),
            std::string::npos)
      << out;
  EXPECT_TRUE(side.at_rest()) << "the robot stopped";
  const std::int64_t z_stopped = side.truth("z");
  fmt::print("simulator stopped at Z {} steps; the robot came to rest at {} ({} steps on)\n",
             z_hung, z_stopped, z_hung - z_stopped);
  // Z runs at most 5,000 steps/s (the robot's own clock): 1.5 s are at most 7,500 steps
  EXPECT_LT(z_hung - z_stopped, 7500)
      << "stopped " << z_hung - z_stopped << " steps after the simulator hung";
  EXPECT_GT(z_stopped, 4111 + 2000) << "stopped on the way, not at the end of the move";
  // the simulator resumes: the next move works with it
  ASSERT_EQ(::kill(rig.sim->pid(), SIGCONT), 0);
  ASSERT_NO_FATAL_FAILURE(expect_next_move_works(rig, side));
}

// The simulator hangs (SIGSTOP) for 3 s during `mirror` and resumes: the hub says it stopped
// answering, drops and retries the connection (the hung simulator's kernel still accepts
// them), is back once the simulator answers again, and the statement reports the loss.
TEST(Faults, SimulatorHungDuringMirrorIsReportedAndTheLinkComesBackWhenItResumes) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("simhangm")));
  auto mirror = rig.cli({"mirror", "--seconds", "8"}, "mirror.log");
  ASSERT_TRUE(mirror);
  std::this_thread::sleep_for(2s);
  ASSERT_EQ(::kill(rig.sim->pid(), SIGSTOP), 0);
  Resume resume{rig.sim->pid()};
  std::this_thread::sleep_for(3s);
  ASSERT_EQ(::kill(rig.sim->pid(), SIGCONT), 0);
  EXPECT_EQ(mirror->wait_exit(60s), 0) << tail_of(*mirror);
  const std::string out = tail_of(*mirror);
  EXPECT_NE(out.find("the simulator stopped answering (no reply to "), std::string::npos) << out;
  EXPECT_NE(out.find("the simulator link is back"), std::string::npos) << out;
  EXPECT_LT(out.find("stopped answering"), out.find("link is back")) << out;
  EXPECT_NE(out.find("interrupted: the simulator link was lost 1 time and came back"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("frames not applied by the simulator"), std::string::npos) << out;
}

// The emulated robot stalls (SIGSTOP, 0.4 s) mid-move, its clock with it, as an emulator on a
// busy host does: the hub says the robot is silent, tells by the robot's clock that it
// stalled rather than the link being cut, and the move goes on to its end (a watchdog that
// took every silence for a cut aborted healthy moves on a loaded machine). With the stall
// taken for a cut (the verdict inverted) this fails: the move ends with exit 1.
TEST(Faults, RobotStalledMidMoveIsToldFromACutAndTheMoveGoesOn) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("stall")));
  Side side(rig.side_port);
  ASSERT_EQ(rig.run({"home"}, "home.log"), 0);
  auto move = rig.cli({"movej", "0.02", "0", "0", "0"}, "move.log");
  ASSERT_TRUE(move);
  ASSERT_TRUE(side.wait(
      "z", [](std::int64_t z) { return z < kHomeZ - 3000; }, 60s))
      << tail_of(*move);
  const std::uint64_t sim_before = static_cast<std::uint64_t>(side.truth("sim_us"));
  ASSERT_EQ(::kill(rig.robot->pid(), SIGSTOP), 0);
  {
    Resume resume{rig.robot->pid()};
    std::this_thread::sleep_for(400ms);
  }
  EXPECT_EQ(move->wait_exit(60s), 0) << tail_of(*move);
  const std::string out = tail_of(*move);
  EXPECT_NE(out.find("no state report from the robot for "), std::string::npos) << out;
  EXPECT_NE(out.find("its own clock stood still as long"), std::string::npos) << out;
  EXPECT_NE(out.find("the robot stalled, not the link"), std::string::npos) << out;
  EXPECT_EQ(out.find("was cut"), std::string::npos) << out;
  // the truth: the robot went on to the end of the move, and its clock ran on afterwards
  EXPECT_TRUE(side.at_rest());
  EXPECT_NEAR(static_cast<double>(side.truth("z")), 0.02 * 205560.0, 200.0);
  EXPECT_GT(static_cast<std::uint64_t>(side.truth("sim_us")), sim_before);
}

// CPU seconds (user + system) the process has used so far.
double cpu_seconds(pid_t pid) {
  std::ifstream in(fmt::format("/proc/{}/stat", pid));
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream rest(stat.substr(stat.rfind(')') + 2));
  std::string field;
  long long utime = 0, stime = 0;
  // after the name: state (3) ... utime (14), stime (15)
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stoll(field);
    if (i == 15) stime = std::stoll(field);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

std::size_t count_of(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto p = text.find(needle); p != std::string::npos; p = text.find(needle, p + 1)) ++n;
  return n;
}

// The simulator out of file descriptors (browsers that keep their connections open, under a
// low RLIMIT_NOFILE): its web server's accept loop used to retry at once and spin (56 % CPU,
// the TCP port no longer answering). Now it waits between attempts and logs once, the hub's
// TCP link keeps being served, and the page is served again once descriptors free up.
TEST(Faults, SimulatorKeepsServingWhenItRunsOutOfFileDescriptors) {
  const fs::path dir = fresh_dir("emfile");
  const int http_port = free_port();
  auto sim = ChildProcess::start(
      "/bin/sh",
      {"-c", "ulimit -n 96 && exec \"$0\" \"$@\"", (kBin / "scaratwin-sim").string(), "--port", "0",
       "--http-port", std::to_string(http_port), "--no-camera"},
      dir / "sim.log");
  ASSERT_TRUE(sim) << sim.error().message;
  auto listening = (*sim)->wait_for_line("listening on", 60s);
  ASSERT_TRUE(listening) << listening.error().message;
  ASSERT_TRUE((*sim)->wait_for_line("browser UI on", 10s));
  const size_t paren = listening->find(" (");
  const size_t colon = listening->rfind(':', paren);
  const int sim_port = std::stoi(listening->substr(colon + 1, paren - colon - 1));
  // the hub's link, connected while there are descriptors
  const int link = connect_loopback(sim_port);
  ASSERT_GE(link, 0);
  ASSERT_EQ(::send(link, "HI,1,\n", 6, 0), 6);
  ASSERT_NE(read_until(link, "\n", 5000ms).find("HI,1,"), std::string::npos);
  const pid_t pid = (*sim)->pid();
  const double idle_cpu = cpu_seconds(pid);
  std::this_thread::sleep_for(2s);
  const double idle_cpu_s = cpu_seconds(pid) - idle_cpu;
  // browsers that keep their connections open until the simulator has no descriptor left
  const std::string get = "GET / HTTP/1.1\r\nHost: x\r\n\r\n";
  std::vector<int> open;
  int pending = -1;
  for (int i = 0; i < 200 && pending < 0; ++i) {
    const int fd = connect_loopback(http_port);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::send(fd, get.data(), get.size(), 0), static_cast<ssize_t>(get.size()));
    if (read_until(fd, "\r\n\r\n", 1000ms).empty()) {
      pending = fd;  // left in the listen queue: accept failed
    } else {
      open.push_back(fd);
    }
  }
  ASSERT_GE(pending, 0) << "the descriptors never ran out";
  const double busy_cpu = cpu_seconds(pid);
  std::this_thread::sleep_for(2s);
  const double busy_cpu_s = cpu_seconds(pid) - busy_cpu;
  EXPECT_LT(busy_cpu_s, idle_cpu_s + 0.4)
      << "CPU over 2 s: " << busy_cpu_s << " s out of descriptors, " << idle_cpu_s << " s before";
  // the hub's link is served meanwhile
  ASSERT_EQ(::send(link, "PI,5,\n", 6, 0), 6);
  EXPECT_NE(read_until(link, "AK,PI,5,", 2000ms).find("AK,PI,5,"), std::string::npos);
  // descriptors free: the waiting browser is served
  for (const int fd : open) ::close(fd);
  EXPECT_NE(read_until(pending, "\r\n\r\n", 5000ms).find("HTTP/1.1"), std::string::npos)
      << "the waiting connection was never served";
  ::close(pending);
  ::close(link);
  // the simulator says so before it serves the connection; its output reaches this process
  // through a reader thread, which may not have taken the line yet (it had not, under TSan)
  EXPECT_TRUE((*sim)->wait_for_line("accepting connections again", 5s));
  const std::string log = (*sim)->output_tail(200);
  EXPECT_EQ(count_of(log, "cannot accept a connection"), 1u) << log;
  EXPECT_EQ(count_of(log, "accepting connections again"), 1u) << log;
  fmt::print("CPU over 2 s: {:.2f} s before, {:.2f} s out of descriptors ({} connections)\n",
             idle_cpu_s, busy_cpu_s, open.size());
}

// An unknown subcommand is named, with the usage exit status (it said "A subcommand is
// required", and exited 0 with --help).
TEST(Cli, UnknownSubcommandIsNamed) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"calibrat"}, std::vector<std::string>{"calibrat", "--help"}}) {
    auto p = ChildProcess::start(kBin / "scaratwin", args);
    ASSERT_TRUE(p) << p.error().message;
    const int status = (*p)->wait_exit(30s);
    const std::string out = (*p)->output_tail(10);
    EXPECT_EQ(status, 2) << out;
    EXPECT_NE(out.find("calibrat"), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace scaratwin
