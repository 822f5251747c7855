// SPDX-License-Identifier: MIT
// The machine a configuration expects, from its INI and HAL files (the
// LinuxCNC INI documentation: [JOINT_n] and homing; hostmot2(9): encoder
// scale, analogout scalemax, stepgen position-scale; the 7I77 manual: the
// field inputs, sinking, read as on when a contact closes to field power).
// The configuration is read (hal_config.hpp), its HAL signal graph built
// (hal_graph.hpp), and the machine derived a part at a time: the axes
// (axis_deriver.hpp), the E-stop and probe switches (switch_deriver.hpp),
// the interlocks (permissive_deriver.hpp), the spindle
// (spindle_deriver.hpp) and the field outputs (output_deriver.hpp); then
// written (machine_toml_writer.hpp).
#include "linuxcnc/machine_from_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <string>

#include "linuxcnc/axis_deriver.hpp"
#include "linuxcnc/derive_common.hpp"
#include "linuxcnc/derive_context.hpp"
#include "linuxcnc/joint_config.hpp"
#include "linuxcnc/machine_toml_writer.hpp"
#include "linuxcnc/output_deriver.hpp"
#include "linuxcnc/permissive_deriver.hpp"
#include "linuxcnc/spindle_deriver.hpp"
#include "linuxcnc/switch_deriver.hpp"

namespace lbpkit::linuxcnc {

bool DerivedMachine::ok() const {
  return std::none_of(findings.begin(), findings.end(), [](const Finding& f) { return f.severity == "error"; });
}

namespace detail {
namespace {

// The machine file for the configuration `c` reads, or "" when an error
// leaves no machine: each part derived in turn, the findings in the order
// they are found.
std::string deriveMachine(DeriveContext& c) {
  for (const auto& p : c.graph.pinSignal())
    if (p.first.find(".7i76.") != std::string::npos) c.sevenI76 = true;
  checkPins(c);
  const auto joints = jointCount(c);
  const auto letters = coordinates(c.hal);
  const auto units = c.hal.ini.find("TRAJ", "LINEAR_UNITS");
  const std::string u = units ? lower(units->value) : "mm";
  c.inch = u == "inch" || u == "in" || u == "imperial";
  std::map<std::string, unsigned> seen;
  for (unsigned n = 0; n < joints; ++n) {
    const char letter = n < letters.size() ? letters[n] : '\0';
    std::string name = letter ? std::string(1, static_cast<char>(std::tolower(static_cast<unsigned char>(letter))))
                              : fmt::format("joint{}", n);
    if (const auto k = seen[name]++; k > 0) name += std::to_string(k + 1);
    deriveAxis(c, n, letter, name);
  }
  if (c.out.axes.empty() && !c.diag.failed())
    c.error({c.ini.filename().string(), 0}, "",
            "no joint drives a 7I77 analog output or a StepGen: lbpkit cannot tell what this configuration moves");
  deriveEstop(c);
  deriveProbe(c);
  derivePermissives(c);
  deriveSpindle(c);
  deriveOutputs(c);
  return c.diag.failed() ? std::string() : machineToml(c.out, c.hal, c.ini);
}

}  // namespace
}  // namespace detail

std::optional<double> AnalogDrive::velocityAt(double pidOutput) const {
  if (!ff1 || !(ff1->v > 0)) return std::nullopt;
  return pidOutput / ff1->v;
}

std::vector<AnalogDrive> analogDrives(const HalConfig& hal, const std::filesystem::path& ini) {
  std::vector<Finding> unused;  // what a machine derived from it would say: not asked here
  detail::DeriveContext c(hal, unused, ini);
  return detail::jointAnalogDrives(c);
}

DerivedMachine machineFromConfig(const std::filesystem::path& ini) {
  DerivedMachine m;
  if (ini.extension() != ".ini") {
    m.findings.push_back({ini.string(), 0, "error", {}, "a machine comes from a configuration's INI file (.ini)", {}});
    return m;
  }
  const auto hal = readConfiguration(ini, m.findings);
  if (!m.ok()) return m;
  detail::DeriveContext c(hal, m.findings, ini);
  m.toml = detail::deriveMachine(c);
  return m;
}

}  // namespace lbpkit::linuxcnc
