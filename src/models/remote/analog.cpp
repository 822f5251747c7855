// SPDX-License-Identifier: MIT
#include "remote/analog.hpp"

#include <algorithm>

namespace lbpkit::model::remote {

namespace {

// Process data of the analog processor, declared once (its GTOC parameters
// are the rows of kGtocParameters for both processors). Names are the pins
// public 7I77 configurations use (analogout0..5, analogena, spinena;
// docs/protocol-facts.md#unit-numbers-and-names). Packing: six 13-bit
// outputs in bits 0..77, AnalogEna bit 78, SpinEna bit 79 (mesaflash's
// 7I77 analog layout agrees): 10 bytes from the host, the fault byte back.
enum Element : ElementId {
  kAnalogOut0,
  kAnalogOut1,
  kAnalogOut2,
  kAnalogOut3,
  kAnalogOut4,
  kAnalogOut5,
  kAnalogEna,
  kSpinEna,
};

constexpr ProcessDataDescriptor kElements[] = {
    {"AnalogOut0", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogOut1", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogOut2", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogOut3", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogOut4", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogOut5", "V", DataType::Signed, Direction::Output, 13, -10.0F, 10.0F},
    {"AnalogEna", "None", DataType::Boolean, Direction::Output, 1, 0.0F, 1.0F},
    {"SpinEna", "None", DataType::Boolean, Direction::Output, 1, 0.0F, 1.0F},
};

constexpr ElementId kMode0[] = {kAnalogOut0, kAnalogOut1, kAnalogOut2, kAnalogOut3,
                                kAnalogOut4, kAnalogOut5, kAnalogEna,  kSpinEna};
constexpr SoftwareMode kModes[] = {{"Analog", kMode0}};

}  // namespace

AnalogProcessor::AnalogProcessor(Options options, SimTime now)
    : RemoteDevice({"7I77", options.unitNumber, 14, 0, "Standard", kAnalogProcessor}, kElements, kModes,
                   options.nvFile, options.nvOwner, options.nvReport) {
  setSetupJumper(options.setupMode);
  powerUp(now);
}

void AnalogProcessor::setLogicPower(bool on, SimTime now) {
  if (on && !powered()) powerUp(now);
  if (!on && powered()) powerDown();
}

AnalogProcessor::State AnalogProcessor::state() const {
  State s;
  s.device = deviceState();
  for (unsigned ch = 0; ch < kChannels; ++ch) s.outputs[ch] = {volts_[ch], codes_[ch], enables_[ch]};
  return s;
}

double AnalogProcessor::dacVolts(std::int64_t code) {
  const double v = static_cast<double>(code) * kFullScaleVolts / kDacMax;
  return std::clamp(v, -kFullScaleVolts, kFullScaleVolts);
}

void AnalogProcessor::driveOutputs() {
  const bool active = powered() && !outputsBlocked();
  // volts_[ch] is dacVolts(codes_[ch]) (both 0 at first): worked out again
  // only for a code that changed.
  for (unsigned ch = 0; ch < kChannels; ++ch) {
    const auto code =
        active ? static_cast<std::int16_t>(rawSigned(static_cast<ElementId>(kAnalogOut0 + ch))) : std::int16_t{0};
    if (code == codes_[ch]) continue;
    codes_[ch] = code;
    volts_[ch] = dacVolts(code);
  }
  const bool ena = active && raw(kAnalogEna) != 0;
  const bool spin = active && raw(kSpinEna) != 0;
  for (unsigned ch = 0; ch < 5; ++ch) enables_[ch] = ena;
  enables_[5] = spin;
}

}  // namespace lbpkit::model::remote
