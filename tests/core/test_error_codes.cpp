// The one table of error codes: the ranges do not overlap, every code lies in its module's
// range, docs/errors.md publishes exactly the header's table (ranges, and every code's number
// and name), and no source file builds an Error from a bare number.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/result.hpp"
#include "scaratwin/protocol/codec_core.h"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = SCARATWIN_SOURCE_DIR;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  EXPECT_TRUE(in) << "cannot read " << p;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<ErrorRange> all_ranges() {
  std::vector<ErrorRange> r(kErrorRanges.begin(), kErrorRanges.end());
  r.push_back(kFleetErrorRange);
  return r;
}

// "sim::SimError" -> "SimError"
std::string unqualified(std::string_view name) {
  const auto c = name.rfind("::");
  return std::string(c == std::string_view::npos ? name : name.substr(c + 2));
}

// enum name -> (code name -> value), read from the header's text
using Codes = std::map<std::string, std::map<std::string, int>>;

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t");
  return std::string(s.substr(b, e - b + 1));
}

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// "enum class Name : int {" or "enum Name : int {" -> Name, else ""
std::string enum_name(const std::string& line) {
  std::string t = trim(line);
  if (t.rfind("enum ", 0) != 0 || t.size() < 2 || t.substr(t.size() - 2) != " {") return {};
  t = t.substr(5);
  if (t.rfind("class ", 0) == 0) t = t.substr(6);
  const auto colon = t.find(" : int {");
  return colon == std::string::npos ? std::string() : t.substr(0, colon);
}

Codes header_codes() {
  std::istringstream in(read_text(kSource / "include/scaratwin/core/error_codes.hpp"));
  Codes out;
  std::string line, current;
  while (std::getline(in, line)) {
    if (const std::string e = enum_name(line); !e.empty()) {
      current = e;
      out[current];
    } else if (trim(line) == "};") {
      current.clear();
    } else if (!current.empty()) {
      // "  kName = 12,  // ..."
      const std::string t = trim(line.substr(0, line.find("//")));
      const auto eq = t.find(" = ");
      if (t.empty() || t[0] != 'k' || eq == std::string::npos || t.back() != ',') continue;
      const std::string value = t.substr(eq + 3, t.size() - eq - 4);
      EXPECT_TRUE(all_digits(value)) << "error_codes.hpp: " << line;
      if (all_digits(value)) out[current][t.substr(0, eq)] = std::stoi(value);
    }
  }
  return out;
}

// The cells of a markdown table row, trimmed; empty for other lines.
std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out;
  if (line.size() < 2 || line[0] != '|') return out;
  std::size_t at = 1;
  for (auto bar = line.find('|', at); bar != std::string::npos; bar = line.find('|', at)) {
    if (bar > 0 && line[bar - 1] == '\\') {  // an escaped bar inside a cell
      bar = line.find('|', bar + 1);
      if (bar == std::string::npos) break;
    }
    out.push_back(trim(std::string_view(line).substr(at, bar - at)));
    at = bar + 1;
  }
  return out;
}

// `text` -> text, else ""
std::string ticked(const std::string& cell) {
  if (cell.size() < 3 || cell.front() != '`' || cell.back() != '`') return {};
  return cell.substr(1, cell.size() - 2);
}

struct DocRange {
  std::string module, codes;
  int first = 0, last = 0;
};
struct Doc {
  std::vector<DocRange> ranges;
  Codes codes;
};

Doc doc_tables() {
  std::istringstream in(read_text(kSource / "docs/errors.md"));
  Doc doc;
  std::string line, current;
  while (std::getline(in, line)) {
    if (line.rfind("### ", 0) == 0) {
      // "### sim: `SimError`"
      const auto colon = line.find(": ");
      current = colon == std::string::npos ? std::string() : ticked(line.substr(colon + 2));
      EXPECT_FALSE(current.empty()) << "docs/errors.md: " << line;
      EXPECT_EQ(doc.codes.count(current), 0u) << "docs/errors.md: two sections for " << current;
      doc.codes[current];
      continue;
    }
    const std::vector<std::string> c = cells(line);
    if (c.size() < 3) continue;
    const auto dots = c[0].find("..");
    if (dots != std::string::npos && all_digits(c[0].substr(0, dots)) &&
        all_digits(c[0].substr(dots + 2)) && c.size() >= 4) {
      doc.ranges.push_back(
          {c[1], ticked(c[2]), std::stoi(c[0].substr(0, dots)), std::stoi(c[0].substr(dots + 2))});
    } else if (all_digits(c[0]) && !ticked(c[1]).empty()) {
      EXPECT_FALSE(current.empty()) << "docs/errors.md: a code row before any section: " << line;
      EXPECT_EQ(doc.codes[current].count(ticked(c[1])), 0u) << "docs/errors.md: twice: " << line;
      doc.codes[current][ticked(c[1])] = std::stoi(c[0]);
    }
  }
  return doc;
}

