#include "scaratwin/hub/twin_db.hpp"

#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include <fmt/format.h>

namespace scaratwin {
namespace {

constexpr int kDbError = error_code(DbError::kSqlite);
constexpr int kAutoCommitRows = 2000;

constexpr const char* kSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = NORMAL;
CREATE TABLE IF NOT EXISTS runs (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  parent INTEGER NOT NULL DEFAULT 0,
  ref INTEGER NOT NULL DEFAULT 0,
  kind TEXT NOT NULL,
  label TEXT NOT NULL,
  status TEXT NOT NULL DEFAULT 'running',
  started_unix_s REAL NOT NULL,
  duration_s REAL NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS samples (
  run INTEGER NOT NULL, source TEXT NOT NULL, t_s REAL NOT NULL, seq INTEGER,
  d1_m REAL, q2_rad REAL, q3_rad REAL, q4_rad REAL, grip_deg REAL
);
CREATE INDEX IF NOT EXISTS samples_run ON samples (run, source, t_s);
CREATE TABLE IF NOT EXISTS commands (
  run INTEGER NOT NULL, t_s REAL NOT NULL, link TEXT NOT NULL, text TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS events (
  run INTEGER NOT NULL, t_s REAL NOT NULL, kind TEXT NOT NULL, detail TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS latencies (
  run INTEGER NOT NULL, seq INTEGER NOT NULL, device_t_us INTEGER, hub_rx_us INTEGER,
  sim_apply_us INTEGER
);
CREATE TABLE IF NOT EXISTS images (
  run INTEGER NOT NULL, t_s REAL NOT NULL, name TEXT NOT NULL, png BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS metrics (
  run INTEGER NOT NULL, name TEXT NOT NULL, value REAL NOT NULL, unit TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS run_owners (
  run INTEGER PRIMARY KEY, host TEXT NOT NULL, pid INTEGER NOT NULL, started TEXT NOT NULL
);
)sql";

// The start time of process `pid` (field 22 of /proc/PID/stat, clock ticks since boot), or ""
// when there is no such process: with the pid it names one process, even after the pid is
// reused.
std::string process_start(long pid) {
  std::ifstream in(fmt::format("/proc/{}/stat", pid));
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t paren = stat.rfind(')');
  if (paren == std::string::npos) return {};
  std::istringstream rest(stat.substr(paren + 2));
  std::string field;
  for (int i = 3; i <= 22 && rest >> field; ++i) {
    if (i == 22) return field;
  }
  return {};
}

std::string host_name() {
  char name[256] = {0};
  if (::gethostname(name, sizeof name - 1) != 0) return "?";
  return name;
}

Error db_error(sqlite3* db, std::string_view what) {
  return Error{kDbError, fmt::format("database: {}: {}", what, sqlite3_errmsg(db))};
}

Status step_done(sqlite3* db, sqlite3_stmt* s, std::string_view what) {
  if (sqlite3_step(s) != SQLITE_DONE) return db_error(db, what);
  return Ok{};
}

void bind_text(sqlite3_stmt* s, int i, std::string_view v) {
  sqlite3_bind_text(s, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
}

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string csv_escape(std::string_view v) {
  if (v.find_first_of(",\"\n") == std::string_view::npos) return std::string(v);
  std::string out = "\"";
  for (char c : v) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

const char* source_name(SampleSource s) {
  switch (s) {
    case SampleSource::kPlanned:
      return "planned";
    case SampleSource::kVirtual:
      return "virtual";
    case SampleSource::kPhysical:
      return "physical";
    case SampleSource::kTruth:
      return "truth";
  }
  return "?";
}

TwinDb::TwinDb(sqlite3* db, std::filesystem::path path) : db_(db), path_(std::move(path)) {}

TwinDb::~TwinDb() {
  (void)flush();
  for (auto& [sql, s] : statements_) sqlite3_finalize(s);
  sqlite3_close(db_);
}

Result<std::unique_ptr<TwinDb>> TwinDb::open(const std::filesystem::path& path) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) {
    Error e{kDbError, fmt::format("cannot open database '{}': {}", path.string(),
                                  db ? sqlite3_errmsg(db) : "out of memory")};
    sqlite3_close(db);
    return e;
  }
  sqlite3_busy_timeout(db, 2000);
  std::unique_ptr<TwinDb> out(new TwinDb(db, path));
  if (Status s = out->exec(kSchema); !s) return s.error();
  if (Status s = out->mark_aborted_runs(); !s) return s.error();
  return out;
}

// A run still 'running' whose recording process on this machine is gone (killed, crashed)
// becomes 'aborted': what it recorded stays, its status no longer claims it goes on. Runs of
// live processes, of other machines, and of databases written before run_owners existed are
// left as they are.
Status TwinDb::mark_aborted_runs() {
  auto s = prepare(
      "SELECT r.id, o.pid, o.started FROM runs r JOIN run_owners o ON o.run = r.id "
      "WHERE r.status = 'running' AND o.host = ?");
  if (!s) return s.error();
  const std::string host = host_name();
  bind_text(*s, 1, host);
  std::vector<int64_t> dead;
  int rc;
  while ((rc = sqlite3_step(*s)) == SQLITE_ROW) {
    const long pid = static_cast<long>(sqlite3_column_int64(*s, 1));
    const auto* started = reinterpret_cast<const char*>(sqlite3_column_text(*s, 2));
    if (process_start(pid) != (started ? started : "")) dead.push_back(sqlite3_column_int64(*s, 0));
  }
  if (rc != SQLITE_DONE) return db_error(db_, "find unfinished runs");
  for (int64_t run : dead) {
    auto u = prepare("UPDATE runs SET status = 'aborted' WHERE id = ? AND status = 'running'");
    if (!u) return u.error();
    sqlite3_bind_int64(*u, 1, run);
    if (Status st = step_done(db_, *u, "mark an aborted run"); !st) return st;
  }
  return Ok{};
}

Status TwinDb::exec(const char* sql) {
  char* msg = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &msg) != SQLITE_OK) {
    Error e{kDbError, fmt::format("database '{}': {}", path_.string(), msg ? msg : "?")};
    sqlite3_free(msg);
    return e;
  }
  return Ok{};
}

Result<sqlite3_stmt*> TwinDb::prepare(const char* sql) {
  if (auto it = statements_.find(sql); it != statements_.end()) {
    sqlite3_reset(it->second);
    sqlite3_clear_bindings(it->second);
    return it->second;
  }
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v3(db_, sql, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) != SQLITE_OK) {
    return db_error(db_, "prepare");
  }
  statements_[sql] = s;
  return s;
}

Status TwinDb::begin_batch() {
  if (in_batch_) {
    if (++pending_ < kAutoCommitRows) return Ok{};
    if (Status s = flush(); !s) return s;
  }
  if (Status s = exec("BEGIN"); !s) return s;
  in_batch_ = true;
  pending_ = 1;
  return Ok{};
}

Status TwinDb::flush() {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (!in_batch_) return Ok{};
  in_batch_ = false;
  pending_ = 0;
  return exec("COMMIT");
}

Result<int64_t> TwinDb::begin_run(std::string_view kind, std::string_view label, int64_t parent,
                                  int64_t ref) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s =
      prepare("INSERT INTO runs (parent, ref, kind, label, started_unix_s) VALUES (?, ?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, parent);
  sqlite3_bind_int64(*s, 2, ref);
  bind_text(*s, 3, kind);
  bind_text(*s, 4, label);
  sqlite3_bind_double(*s, 5, unix_now_s());
  if (Status st = step_done(db_, *s, "begin run"); !st) return st.error();
  const auto run = static_cast<int64_t>(sqlite3_last_insert_rowid(db_));
  // who records it: a later open marks it aborted if this process dies before end_run()
  auto o =
      prepare("INSERT OR REPLACE INTO run_owners (run, host, pid, started) VALUES (?, ?, ?, ?)");
  if (!o) return o.error();
  sqlite3_bind_int64(*o, 1, run);
  bind_text(*o, 2, host_name());
  sqlite3_bind_int64(*o, 3, static_cast<int64_t>(::getpid()));
  bind_text(*o, 4, process_start(static_cast<long>(::getpid())));
  if (Status st = step_done(db_, *o, "begin run"); !st) return st.error();
  return run;
}

Status TwinDb::end_run(int64_t run, std::string_view status, double duration_s) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f;
  auto s = prepare("UPDATE runs SET status = ?, duration_s = ? WHERE id = ?");
  if (!s) return s.error();
  bind_text(*s, 1, status);
  sqlite3_bind_double(*s, 2, duration_s);
  sqlite3_bind_int64(*s, 3, run);
  return step_done(db_, *s, "end run");
}

Status TwinDb::add_sample(int64_t run, SampleSource source, const JointRecord& r) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare(
      "INSERT INTO samples (run, source, t_s, seq, d1_m, q2_rad, q3_rad, q4_rad, grip_deg) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  bind_text(*s, 2, source_name(source));
  sqlite3_bind_double(*s, 3, r.t_s);
  if (r.seq >= 0) sqlite3_bind_int64(*s, 4, r.seq);
  for (int j = 0; j < kNumJoints; ++j) sqlite3_bind_double(*s, 5 + j, r.q[j]);
  sqlite3_bind_double(*s, 9, r.grip_deg);
  return step_done(db_, *s, "add sample");
}

Status TwinDb::add_command(int64_t run, double t_s, std::string_view link, std::string_view text) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare("INSERT INTO commands (run, t_s, link, text) VALUES (?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  sqlite3_bind_double(*s, 2, t_s);
  bind_text(*s, 3, link);
  bind_text(*s, 4, text);
  return step_done(db_, *s, "add command");
}

Status TwinDb::add_event(int64_t run, double t_s, std::string_view kind, std::string_view detail) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare("INSERT INTO events (run, t_s, kind, detail) VALUES (?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  sqlite3_bind_double(*s, 2, t_s);
  bind_text(*s, 3, kind);
  bind_text(*s, 4, detail);
  return step_done(db_, *s, "add event");
}

Status TwinDb::add_latency(int64_t run, const LatencyRecord& r) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare(
      "INSERT INTO latencies (run, seq, device_t_us, hub_rx_us, sim_apply_us) "
      "VALUES (?, ?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  sqlite3_bind_int64(*s, 2, r.seq);
  sqlite3_bind_int64(*s, 3, r.device_t_us);
  sqlite3_bind_int64(*s, 4, r.hub_rx_us);
  sqlite3_bind_int64(*s, 5, r.sim_apply_us);
  return step_done(db_, *s, "add latency");
}

Status TwinDb::add_image(int64_t run, double t_s, std::string_view name, const std::string& png) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare("INSERT INTO images (run, t_s, name, png) VALUES (?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  sqlite3_bind_double(*s, 2, t_s);
  bind_text(*s, 3, name);
  sqlite3_bind_blob(*s, 4, png.data(), static_cast<int>(png.size()), SQLITE_TRANSIENT);
  return step_done(db_, *s, "add image");
}

Status TwinDb::add_metric(int64_t run, std::string_view name, double value, std::string_view unit) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status b = begin_batch(); !b) return b;
  auto s = prepare("INSERT INTO metrics (run, name, value, unit) VALUES (?, ?, ?, ?)");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  bind_text(*s, 2, name);
  sqlite3_bind_double(*s, 3, value);
  bind_text(*s, 4, unit);
  return step_done(db_, *s, "add metric");
}

