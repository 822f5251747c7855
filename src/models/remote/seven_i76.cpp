// SPDX-License-Identifier: MIT
#include "remote/seven_i76.hpp"

#include <algorithm>
#include <limits>

#include "remote/field_io.hpp"

namespace lbpkit::model::remote {

namespace {

// The 7I77's field I/O facts the 7I76 shares here (field_io.hpp): the input
// thresholds, the 8-bit analog readings at 36.3 V full scale, the supply
// limits. No public 7I76 manual text was at hand to say otherwise.
using Sibling = FieldIoProcessor;

// Process data, declared once. Names: the pins LinuxCNC's sserial(9) lists
// for the 7I76 (input-NN, output-NN, spinout, spinena, spindir, analogN,
// fieldvoltage; LinuxCNC builds them from the lowercased names, sserial.c).
// SpinOut is a float "in" pin with -scalemax/-minlim/-maxlim parameters
// there, which LinuxCNC makes for an UNSIGNED or SIGNED output; UNSIGNED
// because the 7I76's speed output is 0..10 V. Its width (16 bits), the
// units and the exact case of names are not attested: our choice.
enum Element : ElementId {
  kInput,
  kOutput,
  kSpinOut,
  kSpinEna,
  kSpinDir,
  kAnalog0,
  kAnalog1,
  kAnalog2,
  kAnalog3,
  kFieldVoltage,
};

constexpr float kFullScale = static_cast<float>(Sibling::kAnalogFullScale);
constexpr float kSpindleMax = static_cast<float>(SevenI76FieldIo::kSpindleFullScale);
constexpr unsigned kSpinOutBits = 16;

constexpr ProcessDataDescriptor kElements[] = {
    {"Input", "None", DataType::Bits, Direction::Input, 32, 0.0F, 0.0F},
    {"Output", "None", DataType::Bits, Direction::Output, 16, 0.0F, 0.0F},
    {"SpinOut", "V", DataType::Unsigned, Direction::Output, kSpinOutBits, 0.0F, kSpindleMax},
    {"SpinEna", "None", DataType::Boolean, Direction::Output, 1, 0.0F, 1.0F},
    {"SpinDir", "None", DataType::Boolean, Direction::Output, 1, 0.0F, 1.0F},
    {"Analog0", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"Analog1", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"Analog2", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"Analog3", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
    {"FieldVoltage", "V", DataType::Unsigned, Direction::Input, 8, 0.0F, kFullScale},
};

// sserial(9): analogN in "modes 1 and 2 only", fieldvoltage in "mode 2
// only". Mode names are ours. pncconf's 7I76 mode-2 table also puts MPG
// encoder inputs on inputs 16..19; sserial(9) lists no counter pins for the
// 7I76, so no counters here.
constexpr ElementId kMode0[] = {kInput, kOutput, kSpinOut, kSpinEna, kSpinDir};
constexpr ElementId kMode1[] = {kInput, kOutput, kSpinOut, kSpinEna, kSpinDir, kAnalog0, kAnalog1, kAnalog2, kAnalog3};
constexpr ElementId kMode2[] = {kInput,   kOutput,  kSpinOut, kSpinEna, kSpinDir,
                                kAnalog0, kAnalog1, kAnalog2, kAnalog3, kFieldVoltage};
constexpr SoftwareMode kModes[] = {
    {"IO+Spindle", kMode0},
    {"IO+Spindle+AnalogIn", kMode1},
    {"IO+Spindle+AnalogIn+FieldVoltage", kMode2},
};

// The rows of kGtocParameters every processor lists (kBothProcessors) and
// no others: the 7I76's parameters in sserial(9) are swrevision,
// nvbaudrate, nvunitnumber and nvwatchdogtimeout, no nvencmodeN. The analog
// processor's selection is exactly that set.
constexpr std::uint8_t kStandardRowsOnly = kAnalogProcessor;

}  // namespace

SevenI76FieldIo::SevenI76FieldIo(Options options, SimTime now)
    : FieldPoweredProcessor({"7I76", options.unitNumber, 14, 0, "Standard", kStandardRowsOnly}, kElements, kModes,
                            options.nvFile, options.nvOwner, options.nvReport, options.fieldVoltage) {
  loadOhms_.fill(std::numeric_limits<double>::infinity());
  setSetupJumper(options.setupMode);
  applyPower(now);
}

double SevenI76FieldIo::spindleVoltsOf(std::uint64_t code) {
  constexpr double kMaxCode = static_cast<double>((std::uint64_t{1} << kSpinOutBits) - 1);
  return std::clamp(static_cast<double>(code) / kMaxCode * kSpindleFullScale, 0.0, kSpindleFullScale);
}

// --- Inputs ---------------------------------------------------------------------

void SevenI76FieldIo::setInputVoltage(unsigned input, double volts) {
  inputVolts_.at(input) = volts;
  updateInput(input);
}

void SevenI76FieldIo::updateInputs() {
  for (unsigned i = 0; i < kInputs; ++i) updateInput(i);
}

void SevenI76FieldIo::updateInput(unsigned i) {
  const double v = inputVolts_[i];
  if (v >= Sibling::kHighThreshold * fieldVolts_ && v > 0.0)
    inputBits_ |= 1U << i;
  else if (v <= Sibling::kLowThreshold * fieldVolts_)
    inputBits_ &= ~(1U << i);
  // between the thresholds: hysteresis keeps the last state
}

void SevenI76FieldIo::sampleInputs() {
  setRaw(kInput, inputBits_);
  for (unsigned i = 0; i < kAnalogInputs; ++i)
    setRaw(static_cast<ElementId>(kAnalog0 + i), Sibling::analogReading(inputVolts_[i]));
  setRaw(kFieldVoltage, Sibling::analogReading(fieldVolts_));
}

// --- Outputs --------------------------------------------------------------------

void SevenI76FieldIo::driveOutputs() {
  // Outputs off, the speed output at 0 V and enable off while unpowered or
  // blocked by the watchdog (as the 7I77's field I/O and analog outputs).
  const bool active = powered() && !outputsBlocked();
  outputsOn_ = active ? static_cast<std::uint16_t>(raw(kOutput)) : std::uint16_t{0};
  const std::uint64_t code = active ? raw(kSpinOut) : 0;
  if (code != spinCode_) {
    spinCode_ = code;
    spindleVolts_ = spindleVoltsOf(code);
  }
  spindleEnable_ = active && raw(kSpinEna) != 0;
  spindleDirection_ = active && raw(kSpinDir) != 0;
}

void SevenI76FieldIo::setOutputLoad(unsigned output, double ohms) { loadOhms_.at(output) = std::max(0.0, ohms); }

double SevenI76FieldIo::outputCurrent(unsigned i) const {
  // Sourcing, as the 7I77's outputs: field power across the load while on
  // (a dead short would draw without bound; its protection is not modelled).
  const double volts = outputVoltage(i);
  if (volts == 0.0) return 0.0;
  const double ohms = loadOhms_.at(i);
  return ohms > 0.0 ? volts / ohms : std::numeric_limits<double>::infinity();
}

SevenI76FieldIo::State SevenI76FieldIo::state() const {
  State s{deviceState(), fieldVolts_, inputBits_, outputsOn_, spindleVolts_, spindleEnable_, spindleDirection_, {}};
  for (unsigned i = 0; i < kOutputs; ++i) s.outputAmps[i] = outputCurrent(i);
  return s;
}

}  // namespace lbpkit::model::remote
