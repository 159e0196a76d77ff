// Subcommands of the `scaratwin` command line. Each registers itself on the CLI11 app and
// returns the process exit code when run.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include <CLI/CLI.hpp>

namespace scaratwin::cli {

// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;        // the operation failed (unreachable, link lost, ...)
inline constexpr int kExitUsage = 2;          // bad arguments or configuration
inline constexpr int kExitInterrupted = 130;  // Ctrl-C stopped the robot

// Options every subcommand understands.
struct CommonOptions {
  std::string config_path;  // robot description; empty = default
  bool json = false;
};

using Runner = std::function<int()>;

// Registers fk and ik; `run` receives the runner of the chosen subcommand.
void add_kinematics_commands(CLI::App& app, CommonOptions& common, Runner& run);
void add_plan_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_report_commands(CLI::App& app, CommonOptions& common, Runner& run);
void add_demo_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_calibrate_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_statement_commands(CLI::App& app, CommonOptions& common, Runner& run);
void add_hub_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_flash_command(CLI::App& app, CommonOptions& common, Runner& run);

void add_model_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_sim_command(CLI::App& app, CommonOptions& common, Runner& run);
void add_bench_command(CLI::App& app, CommonOptions& common, Runner& run);

}  // namespace scaratwin::cli

#include <optional>

#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/session/address.hpp"

namespace scaratwin::cli {

// Adds --config and --json to a subcommand.
void add_common_options(CLI::App& cmd, CommonOptions& common, bool with_json = true);

// Loads the robot description; prints the error and returns nullopt on failure.
std::optional<RobotModel> load_model(const CommonOptions& common);

// Creates a command's output folder `dir` (and its parents); its absolute path, or nullopt
// after printing "scaratwin COMMAND: cannot create --out ...".
std::optional<std::filesystem::path> create_out_dir(const std::string& dir, const char* command);

// Parses "d1_m,q2_deg,q3_deg,q4_deg" into SI joints; prints the error on failure.
std::optional<JointVector> joints_from_edge(const std::vector<double>& values, const char* what);

// An address option's "HOST:PORT" (the session library's parser).
using session::HostPort;
using session::parse_host_port;

}  // namespace scaratwin::cli