namespace {

std::string column_text(sqlite3_stmt* s, int i) {
  const unsigned char* t = sqlite3_column_text(s, i);
  return t ? reinterpret_cast<const char*>(t) : "";
}

RunInfo read_run(sqlite3_stmt* s) {
  RunInfo r;
  r.id = sqlite3_column_int64(s, 0);
  r.kind = column_text(s, 1);
  r.label = column_text(s, 2);
  r.status = column_text(s, 3);
  r.started_unix_s = sqlite3_column_double(s, 4);
  r.duration_s = sqlite3_column_double(s, 5);
  r.parent = sqlite3_column_int64(s, 6);
  r.ref = sqlite3_column_int64(s, 7);
  return r;
}

}  // namespace

Result<std::vector<RunInfo>> TwinDb::runs() {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare(
      "SELECT id, kind, label, status, started_unix_s, duration_s, parent, ref "
      "FROM runs ORDER BY id");
  if (!s) return s.error();
  std::vector<RunInfo> out;
  while (sqlite3_step(*s) == SQLITE_ROW) out.push_back(read_run(*s));
  return out;
}

Result<RunInfo> TwinDb::run(int64_t id) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare(
      "SELECT id, kind, label, status, started_unix_s, duration_s, parent, ref "
      "FROM runs WHERE id = ?");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, id);
  if (sqlite3_step(*s) != SQLITE_ROW) {
    return Error{DbError::kNoRun, fmt::format("no run {} in '{}'", id, path_.string())};
  }
  return read_run(*s);
}

