#include "scaratwin/export/mcap.hpp"

#include <zstd.h>

#include <array>

#include "scaratwin/core/result.hpp"

namespace scaratwin::mcap {
namespace {

// little-endian fields of the spec's "Serialization" section
void put_u8(std::string& out, std::uint8_t v) { out.push_back(static_cast<char>(v)); }

template <typename T>
void put_le(std::string& out, T v) {
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    out.push_back(static_cast<char>(static_cast<std::uint8_t>(v >> (8 * i))));
  }
}
void put_u16(std::string& out, std::uint16_t v) { put_le(out, v); }
void put_u32(std::string& out, std::uint32_t v) { put_le(out, v); }
void put_u64(std::string& out, std::uint64_t v) { put_le(out, v); }

void put_string(std::string& out, std::string_view s) {
  put_u32(out, static_cast<std::uint32_t>(s.size()));
  out.append(s);
}

void put_string_map(std::string& out, const std::map<std::string, std::string>& m) {
  std::string body;
  for (const auto& [k, v] : m) {
    put_string(body, k);
    put_string(body, v);
  }
  put_u32(out, static_cast<std::uint32_t>(body.size()));
  out += body;
}

std::string record(Op op, std::string_view content) {
  std::string r;
  r.reserve(9 + content.size());
  put_u8(r, static_cast<std::uint8_t>(op));
  put_u64(r, content.size());
  r.append(content);
  return r;
}

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}
constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

}  // namespace

std::uint32_t crc32(std::string_view bytes, std::uint32_t crc) {
  crc = ~crc;
  for (char ch : bytes) {
    crc = kCrcTable[(crc ^ static_cast<std::uint8_t>(ch)) & 0xFFU] ^ (crc >> 8);
  }
  return ~crc;
}

Writer::Writer(Sink sink, WriterOptions options)
    : sink_(std::move(sink)), options_(std::move(options)) {
  emit(std::string_view(kMagic, sizeof kMagic));
  std::string header;
  put_string(header, options_.profile);
  put_string(header, options_.library);
  emit_record(Op::kHeader, header);
}

void Writer::emit(std::string_view bytes, bool data_section) {
  // the data section's CRC runs from the file's first byte to the Data End record (as the MCAP
  // project's own writers count it)
  if (data_section) data_crc_ = crc32(bytes, data_crc_);
  offset_ += bytes.size();
  sink_(bytes);
}

void Writer::emit_record(Op op, std::string_view content, bool data_section) {
  emit(record(op, content), data_section);
}

std::uint16_t Writer::add_schema(std::string_view name, std::string_view encoding,
                                 std::string_view data) {
  SCARATWIN_CHECK(!finished_, "add_schema() after finish()");
  SCARATWIN_CHECK(schema_count_ < 0xFFFF, "too many schemas");
  const std::uint16_t id = ++schema_count_;
  std::string c;
  put_u16(c, id);
  put_string(c, name);
  put_string(c, encoding);
  put_string(c, data);  // uint32 length-prefixed bytes
  const std::string r = record(Op::kSchema, c);
  schemas_ += r;
  emit(r);
  return id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema_id, std::string_view topic,
                                  std::string_view message_encoding,
                                  const std::map<std::string, std::string>& metadata) {
  SCARATWIN_CHECK(!finished_, "add_channel() after finish()");
  SCARATWIN_CHECK(schema_id <= schema_count_, "add_channel() with an unknown schema id");
  SCARATWIN_CHECK(channel_count_ < 0xFFFF, "too many channels");
  const std::uint16_t id = ++channel_count_;
  std::string c;
  put_u16(c, id);
  put_u16(c, schema_id);
  put_string(c, topic);
  put_string(c, message_encoding);
  put_string_map(c, metadata);
  const std::string r = record(Op::kChannel, c);
  channels_ += r;
  emit(r);
  return id;
}