// Whether `text` has "Error{<digit>", "Error e{ -<digit>" or "Error(<digit>" at `at` (where
// a word "Error" starts); spaces and line breaks may come between.
bool bare_error_at(const std::string& text, std::size_t at) {
  auto is_word = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  };
  auto skip_space = [&](std::size_t i) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\n' || text[i] == '\t')) ++i;
    return i;
  };
  if (at > 0 && is_word(text[at - 1])) return false;
  std::size_t i = at + 5;
  if (i < text.size() && is_word(text[i])) return false;  // ErrorCode, ErrorRange, ...
  i = skip_space(i);
  if (i < text.size() && ((text[i] >= 'a' && text[i] <= 'z') || text[i] == '_')) {  // a name
    while (i < text.size() && is_word(text[i])) ++i;
    i = skip_space(i);
  }
  if (i >= text.size() || (text[i] != '{' && text[i] != '(')) return false;
  i = skip_space(i + 1);
  if (i < text.size() && text[i] == '-') ++i;
  return i < text.size() && text[i] >= '0' && text[i] <= '9';
}

TEST(ErrorCodes, RangesAreSortedAndDisjoint) {
  const auto ranges = all_ranges();
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    EXPECT_GE(ranges[i].first, 1) << ranges[i].module;
    EXPECT_LE(ranges[i].first, ranges[i].last) << ranges[i].module;
    if (i > 0) {
      EXPECT_LT(ranges[i - 1].last, ranges[i].first)
          << ranges[i - 1].module << " overlaps " << ranges[i].module;
    }
  }
}

TEST(ErrorCodes, EveryCodeLiesInItsModulesRangeAndIsUnique) {
  const Codes codes = header_codes();
  std::map<int, std::string> owner;
  std::size_t enums = 0;
  for (const ErrorRange& r : all_ranges()) {
    if (r.module == "protocol") continue;  // a rule, not an enum
    ++enums;
    const auto it = codes.find(unqualified(r.codes));
    ASSERT_NE(it, codes.end()) << "no enum " << r.codes << " in error_codes.hpp";
    EXPECT_FALSE(it->second.empty()) << r.codes;
    for (const auto& [name, value] : it->second) {
      EXPECT_GE(value, r.first) << r.codes << "::" << name;
      EXPECT_LE(value, r.last) << r.codes << "::" << name;
      EXPECT_TRUE(owner.emplace(value, r.codes).second)
          << value << " is in " << owner[value] << " and " << r.codes;
    }
  }
  // every enum of the header has a range
  EXPECT_EQ(codes.size(), enums);
  // the text read is the compiled table
  EXPECT_EQ(codes.at("IkError").at("kJ4Limit"), error_code(IkError::kJ4Limit));
  EXPECT_EQ(codes.at("PlanError").at("kDiscontinuous"), error_code(PlanError::kDiscontinuous));
  EXPECT_EQ(codes.at("SimError").at("kWrongMode"), error_code(sim::SimError::kWrongMode));
  EXPECT_EQ(codes.at("TransportError").at("kPayloadTooLarge"),
            error_code(transport::TransportError::kPayloadTooLarge));
  EXPECT_EQ(codes.at("FleetError").at("kNoCommands"), fleet::kNoCommands);
  EXPECT_EQ(codes.at("DbError").at("kNotFound"), error_code(DbError::kNotFound));
}

TEST(ErrorCodes, ProtocolCodesKeepTheirWireNumbersOffsetIntoTheirRange) {
  const ErrorRange* protocol = nullptr;
  for (const ErrorRange& r : kErrorRanges) {
    if (r.module == "protocol") protocol = &r;
  }
  ASSERT_NE(protocol, nullptr);
  EXPECT_EQ(protocol_error_code(protocol::core::kErrLineTooLong), protocol->first);
  EXPECT_LE(protocol_error_code(protocol::core::kErrMaxCode), protocol->last);
  EXPECT_EQ(protocol_error_code(protocol::core::kErrTimeout), 216);
  EXPECT_EQ(protocol_error_code(protocol::core::kErrAccess), 218);
}

