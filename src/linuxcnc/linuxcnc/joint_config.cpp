// SPDX-License-Identifier: MIT
// A configuration's joints as LinuxCNC names them (joint_config.hpp; the
// INI documentation's [KINS], [TRAJ] and [JOINT_n]; hostmot2(9)'s analogout
// parameters; pid(9)).
#include "linuxcnc/joint_config.hpp"

#include "linuxcnc/hal_name.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>

namespace lbpkit::linuxcnc::detail {

unsigned jointCount(DeriveContext& c) {
  unsigned n = 0;
  for (const char* pins : {"joint", "axis"}) {
    for (const auto& p : c.graph.pinSignal())
      if (p.first.rfind(std::string(pins) + ".", 0) == 0)
        n = std::max(n, hal_name::number(split(p.first, '.')[1]).value_or(0) + 1);
    if (n > 0) {
      c.jointPinsName = pins;
      break;
    }
  }
  auto given = c.iniValue("KINS", "JOINTS");
  if (!given && c.jointPinsName == "axis") given = c.iniValue("TRAJ", "AXES");
  if (given) {
    if (given->v >= 1 && given->v <= kMaxJoints && given->v == std::floor(given->v))
      return static_cast<unsigned>(given->v);
    c.error(
        given->at, given->said,
        fmt::format("{} is not a number of joints LinuxCNC has: 1 to {} (EMCMOT_MAX_JOINTS)", given->said, kMaxJoints));
    return 0;
  }
  if (n > kMaxJoints) {
    const auto pin = std::find_if(c.graph.pinSignal().begin(), c.graph.pinSignal().end(), [&](const auto& p) {
      return p.first.rfind(c.jointPinsName + ".", 0) == 0 && hal_name::number(split(p.first, '.')[1]).value_or(0) >= kMaxJoints;
    });
    c.error(c.where(pin->first), pin->first,
            fmt::format("{}: LinuxCNC has joints 0 to {} (EMCMOT_MAX_JOINTS)", pin->first, kMaxJoints - 1));
    return 0;
  }
  return n;
}

std::string coordinates(const HalConfig& hal) {
  std::string letters;
  if (const auto* k = hal.ini.find("KINS", "KINEMATICS"))
    for (const auto& w : split(k->value, ' '))
      if (w.rfind("coordinates=", 0) == 0) letters = w.substr(12);
  if (letters.empty())
    if (const auto* c = hal.ini.find("TRAJ", "COORDINATES")) letters = c->value;
  std::string out;
  for (char c : letters)
    if (std::isalpha(static_cast<unsigned char>(c)))
      out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string jointPins(const DeriveContext& c, unsigned n) { return fmt::format("{}.{}.", c.jointPinsName, n); }

std::string sectionOf(const DeriveContext& c, unsigned n, char letter) {
  std::string section = fmt::format("JOINT_{}", n);
  if (!c.hal.ini.sections.count(section)) section = fmt::format("AXIS_{}", n);
  if (!c.hal.ini.sections.count(section) && letter) section = std::string("AXIS_") + letter;
  return section;
}

std::string pidOn(const DeriveContext& c, const std::string& cmdSig) {
  std::string pid;
  for (const auto& p : c.graph.pinsOn(cmdSig))
    if (p.ends_with(".command") && c.graph.moduleOf(p.substr(0, p.size() - 8)) == "pid")
      pid = p.substr(0, p.size() - 8);
  return pid;
}

AnalogDrive analogDrive(const DeriveContext& c, unsigned n, const std::string& section, const std::string& pid,
                        const std::string& output) {
  const Where iniAt = c.sectionWhere(section);
  auto hostmot2 = [&](const std::string& parameter, double v) {
    return c.setpValue(output + "-" + parameter)
        .value_or(
            Value{v, fmt::format("hostmot2's default {} {:g} (none set)", parameter, v), {}, c.where(output), {}});
  };
  AnalogDrive d;
  d.joint = n;
  d.section = section;
  d.pid = pid;
  d.output = output;
  d.outputAt = c.where(output);
  d.scalemax = c.value(output + "-scalemax", section, "OUTPUT_SCALE")
                   .value_or(Value{10.0, "hostmot2's default scalemax 10 (none set)", {}, iniAt, {}});
  d.maxlim = hostmot2("maxlim", 10.0);
  d.minlim = hostmot2("minlim", -10.0);
  d.ff1 = c.value(pid + ".FF1", section, "FF1");
  d.maxVelocity = c.iniValue(section, "MAX_VELOCITY");
  return d;
}

std::vector<AnalogDrive> jointAnalogDrives(DeriveContext& c) {
  const auto joints = jointCount(c);
  const auto letters = coordinates(c.hal);
  std::vector<AnalogDrive> out;
  for (unsigned n = 0; n < joints; ++n) {
    const auto pid = pidOn(c, c.graph.signal(jointPins(c, n) + "motor-pos-cmd"));
    if (pid.empty()) continue;
    for (const auto& p : c.graph.pinsOn(c.graph.signal(pid + ".output")))
      if (analogOut(p, true))
        out.push_back(analogDrive(c, n, sectionOf(c, n, n < letters.size() ? letters[n] : '\0'), pid, p));
  }
  return out;
}

}  // namespace lbpkit::linuxcnc::detail
