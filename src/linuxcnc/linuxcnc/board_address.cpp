// SPDX-License-Identifier: MIT
// The special IPv4 ranges: RFC 6890 (the special-purpose address registry),
// RFC 1122 section 3.2.1.3 (0.0.0.0/8 "this host on this network",
// 127.0.0.0/8 loopback), RFC 5771 (224.0.0.0/4 multicast), RFC 1112 section 4
// (240.0.0.0/4 reserved), RFC 919 (255.255.255.255 the limited broadcast).
#include "linuxcnc/board_address.hpp"

#include <fmt/format.h>

namespace lbpkit::linuxcnc {

namespace {

// `text` as a message quotes it: printable ASCII as it is, anything else as
// \xNN (a terminal escape in an INI value is shown, not run), and at most 64
// characters of it.
std::string asQuoted(std::string_view text) {
  constexpr std::size_t kShown = 64;
  std::string out = "\"";
  for (std::size_t i = 0; i < text.size() && i < kShown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '"' || c == '\\')
      out += fmt::format("\\{}", static_cast<char>(c));
    else if (c >= 0x20 && c < 0x7F)
      out += static_cast<char>(c);
    else
      out += fmt::format("\\x{:02x}", c);
  }
  if (text.size() > kShown) out += fmt::format("...\" ({} characters)", text.size());
  else out += '"';
  return out;
}

}  // namespace

std::optional<Ipv4> parseIpv4(std::string_view text) {
  std::uint32_t value = 0;
  std::size_t at = 0;
  for (int part = 0; part < 4; ++part) {
    if (part > 0) {
      if (at >= text.size() || text[at] != '.') return std::nullopt;
      ++at;
    }
    const std::size_t from = at;
    unsigned number = 0;
    while (at < text.size() && text[at] >= '0' && text[at] <= '9' && at - from < 3) {
      number = number * 10 + static_cast<unsigned>(text[at] - '0');
      ++at;
    }
    const std::size_t digits = at - from;
    if (digits == 0 || number > 255) return std::nullopt;
    if (digits > 1 && text[from] == '0') return std::nullopt;  // "010" is octal to inet_aton
    value = (value << 8) | number;
  }
  if (at != text.size()) return std::nullopt;  // a fourth dot, a fourth digit, anything after
  return Ipv4{value};
}

std::string formatIpv4(Ipv4 address) {
  const auto v = address.value;
  return fmt::format("{}.{}.{}.{}", v >> 24, (v >> 16) & 0xFF, (v >> 8) & 0xFF, v & 0xFF);
}

std::optional<std::string> boardAddressProblem(std::string_view text) {
  const auto address = parseIpv4(text);
  if (!address) return fmt::format("{} is not an IPv4 address (four numbers 0-255 joined by dots)", asQuoted(text));
  const auto v = address->value;
  const auto shown = formatIpv4(*address);
  const unsigned first = v >> 24;
  if (first == 0) return fmt::format("{} is not a unicast address (0.0.0.0/8 means this host)", shown);
  if (first == 127) return fmt::format("{} is a loopback address (127.0.0.0/8): no card can have it", shown);
  if (v == 0xFFFFFFFFU) return fmt::format("{} is the broadcast address", shown);
  if (first >= 224 && first <= 239) return fmt::format("{} is a multicast address (224.0.0.0/4)", shown);
  if (first >= 240) return fmt::format("{} is a reserved address (240.0.0.0/4)", shown);
  if ((v & 0xFF) == 0xFF)
    return fmt::format("{} ends in .255: the broadcast address of its /24, which lbpkit linuxcnc gives the card's "
                       "network",
                       shown);
  if ((v & 0xFF) == 0)
    return fmt::format("{} ends in .0: the network address of its /24, which lbpkit linuxcnc gives the card's network",
                       shown);
  return std::nullopt;
}

}  // namespace lbpkit::linuxcnc
