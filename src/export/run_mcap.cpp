#include "scaratwin/export/run_mcap.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "scaratwin/export/mcap.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/mjcf.hpp"

namespace scaratwin {
namespace {

using nlohmann::json;

// --- the schemas (JSON Schema, as Foxglove's own are written) -------------------------------

json number() { return {{"type", "number"}}; }
json integer() { return {{"type", "integer"}}; }
json string() { return {{"type", "string"}}; }

json time_schema() {
  return {{"type", "object"},
          {"title", "time"},
          {"properties",
           {{"sec", {{"type", "integer"}, {"minimum", 0}}},
            {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}}}};
}

json object(const char* title, const char* description, json properties) {
  return {{"title", title},
          {"description", description},
          {"type", "object"},
          {"properties", std::move(properties)}};
}

std::string frame_transforms_schema() {
  json vector3 = object("foxglove.Vector3", "A vector in 3D space",
                        {{"x", number()}, {"y", number()}, {"z", number()}});
  json quaternion = object("foxglove.Quaternion", "A quaternion (x, y, z, w)",
                           {{"x", number()}, {"y", number()}, {"z", number()}, {"w", number()}});
  json transform = object("foxglove.FrameTransform", "A transform between two reference frames",
                          {{"timestamp", time_schema()},
                           {"parent_frame_id", string()},
                           {"child_frame_id", string()},
                           {"translation", vector3},
                           {"rotation", quaternion}});
  return object("foxglove.FrameTransforms", "An array of FrameTransform messages",
                {{"transforms", {{"type", "array"}, {"items", transform}}}})
      .dump();
}

std::string log_schema() {
  json level = {{"title", "foxglove.LogLevel"},
                {"description", "Log level"},
                {"oneOf", json::array({{{"title", "UNKNOWN"}, {"const", 0}},
                                       {{"title", "DEBUG"}, {"const", 1}},
                                       {{"title", "INFO"}, {"const", 2}},
                                       {{"title", "WARNING"}, {"const", 3}},
                                       {{"title", "ERROR"}, {"const", 4}},
                                       {{"title", "FATAL"}, {"const", 5}}})}};
  return object("foxglove.Log", "A log message",
                {{"timestamp", time_schema()},
                 {"level", level},
                 {"message", string()},
                 {"name", string()},
                 {"file", string()},
                 {"line", {{"type", "integer"}, {"minimum", 0}}}})
      .dump();
}

std::string compressed_image_schema() {
  return object("foxglove.CompressedImage", "A compressed image",
                {{"timestamp", time_schema()},
                 {"frame_id", string()},
                 {"data", {{"type", "string"}, {"contentEncoding", "base64"}}},
                 {"format", string()}})
      .dump();
}

std::string joint_sample_schema() {
  return object("scaratwin.JointSample",
                "A joint sample of the twin database (SI units; seq null when unknown)",
                {{"run", integer()},
                 {"t_s", number()},
                 {"seq", {{"type", json::array({"integer", "null"})}}},
                 {"d1_m", number()},
                 {"q2_rad", number()},
                 {"q3_rad", number()},
                 {"q4_rad", number()},
                 {"grip_deg", number()}})
      .dump();
}

std::string latency_schema() {
  return object("scaratwin.MirrorLatency",
                "One mirror frame: device time as sent, hub receive and simulator apply times "
                "on the hub's monotonic clock (us)",
                {{"run", integer()},
                 {"seq", integer()},
                 {"device_t_us", integer()},
                 {"hub_rx_us", integer()},
                 {"sim_apply_us", integer()},
                 {"hub_to_sim_ms", number()}})
      .dump();
}

std::string command_schema() {
  return object("scaratwin.Command", "A packet the hub sent on a link",
                {{"run", integer()}, {"t_s", number()}, {"link", string()}, {"text", string()}})
      .dump();
}

// --- messages ---------------------------------------------------------------------------------

std::string base64(std::string_view in) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const auto n = (std::uint32_t{static_cast<std::uint8_t>(in[i])} << 16) |
                   (std::uint32_t{static_cast<std::uint8_t>(in[i + 1])} << 8) |
                   std::uint32_t{static_cast<std::uint8_t>(in[i + 2])};
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += kAlphabet[n & 63];
  }
  if (i < in.size()) {
    auto n = std::uint32_t{static_cast<std::uint8_t>(in[i])} << 16;
    if (i + 1 < in.size()) n |= std::uint32_t{static_cast<std::uint8_t>(in[i + 1])} << 8;
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < in.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

json stamp(std::uint64_t ns) { return {{"sec", ns / 1000000000U}, {"nsec", ns % 1000000000U}}; }

// Nanoseconds since the Unix epoch of a run's time t_s.
std::uint64_t unix_ns(double started_unix_s, double t_s) {
  const double ns = std::round(started_unix_s * 1e9) + std::round(t_s * 1e9);
  return ns <= 0.0 ? 0 : static_cast<std::uint64_t>(ns);
}

int log_level(const std::string& kind) {
  const auto has = [&kind](const char* w) { return kind.find(w) != std::string::npos; };
  if (has("error") || has("fail") || has("abort")) return 4;
  if (has("desync") || has("warn") || has("lost")) return 3;
  return 2;
}

// The robot's links in the world at joints q: world -> <robot>/base_link (the same place for
// both robots) -> carriage -> link1 -> link2 -> wrist -> tool, the links of make_urdf().
json frame_transforms(const RobotModel& model, const JointVector& q, const std::string& robot,
                      std::uint64_t ns) {
  static constexpr const char* kLinks[] = {"base_link", "carriage", "link1",
                                           "link2",     "wrist",    "tool"};
  const auto transform = [&](const std::string& parent, const std::string& child,
                             const Eigen::Matrix4d& x) {
    const Eigen::Quaterniond r(Eigen::Matrix3d(x.topLeftCorner<3, 3>()));
    return json{{"timestamp", stamp(ns)},
                {"parent_frame_id", parent},
                {"child_frame_id", child},
                {"translation", {{"x", x(0, 3)}, {"y", x(1, 3)}, {"z", x(2, 3)}}},
                {"rotation", {{"x", r.x()}, {"y", r.y()}, {"z", r.z()}, {"w", r.w()}}}};
  };
  const std::string p = robot + "/";
  json list = json::array();
  list.push_back(transform("world", p + kLinks[0], Eigen::Matrix4d::Identity()));
  const auto links = link_transforms(model, q);
  for (std::size_t i = 0; i < links.size(); ++i) {
    list.push_back(transform(p + kLinks[i], p + kLinks[i + 1], links[i]));
  }
  return {{"transforms", std::move(list)}};
}

// A message to write: its log time and where its row is (rendered as JSON only when written,
// so that a long run's messages never sit in memory all at once).
struct Pending {
  std::uint64_t ns = 0;
  std::uint8_t topic = 0;
  std::uint32_t run = 0;  // index into the runs' rows
  std::uint32_t row = 0;  // index into that run's table of the topic
};

// The topics, in the order of the file's channels.
enum Topic {
  kPlannedJoints,
  kVirtualJoints,
  kPhysicalJoints,
  kTruthJoints,
  kPhysicalTf,
  kVirtualTf,
  kEvents,
  kCamera,
  kLatency,
  kCommands,
  kTopicCount
};

struct TopicSpec {
  const char* topic;
  const char* schema;
  std::string (*schema_text)();
  const char* source;  // the channel's metadata "source"
};

constexpr TopicSpec kTopics[kTopicCount] = {
    {"/planned/joints", "scaratwin.JointSample", joint_sample_schema, "planned"},
    {"/virtual/joints", "scaratwin.JointSample", joint_sample_schema, "virtual"},
    {"/physical/joints", "scaratwin.JointSample", joint_sample_schema, "physical"},
    {"/truth/joints", "scaratwin.JointSample", joint_sample_schema, "truth"},
    {"/physical/tf", "foxglove.FrameTransforms", frame_transforms_schema, "physical"},
    {"/virtual/tf", "foxglove.FrameTransforms", frame_transforms_schema, "virtual"},
    {"/events", "foxglove.Log", log_schema, "events"},
    {"/camera", "foxglove.CompressedImage", compressed_image_schema, "images"},
    {"/mirror/latency", "scaratwin.MirrorLatency", latency_schema, "latencies"},
    {"/commands", "scaratwin.Command", command_schema, "commands"},
};

std::string num(double v) { return fmt::format("{}", v); }

// One run's rows, as read from the database.
struct RunRows {
  RunInfo info;
  std::array<std::vector<JointRecord>, 4> samples;  // by SampleSource
  std::vector<EventRecord> events;
  std::vector<ImageRecord> images;
  std::vector<LatencyRecord> latencies;
  std::vector<double> latency_t_s;  // each latency row's time on the run's clock
  std::vector<CommandRecord> commands;
  std::vector<MetricRecord> metrics;
};

// Reads one run's rows into `rows` and adds their messages (index `index`) to `out`.
Status collect_run(TwinDb& db, const RunInfo& run, std::uint32_t index, RunRows& rows,
                   std::vector<Pending>& out) {
  rows.info = run;
  const auto at = [&run](double t_s) { return unix_ns(run.started_unix_s, t_s); };
  const auto add = [&out, index](std::uint64_t ns, int topic, std::size_t row) {
    out.push_back({ns, static_cast<std::uint8_t>(topic), index, static_cast<std::uint32_t>(row)});
  };
  std::unordered_map<std::int64_t, double> physical_t_s;  // by seq: the latencies' clock
  for (SampleSource src : {SampleSource::kPlanned, SampleSource::kVirtual, SampleSource::kPhysical,
                           SampleSource::kTruth}) {
    auto got = db.samples(run.id, src);
    if (!got) return got.error();
    const int topic = static_cast<int>(src);  // kPlannedJoints.. follow SampleSource's order
    const int tf = src == SampleSource::kPhysical  ? kPhysicalTf
                   : src == SampleSource::kVirtual ? kVirtualTf
                                                   : -1;
    rows.samples[topic] = std::move(*got);
    for (std::size_t i = 0; i < rows.samples[topic].size(); ++i) {
      const JointRecord& r = rows.samples[topic][i];
      add(at(r.t_s), topic, i);
      if (tf >= 0) add(at(r.t_s), tf, i);
      if (src == SampleSource::kPhysical && r.seq >= 0) physical_t_s.emplace(r.seq, r.t_s);
    }
  }
  auto events = db.event_records(run.id);
  if (!events) return events.error();
  rows.events = std::move(*events);
  for (std::size_t i = 0; i < rows.events.size(); ++i) add(at(rows.events[i].t_s), kEvents, i);
  auto images = db.images(run.id);
  if (!images) return images.error();
  rows.images = std::move(*images);
  for (std::size_t i = 0; i < rows.images.size(); ++i) add(at(rows.images[i].t_s), kCamera, i);

  // a latency row has no t_s: its receive time is the physical sample's of the same seq, so
  // the first such pair gives the run's start on the hub's clock
  auto latencies = db.latencies(run.id);
  if (!latencies) return latencies.error();
  rows.latencies = std::move(*latencies);
  std::int64_t start_us = rows.latencies.empty() ? 0 : rows.latencies.front().hub_rx_us;
  for (const LatencyRecord& l : rows.latencies) {
    if (auto p = physical_t_s.find(l.seq); p != physical_t_s.end()) {
      start_us = l.hub_rx_us - static_cast<std::int64_t>(std::llround(p->second * 1e6));
      break;
    }
  }
  for (std::size_t i = 0; i < rows.latencies.size(); ++i) {
    rows.latency_t_s.push_back(static_cast<double>(rows.latencies[i].hub_rx_us - start_us) / 1e6);
    add(at(rows.latency_t_s.back()), kLatency, i);
  }
  auto commands = db.commands(run.id);
  if (!commands) return commands.error();
  rows.commands = std::move(*commands);
  auto metrics = db.metrics(run.id);
  if (!metrics) return metrics.error();
  rows.metrics = std::move(*metrics);
  for (std::size_t i = 0; i < rows.commands.size(); ++i) {
    add(at(rows.commands[i].t_s), kCommands, i);
  }
  return Ok{};
}

// The JSON of one message.
std::string render(const RobotModel& model, const RunRows& rows, const Pending& p) {
  const std::int64_t run = rows.info.id;
  switch (p.topic) {
    case kPhysicalTf:
    case kVirtualTf: {
      const bool physical = p.topic == kPhysicalTf;
      const JointRecord& r = rows.samples[physical ? kPhysicalJoints : kVirtualJoints][p.row];
      return frame_transforms(model, r.q, physical ? "physical" : "virtual", p.ns).dump();
    }
    case kEvents: {
      const EventRecord& e = rows.events[p.row];
      return json{{"timestamp", stamp(p.ns)},
                  {"level", log_level(e.kind)},
                  {"message", e.detail},
                  {"name", e.kind},
                  {"file", ""},
                  {"line", 0}}
          .dump();
    }
    case kCamera: {
      const ImageRecord& im = rows.images[p.row];
      return json{{"timestamp", stamp(p.ns)},
                  {"frame_id", im.name},
                  {"data", base64(im.png)},
                  {"format", "png"}}
          .dump();
    }
    case kLatency: {
      const LatencyRecord& l = rows.latencies[p.row];
      return json{{"run", run},
                  {"seq", l.seq},
                  {"device_t_us", l.device_t_us},
                  {"hub_rx_us", l.hub_rx_us},
                  {"sim_apply_us", l.sim_apply_us},
                  {"hub_to_sim_ms", static_cast<double>(l.sim_apply_us - l.hub_rx_us) / 1e3}}
          .dump();
    }
    case kCommands: {
      const CommandRecord& c = rows.commands[p.row];
      return json{{"run", run}, {"t_s", c.t_s}, {"link", c.link}, {"text", c.text}}.dump();
    }
    default: {  // the joints of a source
      const JointRecord& r = rows.samples[p.topic][p.row];
      json j = {{"run", run},       {"t_s", r.t_s},          {"seq", nullptr},
                {"d1_m", r.q[0]},   {"q2_rad", r.q[1]},      {"q3_rad", r.q[2]},
                {"q4_rad", r.q[3]}, {"grip_deg", r.grip_deg}};
      if (r.seq >= 0) j["seq"] = r.seq;
      return j.dump();
    }
  }
}

std::map<std::string, std::string> run_metadata(const RunInfo& r) {
  return {{"id", std::to_string(r.id)},
          {"parent", std::to_string(r.parent)},
          {"ref", std::to_string(r.ref)},
          {"kind", r.kind},
          {"label", r.label},
          {"status", r.status},
          {"started_unix_s", fmt::format("{:.6f}", r.started_unix_s)},
          {"duration_s", num(r.duration_s)}};
}

}  // namespace

Result<McapExportSummary> export_run_mcap(TwinDb& db, const RobotModel& model, std::int64_t run,
                                          const std::filesystem::path& out,
                                          const McapExportOptions& options) {
  auto top = db.run(run);
  if (!top) return top.error();
  std::vector<RunInfo> runs = {*top};
  if (options.with_children) {
    auto kids = db.children(run);
    if (!kids) return kids.error();
    runs.insert(runs.end(), kids->begin(), kids->end());
  }

  std::vector<Pending> pending;
  std::vector<RunRows> rows(runs.size());
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (Status s = collect_run(db, runs[i], static_cast<std::uint32_t>(i), rows[i], pending); !s) {
      return s.error();
    }
  }
  // one timeline: readers that stream the file see the messages in log time order
  std::stable_sort(pending.begin(), pending.end(),
                   [](const Pending& a, const Pending& b) { return a.ns < b.ns; });

