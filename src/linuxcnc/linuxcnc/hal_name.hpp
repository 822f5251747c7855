// SPDX-License-Identifier: MIT
// The names hostmot2 gives its HAL pins, parameters and functions, read and
// written in this one place (LinuxCNC: hostmot2(9), "Pins" and
// "Parameters"):
//   hm2_<board>.<index>                                 a board
//   hm2_<board>.<index>.<module>.<instance>.<leaf>      a HostMot2 module's
//                                                       (encoder.00.position, gpio.012.in)
//   hm2_<board>.<index>.<remote>.<port>.<channel>.<leaf> a smart-serial
//                                                       remote's (7i77.0.1.analogout0)
// <board> is the card's name as hostmot2 writes it, lower case (7i92,
// 7i96s, 5i25); <index> counts boards of that name from 0. check-config,
// `lbpkit pins`, `lbpkit machine --from-config` and `lbpkit linuxcnc` all
// read and write names through these.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lbpkit::linuxcnc::hal_name {

// Any hostmot2 name: the board, and what follows it.
struct Name {
  std::string board;               // "7i92"
  unsigned index = 0;              // hm2_7i92.<index>
  std::vector<std::string> parts;  // what follows "hm2_7i92.0.", split at the dots
  [[nodiscard]] std::string prefix() const;  // "hm2_7i92.0"
};
// A HAL name's instance or channel number (hm2_7i92.<0>, joint.<2>,
// spindle.<0>): one to three decimal digits; nothing for anything else.
[[nodiscard]] std::optional<unsigned> number(const std::string& s);

// "hm2_<board>.<index>[.<rest>]", <index> decimal digits; nothing for any
// other name.
[[nodiscard]] std::optional<Name> parse(std::string_view name);
// Whether `name` is in hostmot2's part of HAL's names ("hm2_..."), whether
// or not the rest parses: what check-config reports a mistake in.
[[nodiscard]] inline bool isHostMot2(std::string_view name) { return name.starts_with("hm2_"); }

// A HostMot2 module's pin or parameter: hm2_<board>.<index>.<module>.<instance>.<leaf>.
struct ModuleName {
  Name board;
  std::string module;  // "encoder", "stepgen", "gpio", "inm"
  unsigned instance = 0;
  std::string leaf;  // "position", "in_not"
};
[[nodiscard]] std::optional<ModuleName> parseModule(std::string_view name);

// A smart-serial remote's: hm2_<board>.<index>.<remote>.<port>.<channel>.<leaf>.
struct RemoteName {
  Name board;
  std::string remote;  // "7i77", "7i76"
  unsigned port = 0;
  unsigned channel = 0;
  std::string leaf;  // "input-07-not", "analogout3"
};
[[nodiscard]] std::optional<RemoteName> parseRemote(std::string_view name);

// The names made: "hm2_7i92.0"; "hm2_7i92.0.stepgen.03" (the instance in
// two digits, three for gpio, as hostmot2 writes them);
// "hm2_7i92.0.7i77.0.1".
[[nodiscard]] std::string board(std::string_view board, unsigned index);
[[nodiscard]] std::string module(std::string_view boardPrefix, std::string_view module, unsigned instance);
[[nodiscard]] std::string remote(std::string_view boardPrefix, std::string_view remote, unsigned port,
                                 unsigned channel);

// A board hm2_eth makes (an Ethernet card: 7I92, 7I96S, 7I80HD, ...), as
// against hm2_pci's (5I25, 6I25, ...), from its name in HAL.
[[nodiscard]] bool isEthernetBoard(std::string_view board);

}  // namespace lbpkit::linuxcnc::hal_name