Result<std::vector<RunInfo>> TwinDb::children(int64_t parent) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare(
      "SELECT id, kind, label, status, started_unix_s, duration_s, parent, ref "
      "FROM runs WHERE parent = ? ORDER BY id");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, parent);
  std::vector<RunInfo> out;
  while (sqlite3_step(*s) == SQLITE_ROW) out.push_back(read_run(*s));
  return out;
}

Result<std::vector<JointRecord>> TwinDb::samples(int64_t run, SampleSource source) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare(
      "SELECT t_s, seq, d1_m, q2_rad, q3_rad, q4_rad, grip_deg FROM samples "
      "WHERE run = ? AND source = ? ORDER BY t_s");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  bind_text(*s, 2, source_name(source));
  std::vector<JointRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    JointRecord r;
    r.t_s = sqlite3_column_double(*s, 0);
    r.seq = sqlite3_column_type(*s, 1) == SQLITE_NULL ? -1 : sqlite3_column_int64(*s, 1);
    for (int j = 0; j < kNumJoints; ++j) r.q[j] = sqlite3_column_double(*s, 2 + j);
    r.grip_deg = sqlite3_column_double(*s, 6);
    out.push_back(r);
  }
  return out;
}

Result<std::vector<LatencyRecord>> TwinDb::latencies(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare(
      "SELECT seq, device_t_us, hub_rx_us, sim_apply_us FROM latencies "
      "WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<LatencyRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    out.push_back({sqlite3_column_int64(*s, 0), sqlite3_column_int64(*s, 1),
                   sqlite3_column_int64(*s, 2), sqlite3_column_int64(*s, 3)});
  }
  return out;
}

