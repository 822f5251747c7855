// SPDX-License-Identifier: MIT
// A Mesa Ethernet card's address, as a configuration gives it (hm2_eth's
// board_ip=, [HM2]IPADDRESS) and as lbpkit takes it: a unicast IPv4 address
// in strict dotted-quad form, one rule for every place that reads one
// (lbpkit check-config, lbpkit linuxcnc, lbpkit sim --bind).
//
// Strict: four decimal numbers 0..255 joined by three dots and nothing else.
// inet_aton(3) also takes "10.1.2" (three parts), "0x0a.1.1.1" (hex) and
// "010.1.1.1" (octal: 8.1.1.1); none of those is how a card's address is
// written, and a string two readers read differently is refused.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lbpkit::linuxcnc {

// An IPv4 address in host byte order: 10.1.2.3 is 0x0A010203.
struct Ipv4 {
  std::uint32_t value = 0;
  friend bool operator==(Ipv4, Ipv4) = default;
};

// `text` as a dotted quad: exactly four decimal parts 0..255, each "0" or
// without leading zeros, no sign, no spaces, nothing before or after.
std::optional<Ipv4> parseIpv4(std::string_view text);

// "10.1.2.3".
std::string formatIpv4(Ipv4 address);

// Why `text` is not an address a Mesa Ethernet card can have and `lbpkit
// linuxcnc` can give it (a unicast IPv4 address, neither the network nor
// the broadcast address of its /24, which is the network lbpkit linuxcnc
// builds for the card), in words that name the text; nullopt when it is one.
std::optional<std::string> boardAddressProblem(std::string_view text);

}  // namespace lbpkit::linuxcnc
