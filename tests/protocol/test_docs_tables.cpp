// docs/protocol.md's code tables (sections 7 and 8) against the code tables the codec runs on
// (kSerialHostToDevice, kSerialDeviceToHost, kTcpHubToSim, kTcpSimToHub, built from the packet
// structs' rows in messages.hpp): the same codes in each direction, the same required and
// optional field counts (a field in [brackets] is optional), and, where the docs name a
// field's kind (i32, u32, dec, text), the same kind. The docs are read as a reader reads them:
// the table under each direction's heading, one row per code.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "scaratwin/protocol/codec_core.h"
#include "scaratwin/protocol/replies.hpp"

namespace scaratwin::protocol {
namespace {

struct DocField {
  std::string text;
  bool optional = false;
  std::optional<core::FieldKind> kind;  // when the docs name it
};

struct DocRow {
  std::string code;
  std::vector<DocField> fields;
  std::string reply;  // the "reply" cell of a request table, else empty
};

std::string read_docs() {
  std::ifstream in(SCARATWIN_PROTOCOL_DOCS);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

// Splits at `sep` outside parentheses and brackets.
std::vector<std::string> split_top(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  for (char c : s) {
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (c == sep && depth == 0) {
      out.push_back(trim(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(trim(cur));
  return out;
}

// The kind a field's note names: "(i32, 0..65535)", "(dec)", "(text: ...)".
std::optional<core::FieldKind> kind_named(const std::string& field) {
  const auto open = field.find('(');
  if (open == std::string::npos) return std::nullopt;
  const std::string note = field.substr(open + 1);
  const auto starts = [&](const char* w) { return note.rfind(w, 0) == 0; };
  if (starts("i32")) return core::kFieldI32;
  if (starts("u32")) return core::kFieldU32;
  if (starts("dec")) return core::kFieldDec;
  if (starts("text")) return core::kFieldText;
  return std::nullopt;
}

// The fields of a row's "fields" cell: "seq (i32), t_us (u32), d1_mm, q2_deg (dec), [robot]".
// A kind named after a group of fields ("d1_mm, q2_deg, q3_deg, q4_deg (dec)") is each one's.
std::vector<DocField> parse_fields(std::string cell) {
  std::vector<DocField> out;
  cell = trim(cell);
  if (cell == "-" || cell.empty()) return out;
  for (const std::string& item : split_top(cell, ',')) {
    // "[width_px, height_px (i32, 1..8192)]": optional fields, one or several
    const bool optional = item.size() >= 2 && item.front() == '[' && item.back() == ']';
    const std::vector<std::string> group =
        optional ? split_top(trim(item.substr(1, item.size() - 2)), ',')
                 : std::vector<std::string>{item};
    for (const std::string& f : group) {
      DocField d;
      d.optional = optional;
      d.text = f;
      d.kind = kind_named(f);
      out.push_back(d);
    }
  }
  // a group's kind: fields without a note before one whose note is a kind alone
  // ("d1_mm, q2_deg, q3_deg, q4_deg (dec)"), all required or all optional
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i].text.find('(') != std::string::npos) continue;
    for (std::size_t j = i + 1; j < out.size(); ++j) {
      if (out[j].optional != out[i].optional) break;
      const std::string& t = out[j].text;
      const auto open = t.find('(');
      if (open == std::string::npos) continue;
      const std::string note = t.substr(open);
      if (note == "(i32)" || note == "(u32)" || note == "(dec)" || note == "(text)") {
        out[i].kind = out[j].kind;
      }
      break;
    }
  }
  return out;
}

// The table under the heading `heading` (the first line starting with `| code |` after it).
std::vector<DocRow> table_after(const std::string& docs, const std::string& heading) {
  std::vector<DocRow> rows;
  const auto at = docs.find("\n" + heading + "\n");
  if (at == std::string::npos) return rows;
  std::istringstream in(docs.substr(at + heading.size() + 2));
  std::string line;
  bool in_table = false;
  bool has_reply = false;
  while (std::getline(in, line)) {
    if (!in_table) {
      if (line.rfind("| code |", 0) == 0) {
        in_table = true;
        has_reply = line.find("| reply |") != std::string::npos;
      }
      if (line.rfind("#", 0) == 0) break;
      continue;
    }
    if (line.rfind("|---", 0) == 0) continue;
    if (line.rfind("|", 0) != 0) break;
    const auto cells = split_top(line.substr(1), '|');
    if (cells.size() < 2) continue;
    DocRow r;
    r.code = cells[0];
    if (r.code.size() == 4 && r.code.front() == '`' && r.code.back() == '`') {
      r.code = r.code.substr(1, 2);
    }
    r.fields = parse_fields(cells[1]);
    if (has_reply && cells.size() >= 4) r.reply = cells[3];
    rows.push_back(r);
  }
  return rows;
}

std::string code_text(std::uint16_t id) {
  return std::string{static_cast<char>(id >> 8), static_cast<char>(id & 0xff)};
}

const char* kind_text(core::FieldKind k) {
  switch (k) {
    case core::kFieldI32:
      return "i32";
    case core::kFieldU32:
      return "u32";
    case core::kFieldDec:
      return "dec";
    case core::kFieldText:
      return "text";
  }
  return "?";
}

void expect_agree(const std::string& heading, const core::LinkSpec& link) {
  SCOPED_TRACE("docs/protocol.md, " + heading);
  const std::vector<DocRow> rows = table_after(read_docs(), heading);
  ASSERT_FALSE(rows.empty()) << "no code table under the heading";
  std::map<std::string, const DocRow*> documented;
  for (const DocRow& r : rows) {
    EXPECT_TRUE(documented.emplace(r.code, &r).second) << r.code << " documented twice";
  }
  std::map<std::string, const core::CodeSpec*> coded;
  for (std::uint8_t i = 0; i < link.code_count; ++i) {
    coded.emplace(code_text(link.codes[i].code), &link.codes[i]);
  }
  for (const auto& [code, row] : documented) {
    EXPECT_TRUE(coded.count(code)) << code << " is documented but not in the code table";
  }
  for (const auto& [code, spec] : coded) {
    const auto d = documented.find(code);
    if (d == documented.end()) {
      ADD_FAILURE() << code << " is in the code table but not documented";
      continue;
    }
    const std::vector<DocField>& fields = d->second->fields;
    int required = 0;
    for (const DocField& f : fields) required += f.optional ? 0 : 1;
    EXPECT_EQ(required, spec->min_fields) << code << ": required fields";
    // an IM's payload is not a field; every other code's fields are all in the docs
    EXPECT_EQ(static_cast<int>(fields.size()), spec->max_fields) << code << ": fields in all";
    for (std::size_t i = 0; i < fields.size() && i < spec->max_fields; ++i) {
      if (!fields[i].kind) continue;
      const core::FieldKind k = core::field_kind(*spec, static_cast<std::uint8_t>(i));
      EXPECT_EQ(kind_text(*fields[i].kind), std::string(kind_text(k)))
          << code << " field " << i << " ('" << fields[i].text << "')";
    }
  }
}

// The packets a reply cell names before "later" (events that follow): "`AK,OP,count,`" ->
// "AK,OP,count,".
std::vector<std::string> replies_named(const std::string& cell) {
  std::vector<std::string> out;
  const std::string head = cell.substr(0, cell.find("later"));
  for (std::size_t at = head.find('`'); at != std::string::npos;) {
    const std::size_t end = head.find('`', at + 1);
    if (end == std::string::npos) break;
    out.push_back(head.substr(at + 1, end - at - 1));
    at = head.find('`', end + 1);
  }
  return out;
}

// The docs' reply column against the reply table (scaratwin/protocol/replies.hpp): every
// packet a request's cell names is an AK of that request or a row of the table for it, every
// row is named in its request's cell, and a request answered in several parts also names the
// AK that ends them.
void expect_replies_agree(const std::string& heading, std::span<const ReplyRule> rules,
                          char delimiter) {
  SCOPED_TRACE("docs/protocol.md, " + heading + ", the reply column");
  const std::vector<DocRow> rows = table_after(read_docs(), heading);
  ASSERT_FALSE(rows.empty());
  for (const DocRow& row : rows) {
    const std::vector<std::string> named = replies_named(row.reply);
    EXPECT_FALSE(named.empty()) << row.code << ": no reply named in '" << row.reply << "'";
    bool acked = false;
    for (const std::string& n : named) {
      const std::string code = n.substr(0, 2);
      if (code == "AK") {
        acked = true;
        EXPECT_EQ(n.substr(2, 4), std::string{delimiter} + row.code + delimiter)
            << row.code << ": '" << n << "' acknowledges another request";
        continue;
      }
      bool ruled = false;
      for (const ReplyRule& r : rules) ruled = ruled || (r.request == row.code && r.reply == code);
      EXPECT_TRUE(ruled) << row.code << ": the docs name '" << n
                         << "' as a reply, the reply table does not";
    }
    for (const ReplyRule& r : rules) {
      if (r.request != row.code) continue;
      bool documented = false;
      for (const std::string& n : named) documented = documented || n.substr(0, 2) == r.reply;
      EXPECT_TRUE(documented) << row.code << ": the reply table has " << r.reply
                              << ", the docs do not name it in '" << row.reply << "'";
      if (r.partial) {
        EXPECT_TRUE(acked) << row.code << ": answered in parts, but no AK ends them";
      }
    }
  }
  for (const ReplyRule& r : rules) {
    bool found = false;
    for (const DocRow& row : rows) found = found || row.code == r.request;
    EXPECT_TRUE(found) << "the reply table answers " << r.request << ", a request not documented";
  }
}

TEST(ProtocolDocs, TheRepliesAreTheReplyTables) {
  expect_replies_agree("### hub -> simulator", tcp_reply_rules(), ',');
  expect_replies_agree("### host -> device", serial_reply_rules(), '=');
}

// The reply table against packets built here: a JA answers only its own JD, an OP is one of
// several answers to OP, an ER answers anything, an AK only its own request, an event nothing.
TEST(ProtocolReplies, EachPacketAnswersOnlyTheRequestItBelongsTo) {
  const JointApplied ja{7, 100, 0};
  EXPECT_EQ(reply_match("JD", 7, TcpFromSim{ja}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("TJ", 7, TcpFromSim{ja}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("JD", 8, TcpFromSim{ja}), ReplyMatch::kNo);
  EXPECT_EQ(reply_match("QS", std::nullopt, TcpFromSim{ja}), ReplyMatch::kNo);
  EXPECT_EQ(reply_match("OP", std::nullopt, TcpFromSim{ObjectPose{}}), ReplyMatch::kPartial);
  EXPECT_EQ(reply_match("OP", std::nullopt, TcpFromSim{Ack{"OP", 3}}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("SP", std::nullopt, TcpFromSim{Ack{"OP", 3}}), ReplyMatch::kNo);
  EXPECT_EQ(reply_match("CS", std::nullopt, TcpFromSim{ErrorReply{11, 0}}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("QS", std::nullopt, TcpFromSim{SimState{}}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("GR", std::nullopt, TcpFromSim{JointWarning{}}), ReplyMatch::kNo);
  EXPECT_EQ(reply_match("QS", std::nullopt, SerialFromDevice{DeviceState{}}), ReplyMatch::kFinal);
  EXPECT_EQ(reply_match("HM", std::nullopt, SerialFromDevice{DeviceEvent{}}), ReplyMatch::kNo);
  EXPECT_EQ(reply_match("HI", std::nullopt, SerialFromDevice{PeerHello{}}), ReplyMatch::kFinal);
  EXPECT_EQ(code_of(SerialFromDevice{DeviceEvent{}}), "EV");
  EXPECT_EQ(code_of(TcpFromSim{Image{}}), "IM");
}

TEST(ProtocolDocs, TheVirtualLinksTablesAreTheCodeTables) {
  expect_agree("### hub -> simulator", core::kTcpHubToSim);
  expect_agree("### simulator -> hub", core::kTcpSimToHub);
}

TEST(ProtocolDocs, ThePhysicalLinksTablesAreTheCodeTables) {
  expect_agree("### host -> device", core::kSerialHostToDevice);
  expect_agree("### device -> host", core::kSerialDeviceToHost);
}

// The reader itself, on rows written here: a group's kind, optional fields, no fields.
TEST(ProtocolDocs, TheTableReaderReadsGroupsAndOptionalFields) {
  const auto f = parse_fields(
      "seq (i32, 0..65535), t_us (u32), d1_mm, q2_deg (dec), [robot], [token (text; `-`: none)]");
  ASSERT_EQ(f.size(), 6u);
  EXPECT_EQ(f[0].kind, core::kFieldI32);
  EXPECT_EQ(f[1].kind, core::kFieldU32);
  EXPECT_EQ(f[2].kind, core::kFieldDec);
  EXPECT_EQ(f[3].kind, core::kFieldDec);
  EXPECT_FALSE(f[3].optional);
  EXPECT_TRUE(f[4].optional);
  EXPECT_FALSE(f[4].kind.has_value());
  EXPECT_TRUE(f[5].optional);
  EXPECT_EQ(f[5].kind, core::kFieldText);
  EXPECT_TRUE(parse_fields("-").empty());
  // several optional fields in one bracket; a note that is more than a kind names no group
  const auto cs = parse_fields("[width_px, height_px (i32, 1..8192)]");
  ASSERT_EQ(cs.size(), 2u);
  EXPECT_TRUE(cs[0].optional && cs[1].optional);
  EXPECT_FALSE(cs[0].kind.has_value());
  EXPECT_EQ(cs[1].kind, core::kFieldI32);
  const auto hi = parse_fields("proto_version, device (text, e.g. `scara-uno`)");
  EXPECT_FALSE(hi[0].kind.has_value());
  EXPECT_EQ(hi[1].kind, core::kFieldText);
  EXPECT_EQ(parse_fields("z, j2, j3 (steps), wrist_cdeg").size(), 4u);
  EXPECT_FALSE(parse_fields("z, j2, j3 (steps), wrist_cdeg")[0].kind.has_value());
}

}  // namespace
}  // namespace scaratwin::protocol
