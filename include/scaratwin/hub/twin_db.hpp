// The twin database: one SQLite file (WAL mode) that keeps everything a twin run produces, so
// that nothing recorded is lost when a run fails half way and reports can be made afterwards:
// runs, joint samples (planned, virtual, physical and the emulator's ground truth), commands
// sent on each link, events, per-frame mirror latencies, camera images and final metrics.
//
// Times are seconds since the run started (t_s) unless a column says _us. Joint values are SI
// (m, rad). Writes are batched: call flush() (or let the destructor do it) to commit.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

struct sqlite3;
struct sqlite3_stmt;

namespace scaratwin {

// Where a joint sample comes from.
enum class SampleSource { kPlanned, kVirtual, kPhysical, kTruth };
const char* source_name(SampleSource s);

struct JointRecord {
  double t_s = 0.0;
  int64_t seq = -1;  // device sequence number when known
  JointVector q{};
  double grip_deg = 0.0;
};

// One mirror frame: the robot's sample time, the hub's receive time and the simulator's apply
// time, all in microseconds of the same (monotonic) clock of this machine except the device's
// own timestamp, which is kept as sent.
struct LatencyRecord {
  int64_t seq = 0;
  int64_t device_t_us = 0;
  int64_t hub_rx_us = 0;
  int64_t sim_apply_us = 0;
};

struct RunInfo {
  int64_t id = 0;
  int64_t parent = 0;
  int64_t ref = 0;
  std::string kind;  // mirror, control, prediction, replay, script, demo
  std::string label;
  std::string status;  // running, ok, failed, aborted (its process died while it ran)
  double started_unix_s = 0.0;
  double duration_s = 0.0;
};

struct MetricRecord {
  std::string name;
  double value = 0.0;
  std::string unit;
};

struct EventRecord {
  double t_s = 0.0;
  std::string kind;
  std::string detail;
};

struct CommandRecord {
  double t_s = 0.0;
  std::string link;  // the link it was sent on
  std::string text;
};

struct ImageRecord {
  double t_s = 0.0;
  std::string name;
  std::string png;  // the PNG file's bytes
};

// Safe to share between threads: every public member holds the database's own lock (a hub
// records from its I/O thread while a command reads figures from the same database).
class TwinDb {
 public:
  // Opens or creates the database file (and its tables). A run left 'running' by a process
  // of this machine that no longer exists (killed mid-run) is marked 'aborted'.
  static Result<std::unique_ptr<TwinDb>> open(const std::filesystem::path& path);
  ~TwinDb();
  TwinDb(const TwinDb&) = delete;
  TwinDb& operator=(const TwinDb&) = delete;

  // Starts a run; returns its id. `parent` is the session it belongs to (a demo; 0 = none) and
  // `ref` the run it is compared with (a replay's prediction; 0 = none).
  Result<int64_t> begin_run(std::string_view kind, std::string_view label, int64_t parent = 0,
                            int64_t ref = 0);
  Status end_run(int64_t run, std::string_view status, double duration_s);

  Status add_sample(int64_t run, SampleSource source, const JointRecord& r);
  Status add_command(int64_t run, double t_s, std::string_view link, std::string_view text);
  Status add_event(int64_t run, double t_s, std::string_view kind, std::string_view detail);
  Status add_latency(int64_t run, const LatencyRecord& r);
  Status add_image(int64_t run, double t_s, std::string_view name, const std::string& png);
  Status add_metric(int64_t run, std::string_view name, double value, std::string_view unit);

  // Commits the pending batch.
  Status flush();

  // Reading back (for reports, exports and tests).
  Result<std::vector<RunInfo>> runs();
  Result<RunInfo> run(int64_t id);
  Result<std::vector<JointRecord>> samples(int64_t run, SampleSource source);
  Result<std::vector<LatencyRecord>> latencies(int64_t run);
  Result<std::vector<MetricRecord>> metrics(int64_t run);
  Result<std::vector<std::pair<double, std::string>>> events(int64_t run);
  Result<std::vector<EventRecord>> event_records(int64_t run);
  Result<std::vector<CommandRecord>> commands(int64_t run);
  Result<std::vector<ImageRecord>> images(int64_t run);
  Result<std::vector<RunInfo>> children(int64_t parent);
  Result<int64_t> count(std::string_view table, int64_t run);

  // Writes every table of one run as CSV files into `dir` (samples.csv, latencies.csv, ...).
  Status export_csv(int64_t run, const std::filesystem::path& dir);

  const std::filesystem::path& path() const { return path_; }

 private:
  TwinDb(sqlite3* db, std::filesystem::path path);
  Status exec(const char* sql);
  Status mark_aborted_runs();
  Status begin_batch();
  Result<sqlite3_stmt*> prepare(const char* sql);

  std::recursive_mutex mu_;  // guards everything below (public members may call each other)
  sqlite3* db_;
  std::filesystem::path path_;
  std::map<const char*, sqlite3_stmt*> statements_;  // prepared once, by their literal
  bool in_batch_ = false;
  int pending_ = 0;
};

}  // namespace scaratwin
