// SPDX-License-Identifier: MIT
// The shared state of a derivation and the values it reads from a
// configuration (derive_context.hpp; the LinuxCNC INI documentation,
// hostmot2(9)'s parameters).
#include "linuxcnc/derive_context.hpp"

#include <fmt/format.h>

#include <cmath>

namespace lbpkit::linuxcnc::detail {

DeriveContext::DeriveContext(const HalConfig& h, std::vector<Finding>& findings, const std::filesystem::path& i)
    : hal(h), ini(i), diag(findings), graph(h, i) {}

bool DeriveContext::within(const std::optional<Value>& v, const Bound& b) {
  if (!v) return true;
  const double m = std::abs(v->v);
  if (std::isfinite(v->v) && m <= b.high && (m >= b.low || (b.low == 0.0 && m == 0.0)) && (b.low == 0.0 || m > 0.0))
    return true;
  error(v->at, v->said, fmt::format("{} is not {} a machine can have ({})", v->said, b.what, b.range));
  return false;
}

bool DeriveContext::position(std::optional<Value>& v, double mmPerUnit, bool angular) {
  if (!v || (std::isfinite(v->v) && std::abs(v->v) * mmPerUnit <= kMaxPositionMm)) return true;
  if (angular && !std::isnan(v->v)) {
    warning(v->at, v->said,
            fmt::format("{}: a rotary joint turning past {} degrees is taken as turning to there", v->said,
                        fmtNumber(kMaxPositionMm)));
    v->v = std::copysign(kMaxPositionMm, v->v);
    v->from += fmt::format(", taken as {}", fmtNumber(v->v));
    return true;
  }
  error(v->at, v->said, fmt::format("{} is not a position a machine can have (within 1e5 mm, 100 m, of 0)", v->said));
  return false;
}

bool DeriveContext::derived(double x, double low, double high, const Value& v, const std::string& what) {
  if (std::isfinite(x) && x >= low && x <= high) return true;
  error(v.at, v.said,
        fmt::format("{}: {} {:.6g}, and lbpkit's machine files take {:g} to {:g}", v.said, what, x, low, high));
  return false;
}

bool DeriveContext::encoderFits(const Lines& e, const Value& scale) {
  return derived(static_cast<double>(e.lines), 1.0, kMaxEncoderLines, scale,
                 "on the assumed 5 mm screw, encoder lines a motor turn of") &&
         derived(e.gear, kMinGear, kMaxGear, scale, "on the assumed 5 mm screw, a gear ratio of");
}

std::optional<Value> DeriveContext::value(const std::string& halName, const std::string& section,
                                          const std::string& key) const {
  if (auto v = setpValue(halName)) return v;
  return iniValue(section, key);
}

std::optional<Value> DeriveContext::setpValue(const std::string& halName) const {
  const auto* s = hal.setpOf(halName);
  if (!s) return std::nullopt;
  const auto v = number(s->value);
  if (!v) return std::nullopt;
  const auto written = s->written == s->value ? s->value : fmt::format("{} = {}", s->written, s->value);
  Value given{*v, fmt::format("{}: setp {} {}", at(s->at), halName, written),
              fmt::format("setp {} {}", halName, written), s->at, s->at};
  // A setp of [SECTION]KEY: an error names the INI's line.
  if (const auto close = s->written.find(']'); s->written.starts_with("[") && close != std::string::npos)
    if (const auto* e = hal.ini.find(s->written.substr(1, close - 1), s->written.substr(close + 1))) {
      given.said = fmt::format("{} = {}", s->written, e->value);
      given.at = {e->file, e->line};
    }
  return given;
}

std::optional<Value> DeriveContext::iniValue(const std::string& section, const std::string& key) const {
  if (const auto* e = hal.ini.find(section, key))
    if (const auto v = number(e->value))
      return Value{*v,
                   fmt::format("[{}]{} = {} ({}:{})", section, key, e->value, e->file, e->line),
                   fmt::format("[{}]{} = {}", section, key, e->value),
                   Where{e->file, e->line},
                   {}};
  return std::nullopt;
}

Where DeriveContext::sectionWhere(const std::string& section) const {
  unsigned first = 0;
  bool keys = false;
  if (const auto s = hal.ini.sections.find(section); s != hal.ini.sections.end())
    for (const auto& [k, e] : s->second) {
      keys = true;
      if (e.file == hal.ini.file && (first == 0 || e.line < first)) first = e.line;
    }
  if (first == 0 && keys)
    if (const auto at = hal.ini.sectionAt.find(section); at != hal.ini.sectionAt.end()) return at->second;
  return {ini.filename().string(), first > 0 ? first - 1 : 0};
}

void DeriveContext::seedHolds() {
  for (const auto& key : out.switchOrder) {
    const auto& sw = out.switchAt.at(key);
    if (sw.kind.empty() || sw.kind == "held-off") continue;
    holds.emplace(key, Held{sw.contact == "nc",
                            sw.pin,
                            {},
                            fmt::format("the {} switch", sw.name),
                            sw.pin.empty() ? Where{ini.filename().string(), 0} : where(sw.pin)});
  }
}

std::string via(const std::string& through) { return through.empty() ? "" : " (through " + through + ")"; }

void checkPins(DeriveContext& c) {
  for (const auto& [pin, sig] : c.graph.pinSignal()) {
    if (const auto off = offFirst7I77(pin); !off.empty()) {
      c.warning(c.where(pin), pin, fmt::format("{} is {}, so this pin is left out", pin, off));
      continue;
    }
    std::optional<unsigned> n;
    unsigned count = 0;
    std::string what;
    if (const auto f = fieldPin(pin, "input")) {
      n = f->number;
      count = f->daughtercard == "card" ? kCardPins : kFieldInputs;
      what = f->daughtercard == "card" ? "card IO pins" : "inputs";
    } else if (const auto o = fieldPin(pin, "output")) {
      n = o->number;
      count = kFieldOutputs;
      what = "outputs";
    } else if (const auto a = analogOut(pin)) {
      n = a;
      count = kAnalogOutputs;
      what = "analog outputs";
    } else if (const auto e = modulePin(pin, "encoder", "position")) {
      n = e;
      // The 7I77 firmwares' counters 6 to 11 are a second 7I77's; with a
      // 7I76, counter 6 is its spindle encoder's.
      count = c.sevenI76 ? kEncoders : 2 * kEncoders;
      what = "encoders";
    } else if (const auto sg = modulePin(pin, "stepgen", "position-cmd");
               sg || modulePin(pin, "stepgen", "velocity-cmd")) {
      n = sg ? sg : modulePin(pin, "stepgen", "velocity-cmd");
      count = kStepGens;
      what = "StepGens";
    }
    if (n && *n >= count)
      c.error(c.where(pin), pin,
              fmt::format("{}: no such pin (the card has {} {}, 0 to {}): LinuxCNC refuses it", pin, count, what,
                          count - 1));
  }
}

}  // namespace lbpkit::linuxcnc::detail