Result<std::vector<MetricRecord>> TwinDb::metrics(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare("SELECT name, value, unit FROM metrics WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<MetricRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    out.push_back({column_text(*s, 0), sqlite3_column_double(*s, 1), column_text(*s, 2)});
  }
  return out;
}

Result<std::vector<std::pair<double, std::string>>> TwinDb::events(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare("SELECT t_s, kind, detail FROM events WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<std::pair<double, std::string>> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    out.emplace_back(sqlite3_column_double(*s, 0), column_text(*s, 1) + ": " + column_text(*s, 2));
  }
  return out;
}

Result<std::vector<EventRecord>> TwinDb::event_records(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare("SELECT t_s, kind, detail FROM events WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<EventRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    out.push_back({sqlite3_column_double(*s, 0), column_text(*s, 1), column_text(*s, 2)});
  }
  return out;
}

Result<std::vector<CommandRecord>> TwinDb::commands(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare("SELECT t_s, link, text FROM commands WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<CommandRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    out.push_back({sqlite3_column_double(*s, 0), column_text(*s, 1), column_text(*s, 2)});
  }
  return out;
}

Result<std::vector<ImageRecord>> TwinDb::images(int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f.error();
  auto s = prepare("SELECT t_s, name, png FROM images WHERE run = ? ORDER BY rowid");
  if (!s) return s.error();
  sqlite3_bind_int64(*s, 1, run);
  std::vector<ImageRecord> out;
  while (sqlite3_step(*s) == SQLITE_ROW) {
    const auto* blob = static_cast<const char*>(sqlite3_column_blob(*s, 2));
    const int n = sqlite3_column_bytes(*s, 2);
    out.push_back(
        {sqlite3_column_double(*s, 0), column_text(*s, 1),
         blob == nullptr ? std::string{} : std::string(blob, static_cast<std::size_t>(n))});
  }
  return out;
}