void Writer::add_message(std::uint16_t channel_id, std::uint64_t log_time_ns,
                         std::uint64_t publish_time_ns, std::string_view data) {
  SCARATWIN_CHECK(!finished_, "add_message() after finish()");
  SCARATWIN_CHECK(channel_id >= 1 && channel_id <= channel_count_,
                  "add_message() on an unknown channel");
  if (chunk_.empty() || log_time_ns < chunk_start_ns_) chunk_start_ns_ = log_time_ns;
  if (chunk_.empty() || log_time_ns > chunk_end_ns_) chunk_end_ns_ = log_time_ns;
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  std::string c;
  c.reserve(22 + data.size());
  put_u16(c, channel_id);
  put_u32(c, sequence_[channel_id]++);
  put_u64(c, log_time_ns);
  put_u64(c, publish_time_ns);
  c.append(data);
  chunk_ += record(Op::kMessage, c);

  if (stats_.messages == 0 || log_time_ns < stats_.message_start_time_ns) {
    stats_.message_start_time_ns = log_time_ns;
  }
  if (stats_.messages == 0 || log_time_ns > stats_.message_end_time_ns) {
    stats_.message_end_time_ns = log_time_ns;
  }
  ++stats_.messages;
  ++stats_.channel_message_counts[channel_id];
  if (chunk_.size() >= options_.chunk_size_bytes) close_chunk();
}

void Writer::close_chunk() {
  if (chunk_.empty()) return;
  std::string compressed;
  const char* compression = "";
  if (options_.compression == Compression::kZstd) {
    compressed.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compress(compressed.data(), compressed.size(), chunk_.data(),
                                        chunk_.size(), options_.zstd_level);
    SCARATWIN_CHECK(ZSTD_isError(n) == 0, "zstd failed to compress a chunk");
    compressed.resize(n);
    compression = "zstd";
  } else {
    compressed = chunk_;
  }
  std::string c;
  put_u64(c, chunk_start_ns_);
  put_u64(c, chunk_end_ns_);
  put_u64(c, chunk_.size());
  put_u32(c, crc32(chunk_));
  put_string(c, compression);
  put_u64(c, compressed.size());  // uint64 length-prefixed records
  c += compressed;

  ChunkIndex ix;
  ix.start_ns = chunk_start_ns_;
  ix.end_ns = chunk_end_ns_;
  ix.offset = offset_;
  ix.compressed_size = compressed.size();
  ix.uncompressed_size = chunk_.size();
  emit_record(Op::kChunk, c);
  ix.length = offset_ - ix.offset;

  // one Message Index record per channel of the chunk, right after it
  const std::uint64_t index_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    std::string m;
    put_u16(m, channel);
    put_u32(m, static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [t, at] : entries) {
      put_u64(m, t);
      put_u64(m, at);
    }
    ix.index_offsets.emplace_back(channel, offset_);
    emit_record(Op::kMessageIndex, m);
  }
  ix.index_length = offset_ - index_start;
  chunk_indexes_.push_back(std::move(ix));
  ++stats_.chunks;
  chunk_.clear();
  chunk_index_.clear();
}

void Writer::add_attachment(std::string_view name, std::string_view media_type,
                            std::string_view data, std::uint64_t log_time_ns,
                            std::uint64_t create_time_ns) {
  SCARATWIN_CHECK(!finished_, "add_attachment() after finish()");
  close_chunk();  // attachments never sit inside a chunk
  std::string c;
  put_u64(c, log_time_ns);
  put_u64(c, create_time_ns);
  put_string(c, name);
  put_string(c, media_type);
  put_u64(c, data.size());  // uint64 length-prefixed data
  c.append(data);
  put_u32(c, crc32(c));  // over every preceding field
  const std::uint64_t at = offset_;
  emit_record(Op::kAttachment, c);

  std::string ix;
  put_u64(ix, at);
  put_u64(ix, offset_ - at);
  put_u64(ix, log_time_ns);
  put_u64(ix, create_time_ns);
  put_u64(ix, data.size());
  put_string(ix, name);
  put_string(ix, media_type);
  attachment_indexes_ += record(Op::kAttachmentIndex, ix);
  ++attachment_count_;
}

