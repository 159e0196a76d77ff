// The invariants the script parser's fuzzer checks on every input (fuzz_script.cpp), shared
// with the replay of the saved corpus in the normal tests (tests/hub/test_script_fuzz_corpus.cpp).
//
// A script either parses or is refused with an error naming the file and the line:
// "fuzz.txt:N: ...", N a line of the input. A script that parses gives statements in line order,
// each with finite numbers, and each statement parsed again from its own source text on its
// own (parse_statement, the CLI one-liners' path) gives the same statement: the script and the
// one-liner languages agree.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

#include "scaratwin/hub/script.hpp"

namespace scaratwin::fuzz {

inline std::string check_script(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto parsed = parse_script(text, "fuzz.txt");
  // lines as std::getline counts them
  int lines = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t nl = text.find('\n', at);
    ++lines;
    if (nl == std::string_view::npos) break;
    at = nl + 1;
  }
  if (!parsed) {
    const std::string& m = parsed.error().message;
    if (m.rfind("fuzz.txt:", 0) != 0) return "error without the file's name: " + m;
    const std::size_t colon = m.find(':', 9);
    if (colon == std::string::npos) return "error without a line: " + m;
    int line = 0;
    for (std::size_t i = 9; i < colon; ++i) {
      if (m[i] < '0' || m[i] > '9') return "error without a line number: " + m;
      line = line * 10 + (m[i] - '0');
      if (line > lines) break;
    }
    if (line < 1 || line > lines) {
      return "error names line " + std::to_string(line) + " of " + std::to_string(lines) + ": " +
             m;
    }
    if (m.size() <= colon + 2) return "error with no message: " + m;
    return {};
  }
  int last_line = 0;
  for (const Statement& st : *parsed) {
    if (st.line <= last_line || st.line > lines) {
      return "statement at line " + std::to_string(st.line) + " after line " +
             std::to_string(last_line) + " of " + std::to_string(lines);
    }
    last_line = st.line;
    for (double v : st.numbers) {
      if (!std::isfinite(v)) return "a statement with a number that is not finite: " + st.source;
    }
    const auto again = parse_statement(st.source, st.line);
    if (!again) return "'" + st.source + "' parses in a script, not alone: " + again.error().message;
    if (again->kind != st.kind || again->numbers != st.numbers || again->text != st.text ||
        again->has_yaw != st.has_yaw || again->line != st.line) {
      return "'" + st.source + "' parses alone to another statement";
    }
  }
  return {};
}

}  // namespace scaratwin::fuzz