TEST(ErrorCodes, TheDocsTablesAreTheHeaders) {
  const Doc doc = doc_tables();
  const auto ranges = all_ranges();
  ASSERT_EQ(doc.ranges.size(), ranges.size()) << "rows of the range table in docs/errors.md";
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    EXPECT_EQ(doc.ranges[i].module, std::string(ranges[i].module)) << "row " << i;
    EXPECT_EQ(doc.ranges[i].codes, std::string(ranges[i].codes)) << "row " << i;
    EXPECT_EQ(doc.ranges[i].first, ranges[i].first) << ranges[i].module;
    EXPECT_EQ(doc.ranges[i].last, ranges[i].last) << ranges[i].module;
  }
  // every code of the header in the docs with its number, and nothing else there
  const Codes header = header_codes();
  for (const auto& [enum_name, codes] : header) {
    const auto d = doc.codes.find(enum_name);
    if (d == doc.codes.end()) {
      ADD_FAILURE() << "docs/errors.md has no section for " << enum_name;
      continue;
    }
    for (const auto& [name, value] : codes) {
      const auto it = d->second.find(name);
      if (it == d->second.end()) {
        ADD_FAILURE() << "docs/errors.md lacks " << enum_name << "::" << name << " = " << value;
      } else {
        EXPECT_EQ(it->second, value) << "docs/errors.md: " << enum_name << "::" << name;
      }
    }
    for (const auto& [name, value] : d->second) {
      EXPECT_EQ(codes.count(name), 1u) << "docs/errors.md: " << enum_name << "::" << name << " = "
                                       << value << " is not in error_codes.hpp";
    }
  }
  for (const auto& [enum_name, codes] : doc.codes) {
    EXPECT_EQ(header.count(enum_name), 1u) << "docs/errors.md: a section for " << enum_name;
  }
}

// Every `Error{...}` and `Error name{...}` of the sources takes a named code.
TEST(ErrorCodes, NoSourceBuildsAnErrorFromABareNumber) {
  int files = 0;
  for (const char* dir : {"include", "src", "apps", "python/src", "examples", "bench", "fuzz"}) {
    if (!fs::exists(kSource / dir)) continue;
    for (const auto& e : fs::recursive_directory_iterator(kSource / dir)) {
      const std::string ext = e.path().extension().string();
      if (ext != ".cpp" && ext != ".hpp" && ext != ".h") continue;
      ++files;
      // the whole text: a code may follow the brace on the next line
      const std::string text = read_text(e.path());
      for (auto at = text.find("Error"); at != std::string::npos; at = text.find("Error", at + 1)) {
        if (!bare_error_at(text, at)) continue;
        const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(at), '\n');
        ADD_FAILURE() << fs::relative(e.path(), kSource).string() << ":" << line << ": "
                      << text.substr(at, 40);
      }
    }
  }
  EXPECT_GT(files, 100);
}

// Errors keep their structure (a code, a peer's detail): no product code tells errors apart by
// reading their text (message.find, ==, starts_with ...). Tests may read messages: they check
// what a person sees.
TEST(ErrorCodes, NoSourceReadsAnErrorsMessageText) {
  int files = 0;
  const std::vector<std::string> reads = {
      "message.find(",        "message.rfind(",   "message ==",      "message==",
      "message.starts_with(", "message.compare(", "message.substr(", "message().find("};
  for (const char* dir : {"include", "src", "apps", "python/src", "examples", "bench"}) {
    if (!fs::exists(kSource / dir)) continue;
    for (const auto& e : fs::recursive_directory_iterator(kSource / dir)) {
      const std::string ext = e.path().extension().string();
      if (ext != ".cpp" && ext != ".hpp" && ext != ".h") continue;
      ++files;
      std::istringstream in(read_text(e.path()));
      std::string line;
      for (int n = 1; std::getline(in, line); ++n) {
        for (const std::string& r : reads) {
          if (line.find(r) != std::string::npos) {
            ADD_FAILURE() << fs::relative(e.path(), kSource).string() << ":" << n << ": " << line;
          }
        }
      }
    }
  }
  EXPECT_GT(files, 100);
}

}  // namespace
}  // namespace scaratwin