Result<int64_t> TwinDb::count(std::string_view table, int64_t run) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  static constexpr std::string_view kTables[] = {"samples",   "commands", "events",
                                                 "latencies", "images",   "metrics"};
  if (std::find(std::begin(kTables), std::end(kTables), table) == std::end(kTables)) {
    return Error{DbError::kNoTable, fmt::format("no table '{}'", table)};
  }
  if (Status f = flush(); !f) return f.error();
  const std::string sql = fmt::format("SELECT COUNT(*) FROM {} WHERE run = {}", table, run);
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
    return db_error(db_, "count");
  }
  int64_t n = 0;
  if (sqlite3_step(s) == SQLITE_ROW) n = sqlite3_column_int64(s, 0);
  sqlite3_finalize(s);
  return n;
}

Status TwinDb::export_csv(int64_t run, const std::filesystem::path& dir) {
  std::lock_guard<std::recursive_mutex> lock(mu_);
  if (Status f = flush(); !f) return f;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    return Error{DbError::kWriteFailed,
                 fmt::format("cannot create '{}': {}", dir.string(), ec.message())};
  struct Table {
    const char* file;
    const char* sql;
  };
  static constexpr Table kTables[] = {
      {"samples.csv",
       "SELECT source, t_s, seq, d1_m, q2_rad, q3_rad, q4_rad, grip_deg FROM samples WHERE run "
       "= ? ORDER BY source, t_s"},
      {"latencies.csv",
       "SELECT seq, device_t_us, hub_rx_us, sim_apply_us, sim_apply_us - hub_rx_us AS "
       "hub_to_sim_us FROM latencies WHERE run = ? ORDER BY rowid"},
      {"commands.csv", "SELECT t_s, link, text FROM commands WHERE run = ? ORDER BY rowid"},
      {"events.csv", "SELECT t_s, kind, detail FROM events WHERE run = ? ORDER BY rowid"},
      {"metrics.csv", "SELECT name, value, unit FROM metrics WHERE run = ? ORDER BY rowid"},
  };
  for (const Table& t : kTables) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db_, t.sql, -1, &s, nullptr) != SQLITE_OK) {
      return db_error(db_, "export");
    }
    sqlite3_bind_int64(s, 1, run);
    std::ofstream out(dir / t.file);
    const int n = sqlite3_column_count(s);
    for (int i = 0; i < n; ++i) out << (i ? "," : "") << sqlite3_column_name(s, i);
    out << '\n';
    while (sqlite3_step(s) == SQLITE_ROW) {
      for (int i = 0; i < n; ++i) {
        if (i) out << ',';
        switch (sqlite3_column_type(s, i)) {
          case SQLITE_NULL:
            break;
          case SQLITE_INTEGER:
            out << sqlite3_column_int64(s, i);
            break;
          case SQLITE_FLOAT:
            out << fmt::format("{:.17g}", sqlite3_column_double(s, i));
            break;
          default:
            out << csv_escape(column_text(s, i));
        }
      }
      out << '\n';
    }
    sqlite3_finalize(s);
    if (!out)
      return Error{DbError::kWriteFailed,
                   fmt::format("cannot write '{}'", (dir / t.file).string())};
  }
  return Ok{};
}

}  // namespace scaratwin
