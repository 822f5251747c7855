// SPDX-License-Identifier: MIT
// The interlocks and permissives a configuration's machine must satisfy to
// run (permissive_deriver.hpp; LinuxCNC's motion(9), halui(1),
// iocontrol(1) pins and message(9)).
#include "linuxcnc/permissive_deriver.hpp"

#include "linuxcnc/hal_name.hpp"

#include <fmt/format.h>

#include <string>
#include <utility>
#include <vector>

namespace lbpkit::linuxcnc::detail {

// Every interlock and permissive that must read one way for the machine
// to run (LinuxCNC's motion, spindle, joint, halui and iocontrol pins;
// a `message` that would fire), held that way by the resting state of
// the inputs that decide it: an input that must read on gets a switch
// held closed, one that must read off nothing.
void derivePermissives(DeriveContext& c) {
  c.seedHolds();
  std::vector<Interlock> list;
  static const std::pair<const char*, bool> kMustBe[] = {
      {"motion.feed-inhibit", false},    {"motion.feed-hold", false},       {"motion.enable", true},
      {"motion.spindle-inhibit", false}, {"motion.spindle-at-speed", true}, {"motion.homing-inhibit", false},
      {"motion.jog-inhibit", false},     {"motion.jog-stop", false},        {"motion.jog-stop-immediate", false},
      {"halui.program.pause", false},    {"halui.program.stop", false},     {"halui.abort", false},
      {"halui.estop.activate", false},   {"halui.machine.off", false}};
  auto mustBe = [](const std::string& pin, bool want) {
    return Interlock{pin, want, fmt::format("{} to be {}", pin, want ? "TRUE" : "FALSE")};
  };
  for (const auto& [pin, want] : kMustBe) list.push_back(mustBe(pin, want));
  // Per spindle and per joint: spindle.N.inhibit and at-speed,
  // joint.N.amp-fault-in (axis.N. in 2.7), halui.spindle.N.stop.
  for (const auto& [pin, sig] : c.graph.pinSignal()) {
    const auto p = split(pin, '.');
    if (p.size() == 3 && p[0] == "spindle" && hal_name::number(p[1]) && (p[2] == "inhibit" || p[2] == "at-speed"))
      list.push_back(mustBe(pin, p[2] == "at-speed"));
    else if (p.size() == 3 && (p[0] == "joint" || p[0] == "axis") && hal_name::number(p[1]) && p[2] == "amp-fault-in")
      list.push_back(mustBe(pin, false));
    else if (p.size() == 4 && p[0] == "halui" && p[1] == "spindle" && hal_name::number(p[2]) && p[3] == "stop")
      list.push_back(mustBe(pin, false));
  }
  // A message fires when its trigger reaches its edge's state (TRUE
  // unless `edge` is set FALSE): held the other way (LinuxCNC:
  // src/hal/components/message.comp).
  for (const auto& [instance, module] : c.graph.instanceModule()) {
    if (module != "message") continue;
    bool edge = true;
    if (const auto* sp = c.hal.setpOf(instance + ".edge"))
      if (const auto b = HalGraph::bit(sp->value)) edge = *b;
    const auto text = c.graph.messageText(instance);
    list.push_back(
        {instance + ".trigger", !edge,
         fmt::format("{}.trigger to be {} (message {}{} fires when it goes {})", instance, edge ? "FALSE" : "TRUE",
                     instance, text.empty() ? "" : " \"" + text + "\"", edge ? "TRUE" : "FALSE")});
  }
  for (const auto& i : list) {
    if (c.graph.signal(i.pin).empty()) continue;
    const auto added = c.graph.hold(i, c.holds, c.diag);
    if (!added) continue;
    for (const auto& [key, h] : *added) {
      c.holds[key] = h;
      auto& sw = c.out.switchAt[key];
      if (!sw.kind.empty()) continue;
      const auto colon = key.find(':');
      const auto number = static_cast<unsigned>(std::stoul(key.substr(colon + 1)));
      if (!h.on) {
        sw.kind = "held-off";  // nothing to wire: an input with no switch reads off
        c.out.heldOff.push_back(fmt::format("{} ({}) must read off for {}{}: nothing closes it", h.pin,
                                            at(c.where(h.pin)), h.reason, via(h.through)));
        continue;
      }
      sw = {fmt::format("held-{}", number),
            "other",
            key.substr(0, colon),
            "nc",
            "",
            {},
            number,
            std::nullopt,
            true,
            h.pin};
      sw.comment = fmt::format("{} ({}) must read on for {}{}: held closed", h.pin, at(c.where(h.pin)), h.reason,
                               via(h.through));
      c.out.switchOrder.push_back(key);
    }
  }
}

}  // namespace lbpkit::linuxcnc::detail
