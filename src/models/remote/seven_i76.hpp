// SPDX-License-Identifier: MIT
// The 7I76's field I/O processor: the smart-serial remote on the 7I76 (on
// the 7I77+7I76 firmwares, SSerial channel 3: PIN_7I77_7I76_34.vhd;
// docs/cards.md#the-7i76-field-io).
//
// An LBP remote like the 7I77's field I/O processor (field_io.hpp), whose
// power sequencing it shares (FieldPoweredProcessor) and whose facts it
// shares where the public sources give no other: 32 inputs, 16
// sourcing outputs, the analog readings of inputs 0..3 and of the field
// voltage in its higher modes, and the spindle interface the 7I77 does not
// have: an analog speed output (SpinOut, 0..10 V) with enable and direction
// (LinuxCNC: sserial(9), "7I76"). Its step/dir outputs are the card's
// StepGens, not this processor's.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

#include "remote/field_io.hpp"

namespace lbpkit::model::remote {

class SevenI76FieldIo final : public FieldPoweredProcessor {
 public:
  static constexpr unsigned kInputs = 32;
  static constexpr unsigned kOutputs = 16;
  static constexpr unsigned kAnalogInputs = 4;  // inputs 0..3, read as analog in modes 1 and 2
  static constexpr double kSpindleFullScale = 10.0;  // volts at SpinOut's full scale

  struct Options {
    // Top byte 0x10: mesaflash's "GPIO+SPINDLE" (hostmot2_def.h
    // SSLBP_REMOTE_7I76_IO_SPINDLE); the rest as the 7I77's (our choice).
    std::uint32_t unitNumber = 0x10000AEE;
    std::filesystem::path nvFile;  // empty: EEPROM in memory
    std::string nvOwner;
    NvReporter nvReport;
    bool setupMode = false;
    double fieldVoltage = 24.0;  // the processor runs from field power, as the 7I77's (W1 left)
  };

  // What an observer sees at the terminals.
  struct State {
    DeviceState device;
    double fieldVoltage = 0.0;
    std::uint32_t inputs = 0;
    std::uint16_t outputs = 0;
    double spindleVolts = 0.0;
    bool spindleEnable = false;
    bool spindleDirection = false;
    std::array<double, kOutputs> outputAmps{};  // what each output's load draws
  };

  explicit SevenI76FieldIo(Options options, SimTime now = SimTime{0});
  SevenI76FieldIo() : SevenI76FieldIo(Options{}) {}

  // --- The world at the terminals ---------------------------------------------
  // (setFieldVoltage, powerCycle: FieldPoweredProcessor.)
  void setInputVoltage(unsigned input, double volts);
  // Resistive load from an output to field ground (the outputs source);
  // infinity (the default) is an open terminal. Short circuit protection
  // is not modelled: a load draws what field power over it gives.
  void setOutputLoad(unsigned output, double ohms);

  // --- What the terminals show --------------------------------------------------
  [[nodiscard]] bool input(unsigned i) const { return (inputBits_ >> i) & 1U; }
  [[nodiscard]] std::uint32_t inputs() const { return inputBits_; }
  [[nodiscard]] bool outputOn(unsigned i) const { return (outputsOn_ >> i) & 1U; }
  [[nodiscard]] std::uint16_t outputs() const { return outputsOn_; }
  // Sourcing: an output that is on is at field power.
  [[nodiscard]] double outputVoltage(unsigned i) const { return outputOn(i) ? fieldVolts_ : 0.0; }
  [[nodiscard]] double outputLoad(unsigned i) const { return loadOhms_.at(i); }
  [[nodiscard]] double outputCurrent(unsigned i) const;
  [[nodiscard]] double spindleVolts() const { return spindleVolts_; }
  [[nodiscard]] bool spindleEnable() const { return spindleEnable_; }
  [[nodiscard]] bool spindleDirection() const { return spindleDirection_; }
  [[nodiscard]] State state() const;

  // SpinOut's code to volts: full scale (all ones) is 10 V, as LinuxCNC
  // scales an UNSIGNED output (sserial.c: value / scalemax * (2^bits - 1)).
  static double spindleVoltsOf(std::uint64_t code);

 protected:
  void sampleInputs() override;
  void driveOutputs() override;
  void reassertFaults() override { checkSupply(); }
  void updateInputs() override;

 private:
  void updateInput(unsigned i);

  std::array<double, kInputs> inputVolts_{};
  std::array<double, kOutputs> loadOhms_{};
  std::uint32_t inputBits_ = 0;
  std::uint16_t outputsOn_ = 0;
  std::uint64_t spinCode_ = 0;
  double spindleVolts_ = 0.0;
  bool spindleEnable_ = false;
  bool spindleDirection_ = false;
};

}  // namespace lbpkit::model::remote
