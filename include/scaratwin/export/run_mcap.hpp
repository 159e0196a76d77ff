// A recorded run as an MCAP file (docs/mcap.md), for Foxglove and the MCAP tools: the run's
// joint samples per source, the physical and the virtual robot's link frames
// (foxglove.FrameTransforms, computed with the run's robot description), events
// (foxglove.Log), camera images (foxglove.CompressedImage), mirror latencies and commands, the
// run's row of the runs table and its metrics as metadata, the description and its URDF as
// attachments. A session's runs (a demo's phases, its children in the database) come along.
//
// Log times are nanoseconds since the Unix epoch: the run's started_unix_s plus the row's t_s.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

struct McapExportOptions {
  // the robot description file the model was read from: attached when set ("" = none)
  std::filesystem::path description_file;
  bool with_children = true;               // a session's runs too
  std::size_t chunk_size_bytes = 1 << 20;  // uncompressed bytes per chunk
};

struct McapExportSummary {
  std::uint64_t bytes = 0;
  std::uint64_t messages = 0;
  std::uint32_t chunks = 0;
  std::map<std::string, std::uint64_t> topic_messages;  // messages per topic
  std::vector<std::int64_t> runs;                       // the runs written, `run` first
};

// Writes run `run` of `db` (and its children) to `out`. `model` is the robot description the
// run was recorded with (its link frames, its hash in the metadata). Errors: DbError::kNoRun
// (no such run), DbError::kSqlite, DbError::kWriteFailed (the file cannot be written).
Result<McapExportSummary> export_run_mcap(TwinDb& db, const RobotModel& model, std::int64_t run,
                                          const std::filesystem::path& out,
                                          const McapExportOptions& options = {});

}  // namespace scaratwin
