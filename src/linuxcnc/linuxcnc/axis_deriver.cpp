// SPDX-License-Identifier: MIT
// A joint as a machine file's axis (axis_deriver.hpp; hostmot2(9): encoder
// scale, analogout scalemax, stepgen position-scale and maxvel; pid(9):
// FF1; the 7I77 manual: analog outputs of +-10 V, AnalogEna, SpinEna on
// ENA5).
#include "linuxcnc/axis_deriver.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include "linuxcnc/axis_homing.hpp"
#include "linuxcnc/joint_config.hpp"

namespace lbpkit::linuxcnc::detail {

namespace {

// Joint j's encoder scale (a setp of its scale, else [section]ENCODER_SCALE);
// none, and an error, when neither gives one.
std::optional<Value> encoderScale(DeriveContext& c, const Joint& j) {
  const auto encScale =
      c.value(fmt::format("{}.encoder.{:02d}.scale", j.board, *j.encoder), j.section, "ENCODER_SCALE");
  if (!encScale || encScale->v == 0.0) {
    c.error(
        j.iniAt, j.section,
        fmt::format("joint {}: no scale for encoder.{:02d} (setp or [{}]ENCODER_SCALE)", j.n, *j.encoder, j.section));
    return std::nullopt;
  }
  return encScale;
}

// What moves joint j and reads it back: the encoder on its feedback (or
// its PID's), the StepGen on its command, the analog output or velocity-mode
// StepGen on its PID's output; an error when that is none a machine has, or
// is another joint's.
bool findDrive(DeriveContext& c, Joint& j, char letter) {
  const unsigned n = j.n;
  j.jp = jointPins(c, n);
  j.section = sectionOf(c, n, letter);
  j.fbSig = c.graph.signal(j.jp + "motor-pos-fb");
  j.cmdSig = c.graph.signal(j.jp + "motor-pos-cmd");
  j.iniAt = c.sectionWhere(j.section);
  if (j.fbSig.empty() || j.cmdSig.empty()) {
    c.warning(j.iniAt, j.jp + "motor-pos-cmd",
              fmt::format("joint {}: {}motor-pos-cmd or -fb is on no signal: no axis for it", n, j.jp));
    return false;
  }
  j.pid = pidOn(c, j.cmdSig);
  std::string offDrive;
  auto encoderOn = [&](const std::string& sig) {
    for (const auto& p : c.graph.pinsOn(sig))
      if (const auto e = modulePin(p, "encoder", "position")) {
        j.encoder = *e;
        j.encoderPin = p;
        j.board = cardOf(p);
      }
  };
  encoderOn(j.fbSig);
  if (!j.encoder && !j.pid.empty()) encoderOn(c.graph.signal(j.pid + ".feedback"));
  for (const auto& p : c.graph.pinsOn(j.cmdSig))
    if (const auto s = modulePin(p, "stepgen", "position-cmd")) {
      j.stepgen = *s;
      j.board = cardOf(p);
    }
  if (!j.pid.empty())
    for (const auto& p : c.graph.pinsOn(c.graph.signal(j.pid + ".output"))) {
      if (const auto a = analogOut(p)) {
        j.analog = *a;
        j.analogPin = p;
        j.board = cardOf(p);
      } else if (analogOut(p, true)) {
        offDrive = p;
      }
      if (const auto s = modulePin(p, "stepgen", "velocity-cmd")) {
        j.stepgen = *s;
        j.velocityStepgen = true;
        j.board = cardOf(p);
      }
    }
  // A drive or an encoder off the first 7I77 is on no terminal of the
  // machine's.
  if (!j.stepgen && !j.analog && !offDrive.empty()) {
    c.error(c.where(j.jp + "motor-pos-cmd"), j.jp + "motor-pos-cmd",
            fmt::format("joint {}: its PID drives {} ({}), {}, so this joint cannot be derived", n, offDrive,
                        at(c.where(offDrive)), offFirst7I77(offDrive)));
    return false;
  }
  if (j.encoder && *j.encoder >= kEncoders && *j.encoder < 2 * kEncoders && !c.sevenI76) {
    c.error(c.where(j.jp + "motor-pos-fb"), j.jp + "motor-pos-fb",
            fmt::format("joint {}: its feedback {} ({}) is a counter of the second 7I77 (6 to 11): lbpkit's derived "
                        "machine sits behind the first 7I77 only, so this joint cannot be derived",
                        n, j.encoderPin, at(c.where(j.encoderPin))));
    return false;
  }
  if (!j.stepgen && !j.analog) {
    c.error(c.where(j.jp + "motor-pos-cmd"), j.jp + "motor-pos-cmd",
            fmt::format("joint {}: neither a PID whose output reaches a 7I77 analogoutN nor a StepGen takes its "
                        "command (signal {}): lbpkit cannot tell what moves it",
                        n, j.cmdSig));
    return false;
  }
  if (j.analog && !j.encoder) {
    c.error(c.where(j.jp + "motor-pos-fb"), j.jp + "motor-pos-fb",
            fmt::format("joint {}: drives analogout{} but its feedback (signal {}) is no hm2 encoder.NN.position: "
                        "lbpkit's servo axes read an encoder",
                        n, *j.analog, j.fbSig));
    return false;
  }
  // One joint to each: a second on the same output, encoder or StepGen is
  // two writers on one pin (LinuxCNC refuses it).
  for (const auto& [claimed, number, what, pin] :
       {std::tuple{&c.claimedAnalogs, j.analog, "analogout", j.analogPin},
        std::tuple{&c.claimedEncoders, j.encoder, "encoder",
                   fmt::format("{}.encoder.{:02d}.position", j.board, j.encoder.value_or(0))},
        std::tuple{&c.claimedStepgens, j.stepgen, "stepgen",
                   fmt::format("{}.stepgen.{:02d}", j.board, j.stepgen.value_or(0))}})
    if (number && claimed->count(*number)) {
      c.error(c.where(j.jp + "motor-pos-cmd"), j.jp + "motor-pos-cmd",
              fmt::format("joint {}: {} {} already serves another joint ({})", n, what, *number, pin));
      return false;
    }
  return true;
}

// Its [JOINT_n] travel, velocities and homing, each within a machine's
// bounds.
bool readMotion(DeriveContext& c, Joint& j) {
  j.angular = [&] {
    const auto* t = c.hal.ini.find(j.section, "TYPE");
    return t && lower(t->value) == "angular";
  }();
  j.mmPerUnit = j.angular || !c.inch ? 1.0 : 25.4;
  j.minLimit = c.iniValue(j.section, "MIN_LIMIT");
  j.maxLimit = c.iniValue(j.section, "MAX_LIMIT");
  j.homeOffset = c.iniValue(j.section, "HOME_OFFSET");
  j.maxVel = c.iniValue(j.section, "MAX_VELOCITY");
  j.maxAcc = c.iniValue(j.section, "MAX_ACCELERATION");
  j.searchVel = c.iniValue(j.section, "HOME_SEARCH_VEL");
  j.latchVel = c.iniValue(j.section, "HOME_LATCH_VEL");
  // Each checked, so that every value out of bounds is said at once.
  bool good = true;
  for (auto* p : {&j.minLimit, &j.maxLimit, &j.homeOffset}) good = c.position(*p, j.mmPerUnit, j.angular) && good;
  for (const auto* v : {&j.maxVel, &j.searchVel, &j.latchVel}) good = c.within(*v, kVelocityBound) && good;
  good = c.within(j.maxAcc, kAccelerationBound) && good;
  if (!good) return false;
  if (!j.minLimit || !j.maxLimit || !(j.minLimit->v < j.maxLimit->v)) {
    c.error(j.iniAt, j.section,
            fmt::format("[{}] needs MIN_LIMIT below MAX_LIMIT: they give the axis its travel", j.section));
    return false;
  }
  // Six significant digits in the machine file: a travel narrower than
  // they tell apart would read as none.
  if ((j.maxLimit->v - j.minLimit->v) * j.mmPerUnit < 1e-3 ||
      j.maxLimit->v - j.minLimit->v < 1e-4 * std::max(std::abs(j.minLimit->v), std::abs(j.maxLimit->v))) {
    c.error(j.maxLimit->at, j.section,
            fmt::format("[{}] MIN_LIMIT {} to MAX_LIMIT {} is no travel a machine moves over (at least 1e-3 mm, and "
                        "1e-4 of its distance from 0)",
                        j.section, fmtNumber(j.minLimit->v), fmtNumber(j.maxLimit->v)));
    return false;
  }
  j.vmax = j.maxVel ? std::abs(j.maxVel->v) : 25.0 / j.mmPerUnit;
  j.amax = j.maxAcc && j.maxAcc->v > 0 ? j.maxAcc->v : 250.0 / j.mmPerUnit;
  j.sv = j.searchVel.value_or(Value{}).v;
  j.lv = j.latchVel.value_or(Value{}).v;
  j.offset = j.homeOffset.value_or(Value{0.0, "LinuxCNC's default HOME_OFFSET = 0", {}, j.iniAt, {}});
  const auto* useIndexEntry = c.hal.ini.find(j.section, "HOME_USE_INDEX");
  j.useIndex = useIndexEntry && yes(useIndexEntry->value);
  return true;
}

// A stepper axis: steps per unit from the StepGen's position-scale (or
// [JOINT_n]SCALE), and a closed-loop stepper's encoder.
bool deriveStepper(DeriveContext& c, Joint& j, AxisOut& a) {
  const auto scale = c.value(fmt::format("{}.stepgen.{:02d}.position-scale", j.board, *j.stepgen), j.section, "SCALE");
  if (!scale || scale->v == 0.0) {
    c.error(
        j.iniAt, j.section,
        fmt::format("joint {}: no position-scale for stepgen.{:02d} (setp or [{}]SCALE)", j.n, *j.stepgen, j.section));
    return false;
  }
  auto maxStepVel = c.value(fmt::format("{}.stepgen.{:02d}.maxvel", j.board, *j.stepgen), j.section, "STEPGEN_MAXVEL");
  if (!c.within(scale, kScaleBound) || !c.within(maxStepVel, kVelocityBound)) return false;
  const double stepVel = maxStepVel && maxStepVel->v > 0 ? maxStepVel->v : j.vmax * 1.25;
  const double stepsPerMm = std::abs(scale->v) / j.mmPerUnit;
  if (!c.derived(stepsPerMm, kMinStepsPerMm, kMaxStepsPerMm, *scale, "steps/mm") ||
      !c.derived(std::ceil(stepVel * std::abs(scale->v) * 1.25), 1.0, kMaxStepRate,
                 maxStepVel && maxStepVel->v > 0 ? *maxStepVel : j.maxVel.value_or(*scale),
                 "with the scale, a StepGen pull-out rate (steps/s) of"))
    return false;
  a.keys.emplace_back("screw_pitch",
                      fmtNumber(j.pitch) + "|assumed: a configuration gives steps per unit, not the screw");
  a.tableName = "axis.stepper";
  a.drive.emplace_back("stepgen", fmt::format("{}|{}.stepgen.{:02d}{}", *j.stepgen, j.board, *j.stepgen,
                                              j.velocityStepgen ? " (velocity mode, through " + j.pid + ")" : ""));
  a.drive.emplace_back("steps_per_unit",
                       fmtNumber(stepsPerMm) + "|" + scale->from + (j.mmPerUnit != 1.0 ? ", / 25.4" : ""));
  a.drive.emplace_back("max_step_rate",
                       fmtNumber(std::ceil(stepVel * std::abs(scale->v) * 1.25)) + "|" +
                           fmt::format("pulls out 25 % above the StepGen's {} {}/s ({})", fmtNumber(stepVel),
                                       j.unitName, maxStepVel ? maxStepVel->from : "1.25 x MAX_VELOCITY"));
  a.drive.emplace_back("reversed",
                       std::string(scale->v < 0 ? "true" : "false") + "|" +
                           (scale->v < 0 ? "a negative scale: a forward step moves it back" : "the scale's sign"));
  if (j.encoder) {
    // A closed-loop stepper: LinuxCNC's feedback from an encoder.
    const auto encScale = encoderScale(c, j);
    if (!encScale) return false;
    if (!c.within(encScale, kScaleBound)) return false;
    const auto e = encoderLines(std::abs(encScale->v) / j.mmPerUnit, j.pitch);
    if (!c.encoderFits(e, *encScale)) return false;
    j.gear = e.gear;
    a.keys.emplace_back("gear_ratio", fmtNumber(j.gear) + "|motor revolutions per screw revolution");
    a.drive.emplace_back("encoder_input",
                         fmt::format("{}|{}.encoder.{:02d} ({}), its feedback", *j.encoder, j.board, *j.encoder,
                                     at(c.where(fmt::format("{}.encoder.{:02d}.position", j.board, *j.encoder)))));
    a.drive.emplace_back("encoder_lines",
                         fmt::format("{}|{} counts/{} ({}), 4 counts a line, the assumed pitch{}", e.lines,
                                     fmtNumber(std::abs(encScale->v)), j.unitName, encScale->from,
                                     j.gear != 1.0 ? ", and a gear ratio making the counts exact" : ""));
    a.drive.emplace_back("encoder_reversed",
                         std::string(encScale->v < 0 ? "true" : "false") + "|the encoder scale's sign");
  }
  return true;
}

// A servo axis: the encoder's lines from its scale, the drive's gain and
// direction from the analog output's scalemax and the PID's FF1.
bool deriveServo(DeriveContext& c, Joint& j, AxisOut& a) {
  const auto encScale = encoderScale(c, j);
  if (!encScale) return false;
  const auto drive = analogDrive(c, j.n, j.section, j.pid, j.analogPin);
  const auto& outScale = drive.scalemax;
  const auto& ff1 = drive.ff1;
  if (!c.within(encScale, kScaleBound) || !c.within(outScale, kOutputScaleBound) || !c.within(ff1, kFf1Bound))
    return false;
  const auto e = encoderLines(std::abs(encScale->v) / j.mmPerUnit, j.pitch);
  if (!c.encoderFits(e, *encScale)) return false;
  const double lines = static_cast<double>(e.lines);
  j.gear = e.gear;
  std::string linesWhy = fmt::format("{} counts/{} ({}), 4 counts a line, the assumed pitch",
                                     fmtNumber(std::abs(encScale->v)), j.unitName, encScale->from);
  if (j.gear != 1.0) linesWhy += ", and a gear ratio making the counts exact";
  a.keys.emplace_back("screw_pitch",
                      fmtNumber(j.pitch) + "|assumed: a configuration gives counts per unit, not the screw");
  a.keys.emplace_back("gear_ratio", fmtNumber(j.gear) + "|motor revolutions per screw revolution");
  const double lead = j.pitch / j.gear;
  a.tableName = "axis.drive";
  a.drive.emplace_back("analog_output", fmt::format("{}|{} ({})", *j.analog, j.analogPin, at(c.where(j.analogPin))));
  a.drive.emplace_back("enable", fmt::format("{}|AnalogEna{}", *j.analog, *j.analog == 5 ? "/SpinEna (ENA5)" : ""));
  a.drive.emplace_back("encoder_input",
                       fmt::format("{}|{}.encoder.{:02d} ({})", *j.encoder, j.board, *j.encoder,
                                   at(c.where(fmt::format("{}.encoder.{:02d}.position", j.board, *j.encoder)))));
  a.drive.emplace_back("encoder_lines", fmtNumber(lines).substr(0, fmtNumber(lines).find('.')) + "|" + linesWhy);
  a.drive.emplace_back(
      "encoder_reversed",
      std::string(encScale->v < 0 ? "true" : "false") + "|" +
          (encScale->v < 0 ? "a negative ENCODER_SCALE: it counts down going forward" : "the encoder scale's sign"));
  // The PID's output is scalemax at 10 V; with FF1 the output is FF1 x
  // the commanded velocity, so the drive must give 10 V /
  // (scalemax / FF1) per unit/s for the feed-forward to be right (FF1 0
  // or none: the scale taken alone).
  const double unitsPerSecondPerVolt = drive.velocityAt(std::abs(outScale.v)).value_or(std::abs(outScale.v)) / 10.0;
  const double gain = unitsPerSecondPerVolt * j.mmPerUnit / lead;
  // The amplifier's limit is 11 V of it.
  if (!c.derived(gain, kMinGain, kMaxLimit / 11.0, outScale,
                 ff1 && ff1->v > 0
                     ? fmt::format("over FF1 {:g} ({}), a drive gain (motor rev/s per V) of", ff1->v, at(ff1->at))
                     : std::string("on the assumed 5 mm screw, a drive gain (motor rev/s per V) of")))
    return false;
  a.amplifier.emplace_back("mode", "\"velocity\"|assumed: the PID's output is a velocity (FF1 feed-forward)");
  a.amplifier.emplace_back(
      "gain", fmtNumber(gain) + "|" +
                  fmt::format("motor rev/s per V: {} {}/s at 10 V ({}){}", fmtNumber(std::abs(outScale.v)), j.unitName,
                              outScale.from,
                              ff1 && ff1->v > 0 ? fmt::format(" over FF1 {} ({})", fmtNumber(ff1->v), ff1->from)
                                                : std::string(", FF1 0 or none: the scale taken alone")));
  a.amplifier.emplace_back("limit", fmtNumber(gain * 11.0) + "|saturates just past the 7I77's 10 V");
  a.amplifier.emplace_back("reversed", std::string(outScale.v < 0 ? "true" : "false") + "|" +
                                           (outScale.v < 0 ? "a negative OUTPUT_SCALE: positive volts turn it backwards"
                                                           : "the output scale's sign"));
  if (10.0 * unitsPerSecondPerVolt < j.vmax * 0.999)
    c.warning(j.iniAt, j.section,
              fmt::format("joint {}: 10 V gives {} {}/s, under MAX_VELOCITY {}: the PID saturates", j.n,
                          fmtNumber(10.0 * unitsPerSecondPerVolt), j.unitName, fmtNumber(j.vmax)));
  return true;
}

}  // namespace

void deriveAxis(DeriveContext& c, unsigned n, char letter, const std::string& name) {
  Joint j;
  j.n = n;
  j.name = name;
  if (!findDrive(c, j, letter) || !readMotion(c, j)) return;
  AxisOut a;
  a.name = name;
  j.unitName = j.angular ? "degrees" : (c.inch ? "inch" : "mm");
  a.comment = fmt::format("joint {} ([{}], {}){}", n, j.section, j.unitName,
                          j.angular ? ": a rotary joint, one machine unit a degree" : "");
  if (c.inch && !j.angular) a.comment += ": machine files are in mm, 25.4 to the inch";
  // The screw: a configuration gives counts and volts per unit, never the
  // pitch; 5 mm (0.2 in) is assumed and the encoder's lines and the
  // gearing follow from it.
  j.pitch = c.inch && !j.angular ? 5.08 : 5.0;
  if (j.stepgen ? !deriveStepper(c, j, a) : !deriveServo(c, j, a)) return;
  Homing h;
  if (!placeHoming(c, j, a, h)) return;
  placeSwitches(c, j, h);
  checkHomeSwitch(c, j);
  findBrake(c, j, a);
  if (j.stepgen) c.claimedStepgens.insert(*j.stepgen);
  if (j.encoder) c.claimedEncoders.insert(*j.encoder);
  if (j.analog) c.claimedAnalogs.insert(*j.analog);
  c.out.axes.push_back(std::move(a));
}

}  // namespace lbpkit::linuxcnc::detail