void Writer::add_metadata(std::string_view name,
                          const std::map<std::string, std::string>& metadata) {
  SCARATWIN_CHECK(!finished_, "add_metadata() after finish()");
  close_chunk();
  std::string c;
  put_string(c, name);
  put_string_map(c, metadata);
  const std::uint64_t at = offset_;
  emit_record(Op::kMetadata, c);
  std::string ix;
  put_u64(ix, at);
  put_u64(ix, offset_ - at);
  put_string(ix, name);
  metadata_indexes_ += record(Op::kMetadataIndex, ix);
  ++metadata_count_;
}

WriterStats Writer::finish() {
  SCARATWIN_CHECK(!finished_, "finish() twice");
  close_chunk();
  std::string end;
  put_u32(end, data_crc_);
  emit_record(Op::kDataEnd, end);
  finished_ = true;

  // the summary, grouped by opcode; each group's place goes to a Summary Offset record
  const std::uint64_t summary_start = offset_;
  std::uint32_t summary_crc = 0;
  std::string offsets;
  const auto group = [&](Op op, const std::string& records) {
    if (records.empty()) return;
    put_u8(offsets, static_cast<std::uint8_t>(Op::kSummaryOffset));
    put_u64(offsets, 17);
    put_u8(offsets, static_cast<std::uint8_t>(op));
    put_u64(offsets, offset_);
    put_u64(offsets, records.size());
    summary_crc = crc32(records, summary_crc);
    emit(records, false);
  };
  group(Op::kSchema, schemas_);
  group(Op::kChannel, channels_);

  std::string stats;
  put_u64(stats, stats_.messages);
  put_u16(stats, schema_count_);
  put_u32(stats, channel_count_);
  put_u32(stats, attachment_count_);
  put_u32(stats, metadata_count_);
  put_u32(stats, stats_.chunks);
  put_u64(stats, stats_.message_start_time_ns);
  put_u64(stats, stats_.message_end_time_ns);
  std::string counts;
  for (const auto& [channel, n] : stats_.channel_message_counts) {
    put_u16(counts, channel);
    put_u64(counts, n);
  }
  put_u32(stats, static_cast<std::uint32_t>(counts.size()));
  stats += counts;
  group(Op::kStatistics, record(Op::kStatistics, stats));

  std::string chunk_indexes;
  for (const ChunkIndex& ix : chunk_indexes_) {
    std::string c;
    put_u64(c, ix.start_ns);
    put_u64(c, ix.end_ns);
    put_u64(c, ix.offset);
    put_u64(c, ix.length);
    put_u32(c, static_cast<std::uint32_t>(ix.index_offsets.size() * 10));
    for (const auto& [channel, at] : ix.index_offsets) {
      put_u16(c, channel);
      put_u64(c, at);
    }
    put_u64(c, ix.index_length);
    put_string(c, options_.compression == Compression::kZstd ? "zstd" : "");
    put_u64(c, ix.compressed_size);
    put_u64(c, ix.uncompressed_size);
    chunk_indexes += record(Op::kChunkIndex, c);
  }
  group(Op::kChunkIndex, chunk_indexes);
  group(Op::kAttachmentIndex, attachment_indexes_);
  group(Op::kMetadataIndex, metadata_indexes_);

  const std::uint64_t offsets_start = offset_;
  summary_crc = crc32(offsets, summary_crc);
  emit(offsets, false);

  // the footer's CRC runs from the summary's first byte through summary_offset_start
  std::string footer;
  put_u8(footer, static_cast<std::uint8_t>(Op::kFooter));
  put_u64(footer, 20);
  put_u64(footer, summary_start);
  put_u64(footer, offsets.empty() ? 0 : offsets_start);
  summary_crc = crc32(footer, summary_crc);
  put_u32(footer, summary_crc);
  emit(footer, false);
  emit(std::string_view(kMagic, sizeof kMagic), false);
  stats_.bytes = offset_;
  return stats_;
}

}  // namespace scaratwin::mcap
