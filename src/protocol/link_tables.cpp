// The four link directions of docs/protocol.md (codec_core.h), their code tables built at
// compile time from the packet structs' rows (packet_table.hpp). The firmware, which avr-gcc
// 5.4 compiles without these templates, gets the serial directions' tables generated from these
// (firmware/tools/fw_description.cpp).
#include "packet_table.hpp"

namespace scaratwin::protocol::core {
namespace {

constexpr auto kSerialHostToDeviceCodes = table::Rows<SerialToDevice>::make(false);
constexpr auto kSerialDeviceToHostCodes = table::Rows<SerialFromDevice>::make(false);
constexpr auto kTcpHubToSimCodes = table::Rows<TcpToSim>::make(true);
constexpr auto kTcpSimToHubCodes = table::Rows<TcpFromSim>::make(true);

template <std::size_t N>
constexpr std::uint8_t count_of(const std::array<CodeSpec, N>&) {
  static_assert(N < 256, "a link direction has at most 255 codes");
  return static_cast<std::uint8_t>(N);
}

}  // namespace

const LinkSpec kSerialHostToDevice = {
    '=', 1, kSerialMaxLine, 0, kSerialHostToDeviceCodes.data(), count_of(kSerialHostToDeviceCodes)};
const LinkSpec kSerialDeviceToHost = {
    '=', 0, kSerialMaxLine, 0, kSerialDeviceToHostCodes.data(), count_of(kSerialDeviceToHostCodes)};
const LinkSpec kTcpHubToSim = {
    ',', 0, kTcpMaxLine, 0, kTcpHubToSimCodes.data(), count_of(kTcpHubToSimCodes)};
const LinkSpec kTcpSimToHub = {
    ',', 0, kTcpMaxLine, kMaxImageBytes, kTcpSimToHubCodes.data(), count_of(kTcpSimToHubCodes)};

}  // namespace scaratwin::protocol::core
