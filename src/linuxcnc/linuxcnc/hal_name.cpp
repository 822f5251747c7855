// SPDX-License-Identifier: MIT
#include "linuxcnc/hal_name.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cctype>

namespace lbpkit::linuxcnc::hal_name {

namespace {

std::vector<std::string> split(std::string_view s) {
  std::vector<std::string> out;
  std::size_t from = 0;
  for (;;) {
    const auto at = s.find('.', from);
    out.emplace_back(s.substr(from, at == std::string_view::npos ? std::string_view::npos : at - from));
    if (at == std::string_view::npos) return out;
    from = at + 1;
  }
}

}  // namespace

std::optional<unsigned> number(const std::string& s) {
  if (s.empty() || s.size() > 3 ||
      !std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }))
    return std::nullopt;
  return static_cast<unsigned>(std::stoul(s));
}

std::string Name::prefix() const { return hal_name::board(board, index); }

std::optional<Name> parse(std::string_view name) {
  if (!isHostMot2(name)) return std::nullopt;
  auto p = split(name.substr(4));
  if (p.size() < 2 || p[0].empty()) return std::nullopt;
  const auto index = number(p[1]);
  if (!index) return std::nullopt;
  Name n{p[0], *index, {}};
  n.parts.assign(p.begin() + 2, p.end());
  return n;
}

std::optional<ModuleName> parseModule(std::string_view name) {
  auto n = parse(name);
  if (!n || n->parts.size() != 3) return std::nullopt;
  const auto instance = number(n->parts[1]);
  if (!instance) return std::nullopt;
  ModuleName m{*n, n->parts[0], *instance, n->parts[2]};
  return m;
}

std::optional<RemoteName> parseRemote(std::string_view name) {
  auto n = parse(name);
  if (!n || n->parts.size() != 4 || (n->parts[0] != "7i77" && n->parts[0] != "7i76")) return std::nullopt;
  const auto port = number(n->parts[1]);
  const auto channel = number(n->parts[2]);
  if (!port || !channel) return std::nullopt;
  RemoteName r{*n, n->parts[0], *port, *channel, n->parts[3]};
  return r;
}

std::string board(std::string_view board, unsigned index) { return fmt::format("hm2_{}.{}", board, index); }

std::string module(std::string_view boardPrefix, std::string_view module, unsigned instance) {
  return module == "gpio" ? fmt::format("{}.{}.{:03d}", boardPrefix, module, instance)
                          : fmt::format("{}.{}.{:02d}", boardPrefix, module, instance);
}

std::string remote(std::string_view boardPrefix, std::string_view remote, unsigned port, unsigned channel) {
  return fmt::format("{}.{}.{}.{}", boardPrefix, remote, port, channel);
}

bool isEthernetBoard(std::string_view board) {
  // The Ethernet cards' names in HAL (LinuxCNC: hm2_eth.c, the board names
  // it sets from the card's LBP16 name). Any 7I80 (7i80hd, 7i80db).
  static constexpr std::array<std::string_view, 8> kEthernet = {"7i92", "7i76e", "7i96", "7i93",
                                                                "7i94", "7i95",  "7i96s", "7i97"};
  if (board.substr(0, 4) == "7i80") return true;
  return std::find(kEthernet.begin(), kEthernet.end(), board) != kEthernet.end();
}

}  // namespace lbpkit::linuxcnc::hal_name
