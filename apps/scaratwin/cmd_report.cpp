// scaratwin report / runs / export: reading the twin database after the fact.
#include <cstdio>
#include <cstdlib>
#include <ctime>

#include <fmt/format.h>

#include "commands.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/export/run_mcap.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/hub/twin_db.hpp"

namespace scaratwin::cli {
namespace {

struct ReportArgs {
  std::string db_path = "scaratwin-out/twin.db";
  int64_t run = 0;
  std::string out;
  std::string csv_dir;
  std::string run_name = "latest";  // export: a run id or "latest"
  std::string mcap;
};

Result<std::unique_ptr<TwinDb>> open_existing(const std::string& path) {
  if (!std::filesystem::exists(path)) {
    return Error{DbError::kNotFound,
                 fmt::format("no database '{}' (run `scaratwin demo` first, or pass --db)", path)};
  }
  return TwinDb::open(path);
}

// The newest top-level run (a session, not one of its phases), or 0 after printing why not.
int64_t newest_run(TwinDb& db, const char* command) {
  auto runs = db.runs();
  int64_t run = 0;
  if (runs) {
    for (const RunInfo& r : *runs) {
      if (r.parent == 0) run = r.id;
    }
  }
  if (run == 0) {
    std::fprintf(stderr, "scaratwin %s: no runs in '%s'\n", command, db.path().c_str());
  }
  return run;
}

int run_report(const CommonOptions& common, const ReportArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  auto db = open_existing(a.db_path);
  if (!db) {
    std::fprintf(stderr, "scaratwin report: %s\n", db.error().message.c_str());
    return kExitUsage;
  }
  int64_t run = a.run;
  if (run == 0 && (run = newest_run(**db, "report")) == 0) return kExitUsage;
  const std::string out =
      a.out.empty() ? fmt::format("{}/report-{}.html",
                                  std::filesystem::path(a.db_path).parent_path().string(), run)
                    : a.out;
  if (Status s = write_report(**db, *model, run, out); !s) {
    std::fprintf(stderr, "scaratwin report: %s\n", s.error().message.c_str());
    return kExitFailure;
  }
  std::printf("report: %s\n", std::filesystem::absolute(out).c_str());
  if (!a.csv_dir.empty()) {
    if (Status s = (*db)->export_csv(run, a.csv_dir); !s) {
      std::fprintf(stderr, "scaratwin report: %s\n", s.error().message.c_str());
      return kExitFailure;
    }
    // a session's runs (a demo's phases) each get a folder.
    if (auto kids = (*db)->children(run); kids) {
      for (const RunInfo& r : *kids) {
        const auto dir = std::filesystem::path(a.csv_dir) / fmt::format("{}-{}", r.id, r.kind);
        if (Status s = (*db)->export_csv(r.id, dir); !s) {
          std::fprintf(stderr, "scaratwin report: %s\n", s.error().message.c_str());
          return kExitFailure;
        }
      }
    }
    std::printf("csv: %s\n", std::filesystem::absolute(a.csv_dir).c_str());
  }
  return kExitOk;
}

int run_export(const CommonOptions& common, const ReportArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  auto db = open_existing(a.db_path);
  if (!db) {
    std::fprintf(stderr, "scaratwin export: %s\n", db.error().message.c_str());
    return kExitUsage;
  }
  int64_t run = 0;
  if (a.run_name == "latest") {
    if ((run = newest_run(**db, "export")) == 0) return kExitUsage;
  } else {
    char* end = nullptr;
    run = std::strtoll(a.run_name.c_str(), &end, 10);
    if (a.run_name.empty() || *end != '\0' || run <= 0) {
      std::fprintf(stderr,
                   "scaratwin export: RUN '%s' is neither a run id nor 'latest' (see `scaratwin "
                   "runs`)\n",
                   a.run_name.c_str());
      return kExitUsage;
    }
  }
  McapExportOptions options;
  options.description_file = common.config_path.empty() ? default_robot_config_path()
                                                        : std::filesystem::path(common.config_path);
  auto done = export_run_mcap(**db, *model, run, a.mcap, options);
  if (!done) {
    std::fprintf(stderr, "scaratwin export: %s\n", done.error().message.c_str());
    return done.error().code == error_code(DbError::kNoRun) ? kExitUsage : kExitFailure;
  }
  fmt::print("mcap: {} ({} runs, {} messages, {} chunks, {} bytes)\n",
             std::filesystem::absolute(a.mcap).string(), done->runs.size(), done->messages,
             done->chunks, done->bytes);
  for (const auto& [topic, n] : done->topic_messages) fmt::print("  {:<18} {:>8}\n", topic, n);
  return kExitOk;
}

int run_runs(const ReportArgs& a) {
  auto db = open_existing(a.db_path);
  if (!db) {
    std::fprintf(stderr, "scaratwin runs: %s\n", db.error().message.c_str());
    return kExitUsage;
  }
  auto runs = (*db)->runs();
  if (!runs) {
    std::fprintf(stderr, "scaratwin runs: %s\n", runs.error().message.c_str());
    return kExitFailure;
  }
  fmt::print("{:>5} {:>6} {:<11} {:<8} {:>9}  {:<20} {}\n", "run", "parent", "kind", "status",
             "seconds", "started (UTC)", "label");
  for (const RunInfo& r : *runs) {
    const std::time_t t = static_cast<std::time_t>(r.started_unix_s);
    char when[32];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::gmtime(&t));
    fmt::print("{:>5} {:>6} {:<11} {:<8} {:>9.1f}  {:<20} {}\n", r.id, r.parent, r.kind, r.status,
               r.duration_s, when, r.label);
  }
  return kExitOk;
}

}  // namespace

void add_report_commands(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<ReportArgs>();
  CLI::App* report = app.add_subcommand(
      "report", "write the HTML report (plots, figures beside the paper's) of a recorded run");
  report->add_option("run", a->run, "run id (default: the newest top-level run)");
  report->add_option("--db", a->db_path, "twin database")->capture_default_str();
  report->add_option("--out", a->out, "HTML file (default: beside the database)");
  report->add_option("--csv", a->csv_dir, "also export the run's tables as CSV into this folder");
  add_common_options(*report, common, false);
  report->callback([&common, &run, a] { run = [&common, a] { return run_report(common, *a); }; });

  CLI::App* exp = app.add_subcommand(
      "export", "write a recorded run (and its session's runs) as an MCAP file for Foxglove");
  exp->add_option("run", a->run_name, "run id, or 'latest' (the newest top-level run)")
      ->capture_default_str();
  exp->add_option("--mcap", a->mcap, "the MCAP file to write")->required();
  exp->add_option("--db", a->db_path, "twin database")->capture_default_str();
  add_common_options(*exp, common, false);
  exp->callback([&common, &run, a] { run = [&common, a] { return run_export(common, *a); }; });

  CLI::App* runs = app.add_subcommand("runs", "list the runs recorded in a twin database");
  runs->add_option("--db", a->db_path, "twin database")->capture_default_str();
  runs->callback([&run, a] { run = [a] { return run_runs(*a); }; });
}

}  // namespace scaratwin::cli
