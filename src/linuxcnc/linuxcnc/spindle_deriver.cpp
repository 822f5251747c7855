// SPDX-License-Identifier: MIT
// The spindle (spindle_deriver.hpp; hostmot2(9): analogout scalemax,
// encoder scale; the 7I77 manual: analog output 5 and ENA5 for a spindle;
// the 7I76 manual: SpinOut, SpinEna, SpinDir).
#include "linuxcnc/spindle_deriver.hpp"
#include "linuxcnc/hal_name.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

namespace lbpkit::linuxcnc::detail {

void deriveSpindle(DeriveContext& c) {
  std::optional<unsigned> analog;
  std::string pin;
  bool on7I76 = false;
  for (const auto& [p, sig] : c.graph.pinSignal()) {
    if (const auto a = analogOut(p); a && !c.claimedAnalogs.count(*a) && (!analog || *a == 5)) {
      analog = *a;
      pin = p;
    }
    if (p.ends_with(".7i76.0.0.spinout") && !analog) {
      on7I76 = true;
      pin = p;
    }
  }
  if (!analog && !on7I76) return;
  const auto scale = c.value(pin + "-scalemax", "SPINDLE_0", "OUTPUT_SCALE")
                         .value_or(Value{10.0, "hostmot2's default scalemax 10 (none set)", {}, c.where(pin), {}});
  if (!c.within(scale, kOutputScaleBound) ||
      !c.derived(std::abs(scale.v), std::max(1.0, 10.0 * kMinRpmPerVolt), std::min(kMaxRpm, 10.0 * kMaxRpmPerVolt),
                 scale, "the spindle's rpm at 10 V"))
    return;
  c.out.spindle.emplace_back("daughtercard", on7I76 ? "\"7I76\"|the 7I76's SpinOut, SpinEna, SpinDir" : "\"7I77\"|");
  if (!on7I76) {
    c.out.spindle.emplace_back("analog_output", fmt::format("{}|{} ({})", *analog, pin, at(c.where(pin))));
    c.out.spindle.emplace_back("enable",
                               fmt::format("{}|{}", *analog, *analog == 5 ? "ENA5 follows spinena" : "AnalogEna"));
  }
  c.out.spindle.emplace_back("rpm_per_volt", fmtNumber(std::abs(scale.v) / 10.0) + "|" + scale.from + " rpm at 10 V");
  c.out.spindle.emplace_back("max_rpm", fmtNumber(std::abs(scale.v)) + "|10 V");
  // Its encoder: one on the spindle's feedback signals that no joint reads.
  std::optional<unsigned> encoder;
  std::string board, encoderPin;
  for (const char* feedback : {"spindle.0.revs", "spindle.0.speed-in", "spindle.0.index-enable", "motion.spindle-revs",
                               "motion.spindle-speed-in", "motion.spindle-index-enable"})
    for (const auto& p : c.graph.pinsOn(c.graph.signal(feedback))) {
      const auto parts = split(p, '.');
      if (parts.size() == 5 && parts[2] == "encoder" && !encoder) {
        if (const auto e = hal_name::number(parts[3]); e && !c.claimedEncoders.count(*e)) {
          encoder = *e;
          encoderPin = p;
          board = cardOf(p);
        }
      }
    }
  if (encoder && *encoder >= kEncoders && !c.sevenI76) {
    c.warning(c.where(encoderPin), encoderPin,
              fmt::format("{} is a counter of the second 7I77 (6 to 11): lbpkit's derived machine sits behind the "
                          "first 7I77 only, so the spindle's encoder is left out",
                          encoderPin));
    c.out.spindle.emplace_back("encoder_input",
                               fmt::format("-1|{}.encoder.{:02d} is the second 7I77's", board, *encoder));
    return;
  }
  if (!encoder) {
    c.out.spindle.emplace_back("encoder_input", "-1|no encoder on spindle.0.revs or speed-in");
    return;
  }
  const auto encScale = c.value(fmt::format("{}.encoder.{:02d}.scale", board, *encoder), "SPINDLE_0", "ENCODER_SCALE")
                            .value_or(Value{4096.0, "assumed 1024 lines (no scale set)", {}, c.where(pin), {}});
  if (!c.within(encScale, kScaleBound) ||
      !c.derived(std::max(1.0, std::round(std::abs(encScale.v) / 4.0)), 1.0, kMaxEncoderLines, encScale,
                 "the spindle encoder's lines (counts a revolution / 4)"))
    return;
  const bool encoderOn7I76 = c.sevenI76 && *encoder == 6;
  c.out.spindle.emplace_back("encoder_daughtercard",
                             encoderOn7I76 ? "\"7I76\"|muxed counter 6 is the 7I76's" : "\"7I77\"|");
  c.out.spindle.emplace_back("encoder_input",
                             fmt::format("{}|{}.encoder.{:02d}", encoderOn7I76 ? 0 : *encoder, board, *encoder));
  c.out.spindle.emplace_back("encoder_lines",
                             fmt::format("{}|{} counts a revolution ({})",
                                         static_cast<long>(std::max(1.0, std::round(std::abs(encScale.v) / 4.0))),
                                         fmtNumber(std::abs(encScale.v)), encScale.from));
  c.out.spindle.emplace_back("encoder_reversed", std::string(encScale.v < 0 ? "true" : "false") + "|the scale's sign");
}

}  // namespace lbpkit::linuxcnc::detail
