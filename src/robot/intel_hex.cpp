// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see intel_hex.hpp)
#include "intel_hex.hpp"

#include <fstream>
#include <sstream>

namespace scaratwin::robot {
namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Error bad(int line, const std::string& what) {
  return Error{EmulatorError::kBadOption, "Intel HEX line " + std::to_string(line) + ": " + what};
}

}  // namespace

Result<std::vector<HexChunk>> parse_intel_hex(const std::string& text) {
  std::vector<HexChunk> chunks;
  std::uint32_t base = 0;
  bool ended = false;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty()) continue;
    if (ended) return bad(n, "a record after the end-of-file record");
    if (line[0] != ':' || line.size() < 11 || line.size() % 2 == 0) {
      return bad(n, "not a record (':' and an even number of hex digits, at least 10)");
    }
    std::vector<std::uint8_t> rec;
    for (std::size_t i = 1; i + 1 < line.size(); i += 2) {
      const int hi = hex_digit(line[i]), lo = hex_digit(line[i + 1]);
      if (hi < 0 || lo < 0) return bad(n, "'" + line.substr(i, 2) + "' is not a hex byte");
      rec.push_back(static_cast<std::uint8_t>(hi * 16 + lo));
    }
    const std::size_t count = rec[0];
    if (rec.size() != count + 5) {
      return bad(n, "its length byte says " + std::to_string(count) + " data bytes, it has " +
                        std::to_string(rec.size() >= 5 ? rec.size() - 5 : 0));
    }
    std::uint8_t sum = 0;
    for (std::uint8_t b : rec) sum = static_cast<std::uint8_t>(sum + b);
    if (sum != 0) return bad(n, "checksum mismatch");
    const std::uint32_t offset = (static_cast<std::uint32_t>(rec[1]) << 8) | rec[2];
    const std::uint8_t type = rec[3];
    const std::uint8_t* data = rec.data() + 4;
    switch (type) {
      case 0x00: {
        const std::uint32_t at = base + offset;
        if (!chunks.empty() && chunks.back().address + chunks.back().bytes.size() == at) {
          chunks.back().bytes.insert(chunks.back().bytes.end(), data, data + count);
        } else {
          chunks.push_back({at, std::vector<std::uint8_t>(data, data + count)});
        }
        break;
      }
      case 0x01:
        ended = true;
        break;
      case 0x02:
      case 0x04:
        if (count != 2) return bad(n, "an address record needs 2 data bytes");
        base = ((static_cast<std::uint32_t>(data[0]) << 8) | data[1]) << (type == 0x02 ? 4 : 16);
        break;
      case 0x03:
      case 0x05:
        break;  // start address: no use on an AVR
      default:
        return bad(n, "unknown record type " + std::to_string(type));
    }
  }
  if (!ended) return bad(n, "no end-of-file record (a cut file?)");
  return chunks;
}

Result<std::vector<HexChunk>> read_intel_hex(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Error{EmulatorError::kBadOption, "cannot read '" + path + "'"};
  std::stringstream ss;
  ss << f.rdbuf();
  auto chunks = parse_intel_hex(ss.str());
  if (!chunks) return Error{EmulatorError::kBadOption, path + ": " + chunks.error().message};
  return chunks;
}

}  // namespace scaratwin::robot