  const std::filesystem::path part = out.string() + ".part";
  std::ofstream file(part, std::ios::binary | std::ios::trunc);
  if (!file) {
    return Error{DbError::kWriteFailed, fmt::format("cannot write '{}'", out.string())};
  }
  mcap::WriterOptions wo;
  wo.library = "scaratwin " SCARATWIN_VERSION;
  wo.chunk_size_bytes = options.chunk_size_bytes;
  mcap::Writer w(
      [&file](std::string_view b) { file.write(b.data(), static_cast<std::streamsize>(b.size())); },
      wo);

  // the runs, the robot and the metrics
  const std::uint64_t start_ns = unix_ns(top->started_unix_s, 0.0);
  std::map<std::string, std::string> robot = {
      {"name", model.name},
      {"description_hash", description_hash(model)},
      {"log_time", "ns since the Unix epoch: runs.started_unix_s + t_s"}};
  if (!options.description_file.empty()) {
    robot["description_file"] = options.description_file.string();
  }
  w.add_metadata("scaratwin.robot", robot);
  for (const RunRows& r : rows) {
    w.add_metadata("scaratwin.run", run_metadata(r.info));
    if (r.metrics.empty()) continue;
    std::map<std::string, std::string> m = {{"run", std::to_string(r.info.id)}};
    for (const MetricRecord& x : r.metrics) m[x.name] = fmt::format("{} {}", num(x.value), x.unit);
    w.add_metadata("scaratwin.metrics", m);
  }

