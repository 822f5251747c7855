// SPDX-License-Identifier: MIT
// lbpkit's capture files (pcap), shared by what writes them (`lbpkit sim
// --trace`, `lbpkit remote --pty --trace`) and what reads them (`lbpkit
// decode`): the link types and the one header lbpkit adds of its own.
//
// LBP16: raw IPv4 (LINKTYPE_RAW, 101 in the file; libpcap's DLT_RAW), each
// datagram with an IPv4 and a UDP header as it was on the network, so
// Wireshark and tshark dissect UDP port 27181 as for any capture.
// LBP on a serial line: LINKTYPE_USER0 (147), each record one direction
// byte (below) and then the bytes read from, or written to, the line in one
// go; the timestamp is when they were read or written. A gap between records
// is a gap on the line (the LBP framing timeout: manual, LBP, FRAMING).
#pragma once

#include <cstdint>

namespace lbpkit::wire::capture {

inline constexpr int kLinkTypeRaw = 101;       // LINKTYPE_RAW: IPv4 (or IPv6) from the first byte
inline constexpr int kLinkTypeLbpStream = 147;  // LINKTYPE_USER0: lbpkit's LBP stream records
inline constexpr std::uint8_t kToRemote = 0x00;    // host (or SSLBP) to the remote
inline constexpr std::uint8_t kFromRemote = 0x01;  // the remote's answer

}  // namespace lbpkit::wire::capture
