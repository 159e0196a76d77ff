#include "scaratwin/hub/script.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

constexpr int kScriptError = error_code(ScriptError::kLine);

struct Spec {
  const char* word;
  StatementKind kind;
  int min_numbers;
  int max_numbers;
  const char* usage;
};

constexpr Spec kSpecs[] = {
    {"home", StatementKind::kHome, 0, 0, "home"},
    {"move", StatementKind::kMove, 3, 4, "move X_M Y_M Z_M [YAW_DEG]"},
    {"line", StatementKind::kLine, 3, 4, "line X_M Y_M Z_M [YAW_DEG]"},
    {"movej", StatementKind::kMoveJoints, 4, 4, "movej D1_M Q2_DEG Q3_DEG Q4_DEG"},
    {"grip", StatementKind::kGrip, 0, 0, "grip"},
    {"release", StatementKind::kRelease, 0, 0, "release"},
    {"shoot", StatementKind::kShoot, 0, 0, "shoot [FILE.png]"},
    {"spawn", StatementKind::kSpawn, 2, 2, "spawn red|green|blue X_M Y_M"},
    {"reset", StatementKind::kReset, 0, 0, "reset"},
    {"pick", StatementKind::kPick, 1, 1, "pick CUBE_ID"},
    {"sort", StatementKind::kSort, 0, 0, "sort"},
    {"wait", StatementKind::kWait, 1, 1, "wait SECONDS"},
    {"mirror", StatementKind::kMirror, 1, 1, "mirror SECONDS"},
    {"stop", StatementKind::kStop, 0, 0, "stop"},
};

// Errors carry the bare message; the callers add "line N:" or "file:N:".
Error script_error(int /*line*/, std::string message) { return Error{kScriptError, message}; }

std::vector<std::string> split_words(std::string_view text) {
  std::vector<std::string> out;
  std::istringstream in{std::string(text)};
  std::string w;
  while (in >> w) out.push_back(w);
  return out;
}

bool parse_number(const std::string& w, double& out) {
  const char* b = w.data();
  const char* e = b + w.size();
  auto [p, ec] = std::from_chars(b, e, out);
  return ec == std::errc() && p == e && std::isfinite(out);
}

}  // namespace

static Result<Statement> parse_one(std::string_view text, int line) {
  const std::vector<std::string> words = split_words(text);
  if (words.empty()) return script_error(line, "empty statement");
  const Spec* spec = nullptr;
  for (const Spec& s : kSpecs) {
    if (words[0] == s.word) spec = &s;
  }
  if (spec == nullptr) {
    std::string known;
    for (const Spec& s : kSpecs) known += std::string(known.empty() ? "" : ", ") + s.word;
    return script_error(line, fmt::format("unknown statement '{}' (known: {})", words[0], known));
  }
  Statement st;
  st.line = line;
  st.kind = spec->kind;
  st.source = std::string(text);
  size_t first = 1;
  if (spec->kind == StatementKind::kShoot) {
    if (words.size() > 2) return script_error(line, fmt::format("usage: {}", spec->usage));
    if (words.size() == 2) st.text = words[1];
    return st;
  }
  if (spec->kind == StatementKind::kSpawn) {
    if (words.size() < 2) return script_error(line, fmt::format("usage: {}", spec->usage));
    auto c = parse_color(words[1]);
    if (!c) return script_error(line, c.error().message);
    st.text = words[1];
    first = 2;
  }
  const int n = static_cast<int>(words.size() - first);
  if (n < spec->min_numbers || n > spec->max_numbers) {
    return script_error(
        line, fmt::format("'{}' takes {} number{}, got {} (usage: {})", spec->word,
                          spec->min_numbers == spec->max_numbers
                              ? fmt::format("{}", spec->min_numbers)
                              : fmt::format("{} to {}", spec->min_numbers, spec->max_numbers),
                          spec->max_numbers == 1 ? "" : "s", n, spec->usage));
  }
  for (size_t i = first; i < words.size(); ++i) {
    double v = 0.0;
    if (!parse_number(words[i], v)) {
      return script_error(line,
                          fmt::format("'{}' is not a number (usage: {})", words[i], spec->usage));
    }
    st.numbers.push_back(v);
  }
  // convert the script's degrees to radians.
  switch (spec->kind) {
    case StatementKind::kMove:
    case StatementKind::kLine:
      st.has_yaw = st.numbers.size() == 4;
      if (st.has_yaw) st.numbers[3] = deg_to_rad(st.numbers[3]);
      break;
    case StatementKind::kMoveJoints:
      for (size_t j = 1; j < 4; ++j) st.numbers[j] = deg_to_rad(st.numbers[j]);
      break;
    case StatementKind::kWait:
    case StatementKind::kMirror:
      if (st.numbers[0] < 0.0 || st.numbers[0] > 3600.0) {
        return script_error(line, fmt::format("{} seconds must be between 0 and 3600, got {}",
                                              spec->word, st.numbers[0]));
      }
      break;
    case StatementKind::kPick:
      if (st.numbers[0] < 0.0 || st.numbers[0] != std::floor(st.numbers[0])) {
        return script_error(line,
                            fmt::format("cube id must be a whole number >= 0, got {}", words[1]));
      }
      break;
    default:
      break;
  }
  return st;
}

Result<Statement> parse_statement(std::string_view text, int line) {
  auto st = parse_one(text, line);
  if (!st && line > 0)
    return Error{kScriptError, fmt::format("line {}: {}", line, st.error().message)};
  return st;
}

Result<std::vector<Statement>> parse_script(std::string_view text, std::string_view name) {
  std::vector<Statement> out;
  std::istringstream in{std::string(text)};
  std::string raw;
  int line = 0;
  while (std::getline(in, raw)) {
    ++line;
    std::string_view v = raw;
    if (const size_t hash = v.find('#'); hash != std::string_view::npos) v = v.substr(0, hash);
    if (split_words(v).empty()) continue;
    auto st = parse_one(v, line);
    if (!st) return Error{kScriptError, fmt::format("{}:{}: {}", name, line, st.error().message)};
    out.push_back(std::move(*st));
  }
  return out;
}

}  // namespace scaratwin
