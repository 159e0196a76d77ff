// An MCAP writer (https://mcap.dev/spec, major version 0): schemas, channels and messages in
// chunks compressed with zstd, each chunk followed by its message indexes; attachments and
// metadata in the data section; then a summary (schemas, channels, statistics, chunk,
// attachment and metadata indexes), its summary offsets and the footer. Pure: the bytes go to
// a sink the caller gives, in file order; no file, no clock.
//
// Times are Timestamps of the spec: nanoseconds since an epoch the caller chooses.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace scaratwin::mcap {

// The 8 magic bytes that open and close a file: 0x89 'M' 'C' 'A' 'P' '0' '\r' '\n'.
inline constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

// Record opcodes (the spec's "Records" section).
enum class Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// The CRC-32 of the spec (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib's crc32()),
// continued from `crc` (0 to start).
std::uint32_t crc32(std::string_view bytes, std::uint32_t crc = 0);

enum class Compression { kNone, kZstd };

struct WriterOptions {
  std::string profile;  // the Header's profile ("" = none)
  std::string library = "scaratwin";
  // a chunk is closed once its uncompressed records reach this many bytes
  std::size_t chunk_size_bytes = 1 << 20;
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
};

// What finish() wrote.
struct WriterStats {
  std::uint64_t bytes = 0;  // the whole file
  std::uint64_t messages = 0;
  std::uint32_t chunks = 0;
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

// Writes one file into a sink. Call order: schemas and channels before the messages that use
// them (they are written to the data section at once, outside chunks), messages in any order
// (readers that stream a file see them in call order, so give them in log time order),
// attachments and metadata at any time (each closes the open chunk first), finish() once.
class Writer {
 public:
  using Sink = std::function<void(std::string_view bytes)>;

  // Writes the magic and the Header.
  Writer(Sink sink, WriterOptions options = {});

  // A Schema record; its id (1, 2, ...).
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  // A Channel record; its id (1, 2, ...). `schema_id` 0 is a channel without a schema.
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic,
                            std::string_view message_encoding,
                            const std::map<std::string, std::string>& metadata = {});
  // A Message record in the open chunk (a chunk is opened when none is). Its sequence number
  // is the channel's count of messages so far.
  void add_message(std::uint16_t channel_id, std::uint64_t log_time_ns,
                   std::uint64_t publish_time_ns, std::string_view data);
  void add_attachment(std::string_view name, std::string_view media_type, std::string_view data,
                      std::uint64_t log_time_ns, std::uint64_t create_time_ns);
  void add_metadata(std::string_view name, const std::map<std::string, std::string>& metadata);

  // Closes the open chunk and writes Data End, the summary, the summary offsets, the Footer
  // and the closing magic. Nothing may be added afterwards.
  WriterStats finish();

  // Bytes written to the sink so far.
  std::uint64_t offset() const { return offset_; }

 private:
  struct ChunkIndex {
    std::uint64_t start_ns = 0, end_ns = 0, offset = 0, length = 0;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;
    std::uint64_t index_length = 0, compressed_size = 0, uncompressed_size = 0;
  };
  void emit(std::string_view bytes, bool data_section = true);
  void emit_record(Op op, std::string_view content, bool data_section = true);
  void close_chunk();

  Sink sink_;
  WriterOptions options_;
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;
  bool finished_ = false;

  std::string schemas_;   // the Schema records, repeated in the summary
  std::string channels_;  // the Channel records, repeated in the summary
  std::uint16_t schema_count_ = 0;
  std::uint16_t channel_count_ = 0;
  std::map<std::uint16_t, std::uint32_t> sequence_;

  // the open chunk: its uncompressed records and each channel's (log time, offset) pairs
  std::string chunk_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;

  std::vector<ChunkIndex> chunk_indexes_;
  std::string attachment_indexes_;
  std::string metadata_indexes_;
  std::uint32_t attachment_count_ = 0, metadata_count_ = 0;
  WriterStats stats_;
};

}  // namespace scaratwin::mcap
