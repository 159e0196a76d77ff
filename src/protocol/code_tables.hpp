// The code tables of the four link directions (docs/protocol.md sections 7 and 8): which
// codes each receiver accepts, their field counts and field kinds. Included once, by
// codec_core.cpp (so the firmware build still compiles that one file).
#ifndef SCARATWIN_PROTOCOL_CODE_TABLES_HPP_
#define SCARATWIN_PROTOCOL_CODE_TABLES_HPP_

#include "scaratwin/protocol/codec_core.h"

namespace scaratwin {
namespace protocol {
namespace core {

// code tables -------------------------------------------------------------------------------
namespace {

const CodeSpec kSerialHostToDeviceCodes[] = {
    make_code('H', 'I', 1, "it"),       // proto_version [description]
    make_code('P', 'I', 0, "i"),        // [token]
    make_code('S', 'R', 1, "i"),        // rate_hz
    make_code('Q', 'S', 0, ""),         //
    make_code('H', 'M', 0, ""),         //
    make_code('T', 'B', 1, "i"),        // n
    make_code('T', 'P', 6, "iiiiiii"),  // seq dt_ms z j2 j3 wrist_cdeg [grip_cdeg]
    make_code('G', 'R', 1, "i"),        // grip_cdeg
    make_code('J', 'G', 2, "ii"),       // axis delta
    make_code('S', 'P', 0, ""),         //
    make_code('C', 'F', 1, "ii"),       // key [value]
};

const CodeSpec kSerialDeviceToHostCodes[] = {
    make_code('H', 'I', 3, "ittt"),       // proto_version device fw_version [description]
    make_code('S', 'T', 9, "iuiiiiiii"),  // seq t_us z j2 j3 wrist grip flags queue_free
    make_code('A', 'K', 1, "ti"),         // code [value]
    make_code('E', 'R', 1, "ii"),         // err_code [detail]
    make_code('E', 'V', 1, "ii"),         // event [value]
};

const CodeSpec kTcpHubToSimCodes[] = {
    make_code('H', 'I', 1, "ittt"),     // proto_version [role] [token] [description]
    make_code('P', 'I', 0, "i"),        // [token]
    make_code('J', 'D', 6, "iuddddi"),  // seq t_us d1_mm q2_deg q3_deg q4_deg [robot]
    make_code('T', 'J', 6, "iuddddi"),  // seq t_us d1_mm q2_deg q3_deg q4_deg [robot]
    make_code('M', 'D', 1, "ti"),       // mode [robot]
    make_code('G', 'R', 1, "ii"),       // state [robot]
    make_code('C', 'S', 0, "ii"),       // [width_px height_px]
    make_code('S', 'C', 3, "tdd"),      // color x_mm y_mm
    make_code('R', 'S', 0, ""),         //
    make_code('O', 'P', 0, "i"),        // [id]
    make_code('Q', 'S', 0, "i"),        // [robot]
    make_code('S', 'P', 0, "i"),        // [robot]
    make_code('T', 'W', 1, "ti"),       // phase [robot]
};

const CodeSpec kTcpSimToHubCodes[] = {
    make_code('H', 'I', 3, "ittt"),                // proto_version device version [description]
    make_code('J', 'A', 2, "iui"),                 // seq t_apply_us [robot]
    make_code('G', 'R', 2, "iii"),                 // state held_id [robot]
    make_code('I', 'M', 1, "i", kCodeHasPayload),  // nbytes, then the PNG bytes
    make_code('O', 'P', 6, "itdddd"),              // id color x_mm y_mm z_mm yaw_deg
    make_code('S', 'T', 9, "iuddddiiti"),          // seq t_us d1..q4 grip held_id mode [robot]
    make_code('J', 'W', 2, "idi"),                 // joint value [robot]
    make_code('A', 'K', 1, "ti"),                  // code [value]
    make_code('E', 'R', 1, "ii"),                  // err_code [detail]
};

template <typename T, size_t N>
constexpr uint8_t count_of(const T (&)[N]) {
  return static_cast<uint8_t>(N);
}

}  // namespace

const LinkSpec kSerialHostToDevice = {
    '=', 1, kSerialMaxLine, 0, kSerialHostToDeviceCodes, count_of(kSerialHostToDeviceCodes)};
const LinkSpec kSerialDeviceToHost = {
    '=', 0, kSerialMaxLine, 0, kSerialDeviceToHostCodes, count_of(kSerialDeviceToHostCodes)};
const LinkSpec kTcpHubToSim = {
    ',', 0, kTcpMaxLine, 0, kTcpHubToSimCodes, count_of(kTcpHubToSimCodes)};
const LinkSpec kTcpSimToHub = {
    ',', 0, kTcpMaxLine, kMaxImageBytes, kTcpSimToHubCodes, count_of(kTcpSimToHubCodes)};

}  // namespace core
}  // namespace protocol
}  // namespace scaratwin

#endif  // SCARATWIN_PROTOCOL_CODE_TABLES_HPP_
