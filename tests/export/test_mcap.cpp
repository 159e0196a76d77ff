// The MCAP writer's bytes, read back here by a reader written from the spec
// (https://mcap.dev/spec) and nothing of the writer's: opcodes, little-endian lengths and
// fields, offsets, and every CRC checked against zlib's crc32() as an oracle.
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "scaratwin/export/mcap.hpp"

namespace mcap = scaratwin::mcap;

namespace {

std::uint32_t zlib_crc(std::string_view b) {
  return static_cast<std::uint32_t>(
      ::crc32(0L, reinterpret_cast<const Bytef*>(b.data()), static_cast<uInt>(b.size())));
}

// A cursor over little-endian fields.
struct In {
  std::string_view b;
  std::size_t at = 0;
  std::uint64_t le(int n) {
    EXPECT_LE(at + n, b.size());
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint64_t{static_cast<std::uint8_t>(b[at + i])} << (8 * i);
    at += n;
    return v;
  }
  std::uint8_t u8() { return static_cast<std::uint8_t>(le(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(le(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(le(4)); }
  std::uint64_t u64() { return le(8); }
  std::string_view bytes(std::size_t n) {
    EXPECT_LE(at + n, b.size());
    std::string_view v = b.substr(at, n);
    at += n;
    return v;
  }
  std::string str() { return std::string(bytes(u32())); }
  bool done() const { return at >= b.size(); }
};

struct Record {
  std::uint8_t op = 0;
  std::size_t offset = 0;  // of the opcode
  std::string_view content;
};

// The records of `b` from `at` until `stop_op` (included) or the end.
std::vector<Record> records(std::string_view b, std::size_t at, int stop_op = -1) {
  std::vector<Record> out;
  In in{b, at};
  while (!in.done()) {
    Record r;
    r.offset = in.at;
    r.op = in.u8();
    const std::uint64_t n = in.u64();
    r.content = in.bytes(n);
    out.push_back(r);
    if (r.op == stop_op) break;
  }
  return out;
}

struct File {
  std::string bytes;
  mcap::WriterStats stats;
};

mcap::Writer::Sink into(std::string& s) {
  return [&s](std::string_view b) { s.append(b); };
}

const std::string kMagic("\x89MCAP0\r\n", 8);

}  // namespace

TEST(McapWriter, CrcIsZlibsCrc32AndContinues) {
  std::mt19937 rng(7);
  std::string data(4099, '\0');
  for (char& c : data) c = static_cast<char>(rng());
  EXPECT_EQ(mcap::crc32(data), zlib_crc(data));
  EXPECT_EQ(mcap::crc32(data.substr(1000), mcap::crc32(data.substr(0, 1000))), zlib_crc(data));
  EXPECT_EQ(mcap::crc32(""), 0U);
  EXPECT_EQ(mcap::crc32("123456789"), 0xCBF43926U);  // the CRC-32 check value
}

TEST(McapWriter, EmptyFileIsMagicHeaderDataEndSummaryFooterMagic) {
  std::string f;
  mcap::WriterOptions o;
  o.profile = "x-test";
  o.library = "lib 1";
  mcap::Writer w(into(f), o);
  const auto stats = w.finish();
  EXPECT_EQ(stats.bytes, f.size());
  ASSERT_GT(f.size(), 16U);
  EXPECT_EQ(f.substr(0, 8), kMagic);
  EXPECT_EQ(f.substr(f.size() - 8), kMagic);
  const auto recs = records(std::string_view(f).substr(0, f.size() - 8), 8);
  ASSERT_GE(recs.size(), 3U);
  // Header: profile, library
  EXPECT_EQ(recs[0].op, 0x01);
  EXPECT_EQ(recs[0].content.size(), 4U + 6 + 4 + 5);
  In h{recs[0].content};
  EXPECT_EQ(h.str(), "x-test");
  EXPECT_EQ(h.str(), "lib 1");
  // Data End: the CRC of every byte before it
  EXPECT_EQ(recs[1].op, 0x0F);
  EXPECT_EQ(In{recs[1].content}.u32(), zlib_crc(std::string_view(f).substr(0, recs[1].offset)));
  // Footer: 20 bytes, last record before the magic
  const Record& footer = recs.back();
  EXPECT_EQ(footer.op, 0x02);
  EXPECT_EQ(footer.content.size(), 20U);
  EXPECT_EQ(footer.offset + 9 + 20, f.size() - 8);
}

TEST(McapWriter, UncompressedChunkHoldsMessagesWithIndexesAndCrcs) {
  std::string f;
  mcap::WriterOptions o;
  o.compression = mcap::Compression::kNone;
  mcap::Writer w(into(f), o);
  const auto schema = w.add_schema("s.Name", "jsonschema", "{\"type\":\"object\"}");
  const auto a = w.add_channel(schema, "/a", "json", {{"k", "v"}});
  const auto b = w.add_channel(schema, "/b", "json");
  EXPECT_EQ(schema, 1);
  EXPECT_EQ(a, 1);
  EXPECT_EQ(b, 2);
  w.add_message(a, 1000, 1001, "{\"x\":1}");
  w.add_message(b, 2000, 2000, "{}");
  w.add_message(a, 3000, 3000, "{\"x\":2}");
  const auto stats = w.finish();
  EXPECT_EQ(stats.messages, 3U);
  EXPECT_EQ(stats.chunks, 1U);

  const auto recs = records(f, 8, 0x0F);
  ASSERT_EQ(recs.size(), 8U);  // header, schema, 2 channels, chunk, 2 indexes, data end
  // Schema: id, name, encoding, uint32-length data
  ASSERT_EQ(recs[1].op, 0x03);
  In s{recs[1].content};
  EXPECT_EQ(s.u16(), 1);
  EXPECT_EQ(s.str(), "s.Name");
  EXPECT_EQ(s.str(), "jsonschema");
  EXPECT_EQ(s.str(), "{\"type\":\"object\"}");
  EXPECT_TRUE(s.done());
  // Channel: id, schema id, topic, encoding, map<string,string> with its byte length
  ASSERT_EQ(recs[2].op, 0x04);
  In c{recs[2].content};
  EXPECT_EQ(c.u16(), 1);
  EXPECT_EQ(c.u16(), 1);
  EXPECT_EQ(c.str(), "/a");
  EXPECT_EQ(c.str(), "json");
  EXPECT_EQ(c.u32(), 4U + 1 + 4 + 1);
  EXPECT_EQ(c.str(), "k");
  EXPECT_EQ(c.str(), "v");
  EXPECT_TRUE(c.done());
  // Chunk: times, sizes, CRC of the uncompressed records, compression "", uint64-length records
  ASSERT_EQ(recs[4].op, 0x06);
  In k{recs[4].content};
  EXPECT_EQ(k.u64(), 1000U);
  EXPECT_EQ(k.u64(), 3000U);
  const std::uint64_t size = k.u64();
  const std::uint32_t crc = k.u32();
  EXPECT_EQ(k.str(), "");
  ASSERT_EQ(k.u64(), size);
  const std::string_view inner = k.bytes(size);
  EXPECT_TRUE(k.done());
  EXPECT_EQ(crc, zlib_crc(inner));
  const auto msgs = records(inner, 0);
  ASSERT_EQ(msgs.size(), 3U);
  const std::uint16_t channels[] = {1, 2, 1};
  const std::uint32_t sequences[] = {0, 0, 1};
  const std::uint64_t times[] = {1000, 2000, 3000};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(msgs[i].op, 0x05);
    In m{msgs[i].content};
    EXPECT_EQ(m.u16(), channels[i]);
    EXPECT_EQ(m.u32(), sequences[i]);
    EXPECT_EQ(m.u64(), times[i]);
    EXPECT_EQ(m.u64(), i == 0 ? 1001U : times[i]);
  }
  EXPECT_EQ(msgs[0].content.substr(22), "{\"x\":1}");
  // a Message Index per channel: (log time, offset into the uncompressed records)
  for (int r = 5; r <= 6; ++r) {
    ASSERT_EQ(recs[r].op, 0x07);
    In m{recs[r].content};
    const std::uint16_t channel = m.u16();
    const std::uint32_t n = m.u32();
    EXPECT_EQ(n, channel == 1 ? 32U : 16U);
    for (std::uint32_t e = 0; e < n / 16; ++e) {
      const std::uint64_t t = m.u64();
      const std::uint64_t at = m.u64();
      const auto hit = std::find_if(msgs.begin(), msgs.end(), [at](const Record& x) {
        return x.offset == static_cast<std::size_t>(at);
      });
      ASSERT_NE(hit, msgs.end());
      EXPECT_EQ(In{hit->content}.u16(), channel);
      EXPECT_EQ(t, times[hit - msgs.begin()]);
    }
  }
  ASSERT_EQ(recs[7].op, 0x0F);
  EXPECT_EQ(In{recs[7].content}.u32(), zlib_crc(std::string_view(f).substr(0, recs[7].offset)));

  // Footer: where the summary and its offsets start, and the CRC from the summary's first byte
  // through summary_offset_start
  const std::size_t footer = f.size() - 8 - 29;
  In ft{std::string_view(f).substr(footer)};
  EXPECT_EQ(ft.u8(), 0x02);
  EXPECT_EQ(ft.u64(), 20U);
  const std::uint64_t summary_start = ft.u64();
  const std::uint64_t offsets_start = ft.u64();
  EXPECT_EQ(summary_start, recs[7].offset + 9 + 4);
  EXPECT_EQ(ft.u32(),
            zlib_crc(std::string_view(f).substr(summary_start, footer + 25 - summary_start)));

  // the summary: schemas, channels, statistics, chunk index, then the summary offsets
  const auto summary = records(std::string_view(f).substr(0, offsets_start),
                               static_cast<std::size_t>(summary_start));
  std::vector<std::uint8_t> ops;
  for (const Record& r : summary) ops.push_back(r.op);
  EXPECT_EQ(ops, (std::vector<std::uint8_t>{0x03, 0x04, 0x04, 0x0B, 0x08}));
  EXPECT_EQ(summary[0].content, recs[1].content);
  In st{summary[3].content};
  EXPECT_EQ(st.u64(), 3U);  // messages
  EXPECT_EQ(st.u16(), 1);   // schemas
  EXPECT_EQ(st.u32(), 2U);  // channels
  EXPECT_EQ(st.u32(), 0U);  // attachments
  EXPECT_EQ(st.u32(), 0U);  // metadata
  EXPECT_EQ(st.u32(), 1U);  // chunks
  EXPECT_EQ(st.u64(), 1000U);
  EXPECT_EQ(st.u64(), 3000U);
  EXPECT_EQ(st.u32(), 20U);
  EXPECT_EQ(st.u16(), 1);
  EXPECT_EQ(st.u64(), 2U);
  In ci{summary[4].content};
  EXPECT_EQ(ci.u64(), 1000U);
  EXPECT_EQ(ci.u64(), 3000U);
  EXPECT_EQ(ci.u64(), recs[4].offset);
  EXPECT_EQ(ci.u64(), 9 + recs[4].content.size());
  EXPECT_EQ(ci.u32(), 20U);
  EXPECT_EQ(ci.u16(), 1);
  EXPECT_EQ(ci.u64(), recs[5].offset);
  EXPECT_EQ(ci.u16(), 2);
  EXPECT_EQ(ci.u64(), recs[6].offset);
  EXPECT_EQ(ci.u64(), recs[7].offset - recs[5].offset);
  EXPECT_EQ(ci.str(), "");
  EXPECT_EQ(ci.u64(), size);
  EXPECT_EQ(ci.u64(), size);
  // a Summary Offset per group, each pointing at its group's first record
  const auto offsets = records(std::string_view(f).substr(0, footer), offsets_start);
  ASSERT_EQ(offsets.size(), 4U);
  const std::uint8_t groups[] = {0x03, 0x04, 0x0B, 0x08};
  for (int g = 0; g < 4; ++g) {
    In so{offsets[g].content};
    EXPECT_EQ(offsets[g].op, 0x0E);
    EXPECT_EQ(so.u8(), groups[g]);
    const std::uint64_t start = so.u64();
    EXPECT_EQ(static_cast<std::uint8_t>(f[start]), groups[g]);
    EXPECT_GT(so.u64(), 9U);
  }
}

TEST(McapWriter, ZstdChunksCloseAtTheirSizeAndDecompressToTheirRecords) {
  std::string f;
  mcap::WriterOptions o;
  o.chunk_size_bytes = 1000;
  mcap::Writer w(into(f), o);
  const auto ch = w.add_channel(w.add_schema("s", "jsonschema", "{}"), "/t", "json");
  const std::string payload(100, 'x');
  for (int i = 0; i < 50; ++i) w.add_message(ch, 1000U * i, 1000U * i, payload);
  const auto stats = w.finish();
  // 131 bytes per message record: a chunk closes at its 8th message
  EXPECT_EQ(stats.chunks, 7U);
  std::uint64_t seen = 0;
  for (const Record& r : records(f, 8, 0x0F)) {
    if (r.op != 0x06) continue;
    In k{r.content};
    k.u64();
    k.u64();
    const std::uint64_t size = k.u64();
    const std::uint32_t crc = k.u32();
    EXPECT_EQ(k.str(), "zstd");
    const std::string_view packed = k.bytes(k.u64());
    std::string plain(size, '\0');
    ASSERT_EQ(ZSTD_decompress(plain.data(), plain.size(), packed.data(), packed.size()), size);
    EXPECT_EQ(crc, zlib_crc(plain));
    for (const Record& m : records(plain, 0)) {
      EXPECT_EQ(m.op, 0x05);
      In msg{m.content};
      msg.u16();
      EXPECT_EQ(msg.u32(), seen);  // the channel's sequence runs on across chunks
      ++seen;
    }
  }
  EXPECT_EQ(seen, 50U);
}

TEST(McapWriter, AttachmentAndMetadataSitOutsideChunksWithTheirIndexes) {
  std::string f;
  mcap::Writer w(into(f));
  const auto ch = w.add_channel(w.add_schema("s", "jsonschema", "{}"), "/t", "json");
  w.add_message(ch, 5, 5, "{}");
  w.add_attachment("a.toml", "application/toml", "x = 1\n", 7, 0);
  w.add_metadata("m", {{"a", "1"}});
  const auto stats = w.finish();
  EXPECT_EQ(stats.chunks, 1U);  // the attachment closed the chunk before it
  const auto recs = records(f, 8, 0x0F);
  std::vector<std::uint8_t> ops;
  for (const Record& r : recs) ops.push_back(r.op);
  EXPECT_EQ(ops, (std::vector<std::uint8_t>{0x01, 0x03, 0x04, 0x06, 0x07, 0x09, 0x0C, 0x0F}));
  // Attachment: times, name, media type, uint64-length data, CRC of the fields before it
  In a{recs[5].content};
  EXPECT_EQ(a.u64(), 7U);
  EXPECT_EQ(a.u64(), 0U);
  EXPECT_EQ(a.str(), "a.toml");
  EXPECT_EQ(a.str(), "application/toml");
  EXPECT_EQ(a.bytes(a.u64()), "x = 1\n");
  const std::size_t fields = a.at;
  EXPECT_EQ(a.u32(), zlib_crc(recs[5].content.substr(0, fields)));
  EXPECT_TRUE(a.done());
  // the summary's indexes point back at them
  bool attachment_index = false, metadata_index = false;
  In ft2{std::string_view(f).substr(f.size() - 8 - 29 + 9)};
  const std::uint64_t summary_start = ft2.u64();
  const std::uint64_t offsets_start = ft2.u64();
  for (const Record& r : records(std::string_view(f).substr(0, offsets_start), summary_start)) {
    In x{r.content};
    if (r.op == 0x0A) {
      attachment_index = true;
      EXPECT_EQ(x.u64(), recs[5].offset);
      EXPECT_EQ(x.u64(), 9 + recs[5].content.size());
      EXPECT_EQ(x.u64(), 7U);
      EXPECT_EQ(x.u64(), 0U);
      EXPECT_EQ(x.u64(), 6U);
      EXPECT_EQ(x.str(), "a.toml");
      EXPECT_EQ(x.str(), "application/toml");
    }
    if (r.op == 0x0D) {
      metadata_index = true;
      EXPECT_EQ(x.u64(), recs[6].offset);
      EXPECT_EQ(x.u64(), 9 + recs[6].content.size());
      EXPECT_EQ(x.str(), "m");
    }
  }
  EXPECT_TRUE(attachment_index);
  EXPECT_TRUE(metadata_index);
}
