// SPDX-License-Identifier: MIT
// The E-stop chain's and the probe's switches (switch_deriver.hpp; LinuxCNC's
// iocontrol(1) emc-enable-in and motion(9) probe-input).
#include "linuxcnc/switch_deriver.hpp"

#include <fmt/format.h>

#include <optional>
#include <vector>

namespace lbpkit::linuxcnc::detail {

// The E-stop chain: every input reaching iocontrol.0.emc-enable-in is an
// E-stop switch, its contact what keeps emc-enable-in TRUE until pressed.
void deriveEstop(DeriveContext& c) {
  c.seedHolds();
  std::vector<Source> sources;
  c.graph.trace("iocontrol.0.emc-enable-in", false, sources);
  std::optional<Holds> chosen;
  if (!sources.empty())
    chosen =
        c.graph.hold({"iocontrol.0.emc-enable-in", true, "iocontrol.0.emc-enable-in to be TRUE (the E-stop chain)"},
                     c.holds, c.diag);
  unsigned k = 0;
  for (const auto& s : sources) {
    const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
    auto& sw = c.out.switchAt[key];
    if (!sw.kind.empty()) continue;
    // On at rest where the chain needs it on (the inputs that decide
    // it), else as the `not`s on the way say.
    const auto it = chosen ? chosen->find(key) : Holds::iterator{};
    const bool on = chosen && it != chosen->end() ? it->second.on : !s.inverted;
    sw = {k++ == 0 ? "estop" : fmt::format("estop{}", k),
          "estop",
          s.field.daughtercard,
          on ? "nc" : "no",
          "",
          {},
          s.field.number,
          std::nullopt,
          true,
          s.pin};
    sw.comment = fmt::format("{} ({}) reaches iocontrol.0.emc-enable-in{}{}: {}", s.pin, at(c.where(s.pin)),
                             s.inverted ? " inverted" : "",
                             chosen && it != chosen->end() ? via(it->second.through) : std::string(),
                             on ? "NC, the input on while all is well" : "NO, the input on while pressed");
    c.out.switchOrder.push_back(key);
  }
}

void deriveProbe(DeriveContext& c) {
  std::vector<Source> sources;
  c.graph.trace("motion.probe-input", false, sources);
  for (const auto& s : sources) {
    const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
    auto& sw = c.out.switchAt[key];
    if (!sw.kind.empty()) continue;
    sw = {"probe", "probe", s.field.daughtercard, s.inverted ? "nc" : "no", "", {}, s.field.number, std::nullopt,
          true,    s.pin};
    sw.comment = fmt::format("{} ({}) reaches motion.probe-input: trips when told (POST /api/machine)", s.pin,
                             at(c.where(s.pin)));
    c.out.switchOrder.push_back(key);
    break;
  }
}

}  // namespace lbpkit::linuxcnc::detail
