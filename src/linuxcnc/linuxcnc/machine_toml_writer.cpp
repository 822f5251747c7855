// SPDX-License-Identifier: MIT
// The machine file's text (machine_toml_writer.hpp): TOML as
// examples/machines/mill.toml lays it out, a comment on each value.
#include "linuxcnc/machine_toml_writer.hpp"

#include <fmt/format.h>

#include "linuxcnc/derive_common.hpp"

namespace lbpkit::linuxcnc::detail {

namespace {

// One `key = value` line, its comment (after '|' in `valueAndWhy`) at the
// 31st column.
std::string tomlLine(const std::string& indent, const std::string& key, const std::string& valueAndWhy) {
  const auto bar = valueAndWhy.find('|');
  const auto v = valueAndWhy.substr(0, bar);
  const auto why = bar == std::string::npos ? std::string() : valueAndWhy.substr(bar + 1);
  auto text = fmt::format("{}{} = {}", indent, key, v);
  if (!why.empty())
    text += fmt::format("{}# {}", std::string(text.size() < 30 ? 30 - text.size() : 1, ' '), commentText(why));
  return text + "\n";
}

}  // namespace

std::string machineToml(const MachineOut& m, const HalConfig& hal, const std::filesystem::path& ini) {
  std::string t;
  t += fmt::format("# The machine {} expects, derived from it by lbpkit machine --from-config\n",
                   commentText(ini.filename().string()));
  t += fmt::format("# (read: {}).\n", commentText([&] {
                     std::string files;
                     for (const auto& f : hal.files)
                       files += (files.empty() ? "" : ", ") + std::filesystem::path(f).filename().string();
                     return files;
                   }()));
  t += "# Each value says where it came from. Assumed, because a configuration cannot say: the screw's\n"
       "# pitch (5 mm, 0.2 in), the masses, inertias and friction (the schema's defaults,\n"
       "# examples/machines/mill.toml), that drives are velocity-mode and that no axis is vertical.\n\n";
  t += fmt::format("name = \"{}\"\n\n", machineName(ini.stem().string()));
  for (const auto& a : m.axes) {
    t += fmt::format("# {}\n[[axis]]\nname = \"{}\"\n", commentText(a.comment), a.name);
    for (const auto& [k, v] : a.keys) t += tomlLine("", k, v);
    if (a.brakeOutput >= 0) {
      t += tomlLine("", "brake_output", fmt::format("{}|{}", a.brakeOutput, a.brakeComment));
      t += tomlLine("", "brake_daughtercard", fmt::format("\"{}\"|", a.brakeDaughtercard));
      t += tomlLine("", "brake_torque", "4.0|assumed: holds what a drive's peak torque can");
    }
    if (a.tableName == "axis.stepper") {
      t += "  [axis.stepper]\n";
      for (const auto& [k, v] : a.drive) t += tomlLine("  ", k, v);
    } else {
      t += "  [[axis.drive]]\n";
      for (const auto& [k, v] : a.drive) t += tomlLine("  ", k, v);
      t += "  [axis.drive.amplifier]\n";
      for (const auto& [k, v] : a.amplifier) t += tomlLine("  ", k, v);
    }
    t += "\n";
  }
  if (!m.spindle.empty()) {
    t += "[spindle]\n";
    for (const auto& [k, v] : m.spindle) t += tomlLine("", k, v);
    t += "\n";
  }
  // Names are unique in a machine file: a second switch of one kind on an
  // axis (two inputs reach its home-sw-in through or2), or held on a 7I77
  // and a 7I76 input of one number, is numbered.
  std::set<std::string> switchNames;
  for (const auto& key : m.switchOrder) {
    const auto& s = m.switchAt.at(key);
    if (s.kind == "held-off") continue;
    std::string name = s.name;
    for (unsigned k = 2; !switchNames.insert(name).second; ++k) name = fmt::format("{}-{}", s.name, k);
    t += fmt::format(
        "# {}\n[[switch]]\nname = \"{}\"\nkind = \"{}\"\ndaughtercard = \"{}\"\ninput = {}\ncontact = \"{}\"\n",
        commentText(s.comment), name, s.kind, s.daughtercard, s.input, s.contact);
    if (!s.axis.empty()) {
      t += fmt::format("axis = \"{}\"\nposition = {}\ntrip_above = {}\n", s.axis, fmtNumber(*s.position),
                       s.tripAbove ? "true" : "false");
    }
    t += "\n";
  }
  for (const auto& h : m.heldOff) t += "# " + commentText(h) + "\n";
  for (const auto& key : m.homeInPlaceInputs)
    if (m.switchAt.at(key).kind.empty())
      t += fmt::format("# {} input {}: a home switch its joint never searches for (it homes in place)\n",
                       key.substr(0, key.find(':')), key.substr(key.find(':') + 1));
  for (const auto& o : m.outputs) {
    t += fmt::format("# {}\n[[output]]\nname = \"{}\"\ndaughtercard = \"{}\"\noutput = {}\n\n", commentText(o.comment),
                     o.name, o.daughtercard, o.output);
  }
  return t;
}

}  // namespace lbpkit::linuxcnc::detail