  // the description as given and its URDF
  if (!options.description_file.empty()) {
    std::ifstream in(options.description_file, std::ios::binary);
    if (in) {
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      w.add_attachment(options.description_file.filename().string(), "application/toml", text,
                       start_ns, 0);
    }
  }
  if (auto urdf = sim::make_urdf(model); urdf) {
    w.add_attachment(model.name + ".urdf", "application/xml", *urdf, start_ns, 0);
  }

  // a channel (and its schema) for each topic that has messages
  std::vector<std::uint64_t> per_topic(kTopicCount, 0);
  for (const Pending& p : pending) ++per_topic[p.topic];
  std::map<std::string, std::uint16_t> schema_ids;
  std::vector<std::uint16_t> channel(kTopicCount, 0);
  for (int t = 0; t < kTopicCount; ++t) {
    if (per_topic[t] == 0) continue;
    const TopicSpec& spec = kTopics[t];
    auto [it, fresh] = schema_ids.emplace(spec.schema, 0);
    if (fresh) it->second = w.add_schema(spec.schema, "jsonschema", spec.schema_text());
    channel[t] = w.add_channel(it->second, spec.topic, "json", {{"source", spec.source}});
  }
  for (const Pending& p : pending) {
    w.add_message(channel[p.topic], p.ns, p.ns, render(model, rows[p.run], p));
  }
  const mcap::WriterStats stats = w.finish();
  file.close();
  if (!file) {
    std::filesystem::remove(part);
    return Error{DbError::kWriteFailed, fmt::format("cannot write '{}'", out.string())};
  }
  std::error_code ec;
  std::filesystem::rename(part, out, ec);
  if (ec) {
    return Error{DbError::kWriteFailed,
                 fmt::format("cannot write '{}': {}", out.string(), ec.message())};
  }

  McapExportSummary summary;
  summary.bytes = stats.bytes;
  summary.messages = stats.messages;
  summary.chunks = stats.chunks;
  for (int t = 0; t < kTopicCount; ++t) {
    if (per_topic[t] > 0) summary.topic_messages[kTopics[t].topic] = per_topic[t];
  }
  for (const RunInfo& r : runs) summary.runs.push_back(r.id);
  return summary;
}

}  // namespace scaratwin
