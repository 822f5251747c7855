// SPDX-License-Identifier: MIT
#include "remote/field_io.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

namespace lbpkit::model::remote {

namespace {

// Process data of the field I/O processor, declared once (its GTOC
// parameters, NVEncMode0/1 among them, are rows of kGtocParameters). Names:
// the pins public 7I77 configurations use (input-NN, output-NN); the mode
// 1..3 names follow pncconf's smart-serial pin names (analoginN, encN;
// LinuxCNC: pncconf.py) and the 7I76's and 7I70's fieldvoltage (sserial(9))
// (docs/protocol-facts.md#unit-numbers-and-names).
// Units and the exact case of names are not attested: our choice.
enum Element : ElementId {
  kInput,
  kOutput,
  kAnalogIn0,
  kAnalogIn1,
  kAnalogIn2,
  kAnalogIn3,
  kFieldVoltage,
  kEnc0,
  kEnc1,
};

constexpr float kFullScale = static_cast<float>(FieldIoProcessor::kAnalogFullScale);

constexpr ProcessDataDescriptor kElements[] = {
    {"Input", "None", DataType::Bits, Direction::Input, 32, 0.0F, 0.0F},
    {"Output", "None", DataType::Bits, Direction::Output, 16, 0.0F, 0.0F},
    {"AnalogIn0", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"AnalogIn1", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"AnalogIn2", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"AnalogIn3", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"FieldVoltage", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"Enc0", "count", DataType::Encoder, Direction::Input, 8, 0.0F, 1.0F},
    {"Enc1", "count", DataType::Encoder, Direction::Input, 8, 0.0F, 1.0F},
};

// SOFTWARE PROCESS DATA MODES, PTOC order. Sizes to the host (fault byte
// included): 5, 9, 10, 12 bytes; from the host: 2 bytes in every mode.
constexpr ElementId kMode0[] = {kInput, kOutput};
constexpr ElementId kMode1[] = {kInput, kOutput, kAnalogIn0, kAnalogIn1, kAnalogIn2, kAnalogIn3};
constexpr ElementId kMode2[] = {kInput, kOutput, kAnalogIn0, kAnalogIn1, kAnalogIn2, kAnalogIn3, kFieldVoltage};
constexpr ElementId kMode3[] = {kInput,     kOutput,       kAnalogIn0, kAnalogIn1, kAnalogIn2,
                                kAnalogIn3, kFieldVoltage, kEnc0,      kEnc1};
constexpr SoftwareMode kModes[] = {
    {"IO", kMode0},
    {"IO+AnalogIn", kMode1},
    {"IO+AnalogIn+FieldVoltage", kMode2},
    {"IO+AnalogIn+FieldVoltage+MPG", kMode3},
};

// MPG inputs in mode 3 as pncconf's 7I77 mode-3 table assigns them
// (LinuxCNC: pncconf private_data.py, "7i77-m3": input 16 ENCB 0, 17 ENCA 0,
// 18 ENCB 1, 19 ENCA 1); the manual says only "inputs 16,17,18 and 19".
constexpr unsigned kMpgA[] = {17, 19};
constexpr unsigned kMpgB[] = {16, 18};

}  // namespace

// --- Power (either board's field I/O processor) ---------------------------------

FieldPoweredProcessor::FieldPoweredProcessor(Identity identity, std::span<const ProcessDataDescriptor> elements,
                                             std::span<const SoftwareMode> modes, std::filesystem::path nvFile,
                                             std::string nvOwner, NvReporter nvReport, double fieldVolts)
    : RemoteDevice(identity, elements, modes, std::move(nvFile), std::move(nvOwner), std::move(nvReport)),
      fieldVolts_(fieldVolts) {}

void FieldPoweredProcessor::applyPower(SimTime now) {
  // VIN powers the processor: it must be present for the field I/O to be
  // detected and operate (manual: VIN AND FIELD POWER SUPPLY).
  const bool on = supplyVolts() >= kMinVin;
  if (on && !powered()) powerUp(now);
  if (!on && powered()) powerDown();
  updateInputs();
  if (powered()) checkSupply();
  driveOutputs();
}

void FieldPoweredProcessor::powerCycle(SimTime now) {
  advance(now);
  powerDown();
  applyPower(now);
}

void FieldPoweredProcessor::setFieldVoltage(double volts, SimTime now) {
  advance(now);
  fieldVolts_ = std::max(0.0, volts);
  applyPower(now);
}

void FieldPoweredProcessor::checkSupply() {
  if (fieldVolts_ < kLowFieldVoltage) raiseFault(fault::kLowVoltage);
  if (fieldVolts_ > kHighFieldVoltage) raiseFault(fault::kHighVoltage);
}

// --- The 7I77's ------------------------------------------------------------------

FieldIoProcessor::FieldIoProcessor(Options options, SimTime now)
    : FieldPoweredProcessor({"7I77", options.unitNumber, 14, 0, "Standard", kFieldIoProcessor}, kElements, kModes,
                            options.nvFile, options.nvOwner, options.nvReport, options.fieldVoltage),
      outputType_(options.outputs),
      vinFromField_(options.vinFromField),
      vinVolts_(options.vin) {
  loadOhms_.fill(std::numeric_limits<double>::infinity());
  nvEncMode_ = {parameter("NVEncMode0"), parameter("NVEncMode1")};
  setSetupJumper(options.setupMode);
  applyPower(now);
}

std::uint8_t FieldIoProcessor::analogReading(double volts) {
  const double code = std::round(volts / kAnalogFullScale * 255.0);
  return static_cast<std::uint8_t>(std::clamp(code, 0.0, 255.0));
}

void FieldIoProcessor::setVin(double volts, SimTime now) {
  advance(now);
  vinVolts_ = std::max(0.0, volts);
  applyPower(now);
}

void FieldIoProcessor::onPowerUp() {
  mpgCounts_.fill(0);
  tripped_ = 0;
  chipOff_ = chipHot_;
  // NV to working copy at power-up only (manual: NON-VOLATILE FIELD I/O
  // PARAMETERS); no sibling lists the working copy as a parameter.
  for (unsigned n = 0; n < kMpgs; ++n) encMode_[n] = static_cast<std::uint8_t>(raw(nvEncMode_[n]));
}

void FieldIoProcessor::reassertFaults() {
  // A fault clear re-enables shorted outputs and cool chips; what is still
  // wrong trips again (manual: SHORT CIRCUIT / OVER-TEMPERATURE PROTECTION).
  tripped_ = 0;
  for (unsigned c = 0; c < kChips; ++c) {
    chipOff_[c] = chipHot_[c];
    if (chipHot_[c]) raiseFault(fault::kOverTemp);
  }
  checkSupply();
}

// --- Inputs ---------------------------------------------------------------------

bool FieldIoProcessor::mpgMode() const { return softwareMode() == 3; }

void FieldIoProcessor::setInputVoltage(unsigned input, double volts) {
  const bool oldA[] = {this->input(kMpgA[0]), this->input(kMpgA[1])};
  const bool oldB[] = {this->input(kMpgB[0]), this->input(kMpgB[1])};
  inputVolts_.at(input) = volts;
  updateInput(input);
  // This input now follows the current mode's thresholds; the others keep
  // inputsMpg_'s (sampleInputs() brings them all to one mode).
  if (mpgMode() != inputsMpg_) inputsCurrent_ = false;
  if (!mpgMode() || !powered()) return;
  for (unsigned n = 0; n < kMpgs; ++n)
    countMpg(n, oldA[n], oldB[n], this->input(kMpgA[n]), this->input(kMpgB[n]));
}

void FieldIoProcessor::updateInput(unsigned i) {
  const double v = inputVolts_[i];
  bool state = input(i);
  if (mpgMode() && i >= 16 && i <= 19) {
    state = v >= kMpgThreshold;  // fixed 2.5 V for 5 V encoder signals
  } else if (v >= kHighThreshold * fieldVolts_ && v > 0.0) {
    state = true;
  } else if (v <= kLowThreshold * fieldVolts_) {
    state = false;
  }  // between the thresholds: hysteresis keeps the last state
  if (state)
    inputBits_ |= 1U << i;
  else
    inputBits_ &= ~(1U << i);
}

void FieldIoProcessor::updateInputs() {
  // updateInput() for every input, with what it works out for each one
  // (the mode, the thresholds) worked out once: this runs at every command.
  const bool mpg = mpgMode();
  const double high = kHighThreshold * fieldVolts_;
  const double low = kLowThreshold * fieldVolts_;
  inputsCurrent_ = true;
  inputsMpg_ = mpg;
  std::uint32_t bits = inputBits_;
  for (unsigned i = 0; i < kInputs; ++i) {
    const double v = inputVolts_[i];
    bool state = false;
    if (mpg && i >= 16 && i <= 19)
      state = v >= kMpgThreshold;
    else if (v >= high && v > 0.0)
      state = true;
    else if (v <= low)
      state = false;
    else
      continue;  // between the thresholds: hysteresis keeps the last state
    bits = state ? bits | (1U << i) : bits & ~(1U << i);
  }
  inputBits_ = bits;
}

void FieldIoProcessor::countMpg(unsigned n, bool oldA, bool oldB, bool newA, bool newB) {
  if (oldA == newA && oldB == newB) return;
  // Quadrature, A leading B counts up. EncMode: 0 = 1X (rising A only, the
  // default for 100 PPR MPGs), 1 = 2X (both A edges), 2 = 4X (every edge).
  const auto mode = encMode_[n];
  int dir = 0;
  if (oldA != newA) dir = (newA != newB) ? +1 : -1;
  else dir = (newA == newB) ? +1 : -1;
  const bool countIt = mode >= 2 || (mode == 1 && oldA != newA) || (oldA != newA && newA);
  if (countIt) mpgCounts_[n] += dir;
}

void FieldIoProcessor::sampleInputs() {
  // Every input's state is what updateInput() makes of its voltage (it
  // would change nothing) while no input was set under another mode and the
  // mode is the same: setInputVoltage() and applyPower() keep it so.
  if (!inputsCurrent_ || mpgMode() != inputsMpg_) updateInputs();
  setRaw(kInput, inputBits_);
  // The readings of inputs 0..3 and of the field voltage, worked out again
  // only for a voltage that is not the one last read.
  for (unsigned k = 0; k < readings_.size(); ++k) {
    const double volts = k < 4 ? inputVolts_[k] : fieldVolts_;
    if (!(volts == readVolts_[k])) {
      readVolts_[k] = volts;
      readings_[k] = analogReading(volts);
    }
  }
  for (unsigned i = 0; i < 4; ++i) setRaw(static_cast<ElementId>(kAnalogIn0 + i), readings_[i]);
  setRaw(kFieldVoltage, readings_[4]);
  setRaw(kEnc0, static_cast<std::uint32_t>(mpgCounts_[0]));
  setRaw(kEnc1, static_cast<std::uint32_t>(mpgCounts_[1]));
}

// --- Outputs --------------------------------------------------------------------

void FieldIoProcessor::setOutputLoad(unsigned output, double ohms) {
  loadOhms_.at(output) = std::max(0.0, ohms);
  driveOutputs();
}

void FieldIoProcessor::setDriverOverTemperature(unsigned chip, bool hot) {
  chipHot_.at(chip) = hot;
  if (hot && powered()) {
    chipOff_[chip] = true;
    raiseFault(fault::kOverTemp);
  }
  driveOutputs();
}

double FieldIoProcessor::outputCurrent(unsigned i) const {
  if (!outputOn(i) || std::isinf(loadOhms_.at(i))) return 0.0;
  return loadOhms_[i] <= 0.0 ? std::numeric_limits<double>::infinity() : fieldVolts_ / loadOhms_[i];
}

double FieldIoProcessor::outputVoltage(unsigned i) const {
  // Sourcing: an on output connects the load to field power. Sinking: an on
  // output pulls the load's low side to field ground; off, the terminal
  // sits at field power through the load.
  if (outputType_ == OutputType::Sourcing) return outputOn(i) ? fieldVolts_ : 0.0;
  return outputOn(i) ? 0.0 : fieldVolts_;
}

FieldIoProcessor::State FieldIoProcessor::state() const {
  State s;
  s.device = deviceState();
  s.outputType = outputType_;
  s.fieldVoltage = fieldVoltage();
  s.vin = vin();
  s.fieldVoltageLed = fieldVoltageLed();
  for (unsigned i = 0; i < kInputs; ++i) s.inputs[i] = {inputVoltage(i), input(i)};
  for (unsigned i = 0; i < kOutputs; ++i) s.outputs[i] = {outputOn(i), outputVoltage(i), outputCurrent(i), outputTripped(i)};
  for (unsigned n = 0; n < kMpgs; ++n) s.mpg[n] = mpgCount(n);
  return s;
}

void FieldIoProcessor::driveOutputs() {
  const bool enabled = powered() && !outputsBlocked();
  const auto commanded = enabled ? static_cast<std::uint16_t>(raw(kOutput)) : std::uint16_t{0};
  // Commanded, not tripped, on a chip that is not shut down.
  unsigned chips = 0;
  for (unsigned c = 0; c < kChips; ++c)
    if (!chipOff_[c]) chips |= ((1U << kOutputsPerChip) - 1) << (c * kOutputsPerChip);
  const auto on = static_cast<std::uint16_t>(commanded & ~tripped_ & chips);
  outputsOn_ = on;
  if (!powered()) return;
  // Short circuit: the output turns itself off and the firmware flags it.
  // Outputs that are off carry no current (outputCurrent() is 0): only the
  // ones that are on are looked at, in order.
  for (unsigned rest = on; rest != 0; rest &= rest - 1) {
    const auto i = static_cast<unsigned>(std::countr_zero(rest));
    if (outputCurrent(i) > kShortCircuitAmps) {
      tripped_ = static_cast<std::uint16_t>(tripped_ | (1U << i));
      outputsOn_ = static_cast<std::uint16_t>(outputsOn_ & ~(1U << i));
      raiseFault(fault::kOverCurrent);
    }
  }
  // Per-chip current above 1.4 A: thermal shutdown of that chip.
  for (unsigned c = 0; c < kChips; ++c) {
    double amps = 0.0;  // an output that is off adds 0 A: the ones on, in order
    const unsigned chipMask = ((1U << kOutputsPerChip) - 1) << (c * kOutputsPerChip);
    for (unsigned rest = outputsOn_ & chipMask; rest != 0; rest &= rest - 1)
      amps += outputCurrent(static_cast<unsigned>(std::countr_zero(rest)));
    if (amps > kChipLimitAmps) {
      chipOff_[c] = true;
      raiseFault(fault::kOverTemp);
    }
    if (chipOff_[c]) outputsOn_ = static_cast<std::uint16_t>(outputsOn_ & ~(0xFFU << (c * kOutputsPerChip)));
  }
}

}  // namespace lbpkit::model::remote
