// SPDX-License-Identifier: MIT
// The 7I77's isolated field I/O processor: SSLBP channel 0 (manual: FIELD I/O,
// FIELD I/O PARAMETERS, SOFTWARE PROCESS DATA MODES).
//
// 32 sinking inputs with 60 % / 40 % of field voltage thresholds, 16 outputs
// (sourcing on the 7I77, sinking on the 7I77D) in two driver chips of 8, the
// analog readings of inputs 0..3 and of the field voltage, and two MPG
// counters on inputs 16..19 in mode 3.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <span>
#include <string>

#include "remote/remote_device.hpp"

namespace lbpkit::model::remote {

enum class OutputType { Sourcing, Sinking };  // 7I77, 7I77D

// A field I/O processor that runs from its board's supply, field power (the
// 7I77's with W1 left, and the 7I76's: seven_i76.hpp): its power
// sequencing, shared by both. It runs while its supply is at least kMinVin,
// and flags a field voltage outside kLowFieldVoltage..kHighFieldVoltage at
// power-up and at every fault clear (manual: VIN AND FIELD POWER SUPPLY).
class FieldPoweredProcessor : public RemoteDevice {
 public:
  static constexpr double kMinVin = 8.0;            // processor runs at VIN >= 8 V
  static constexpr double kLowFieldVoltage = 5.0;   // below: LowVoltageFault
  static constexpr double kHighFieldVoltage = 32.0;  // above: HighVoltageFault

  void setFieldVoltage(double volts, SimTime now);
  // The supply off and on (the machine power-cycled): the processor boots
  // again if its supply is present, with the supply checks a power-up makes.
  void powerCycle(SimTime now) override;
  [[nodiscard]] double fieldVoltage() const { return fieldVolts_; }

 protected:
  FieldPoweredProcessor(Identity identity, std::span<const ProcessDataDescriptor> elements,
                        std::span<const SoftwareMode> modes, std::filesystem::path nvFile, std::string nvOwner,
                        NvReporter nvReport, double fieldVolts);
  // After a change of supply: the processor boots or stops, the inputs are
  // read again at the new thresholds, the supply is checked and the outputs
  // driven. The derived constructor calls it once (this one cannot reach
  // their overrides).
  void applyPower(SimTime now);
  void checkSupply();
  // What runs the processor: field power, or the 7I77's VIN with W1 right.
  [[nodiscard]] virtual double supplyVolts() const { return fieldVolts_; }
  // Every input's state again from its voltage and the field voltage.
  virtual void updateInputs() = 0;

  double fieldVolts_;
};

class FieldIoProcessor final : public FieldPoweredProcessor {
 public:
  static constexpr unsigned kInputs = 32;
  static constexpr unsigned kOutputs = 16;
  static constexpr unsigned kOutputsPerChip = 8;
  static constexpr unsigned kChips = kOutputs / kOutputsPerChip;
  static constexpr unsigned kMpgs = 2;

  // Electrical limits (manual: SHORT CIRCUIT PROTECTION, MAXIMUM PER CHIP
  // CURRENT, ANALOG INPUTS, MPG INPUTS; the supply's: FieldPoweredProcessor).
  static constexpr double kShortCircuitAmps = 0.8;
  static constexpr double kChipLimitAmps = 1.4;
  static constexpr double kAnalogFullScale = 36.3;  // 8-bit readings
  static constexpr double kMpgThreshold = 2.5;
  static constexpr double kHighThreshold = 0.6;  // of field voltage
  static constexpr double kLowThreshold = 0.4;

  struct Options {
    OutputType outputs = OutputType::Sourcing;
    std::uint32_t unitNumber = 0x12000AEE;  // top byte 0x12: 7I77 field I/O (docs/protocol-facts.md#unit-numbers-and-names)
    std::filesystem::path nvFile;          // empty: EEPROM in memory
    std::string nvOwner;                    // who holds nvFile, told to a second user (nv_store.hpp)
    NvReporter nvReport;                    // what the EEPROM file has to say (the model cannot log)
    bool setupMode = false;                 // W12 right
    bool vinFromField = true;               // W1 left: VIN = field power
    double fieldVoltage = 24.0;
    double vin = 24.0;  // only used with vinFromField = false
  };

  // What an observer sees at the terminals and of the processor.
  struct State {
    struct Input {
      double volts = 0.0;
      bool on = false;
    };
    struct Output {
      bool on = false;
      double volts = 0.0;
      double amps = 0.0;  // infinity: a dead short on a driver that is on
      bool tripped = false;
    };
    DeviceState device;
    OutputType outputType = OutputType::Sourcing;
    double fieldVoltage = 0.0;
    double vin = 0.0;
    bool fieldVoltageLed = false;  // CR3
    std::array<Input, kInputs> inputs{};
    std::array<Output, kOutputs> outputs{};
    std::array<std::uint8_t, kMpgs> mpg{};
  };

  explicit FieldIoProcessor(Options options, SimTime now = SimTime{0});
  FieldIoProcessor() : FieldIoProcessor(Options{}) {}

  // --- The world at the terminals ---------------------------------------------
  // (setFieldVoltage, powerCycle: FieldPoweredProcessor.)
  void setVin(double volts, SimTime now);  // TB2 pin 5, with W1 right
  void setInputVoltage(unsigned input, double volts);
  // Resistive load from an output to field ground (7I77) or field power
  // (7I77D); infinity is an open terminal, 0 a dead short.
  void setOutputLoad(unsigned output, double ohms);
  void setDriverOverTemperature(unsigned chip, bool hot);

  // --- What the terminals show --------------------------------------------------
  [[nodiscard]] double vin() const { return vinFromField_ ? fieldVolts_ : vinVolts_; }
  [[nodiscard]] double inputVoltage(unsigned i) const { return inputVolts_.at(i); }
  [[nodiscard]] bool input(unsigned i) const { return (inputBits_ >> i) & 1U; }
  [[nodiscard]] std::uint32_t inputs() const { return inputBits_; }
  [[nodiscard]] bool outputOn(unsigned i) const { return (outputsOn_ >> i) & 1U; }
  [[nodiscard]] std::uint16_t outputs() const { return outputsOn_; }
  [[nodiscard]] double outputVoltage(unsigned i) const;
  [[nodiscard]] double outputCurrent(unsigned i) const;
  [[nodiscard]] bool outputTripped(unsigned i) const { return (tripped_ >> i) & 1U; }
  [[nodiscard]] bool chipShutdown(unsigned chip) const { return chipOff_.at(chip); }
  [[nodiscard]] std::uint8_t mpgCount(unsigned n) const { return static_cast<std::uint8_t>(mpgCounts_.at(n)); }
  [[nodiscard]] OutputType outputType() const { return outputType_; }
  // CR3: field voltage present.
  [[nodiscard]] bool fieldVoltageLed() const { return fieldVolts_ >= kLowFieldVoltage; }
  [[nodiscard]] State state() const;

  // 8-bit reading of a voltage at 36.3 V full scale (manual: ANALOG INPUTS).
  static std::uint8_t analogReading(double volts);

 protected:
  void sampleInputs() override;
  void driveOutputs() override;
  void reassertFaults() override;
  void onPowerUp() override;
  [[nodiscard]] double supplyVolts() const override { return vin(); }
  void updateInputs() override;

 private:
  void updateInput(unsigned i);
  [[nodiscard]] bool mpgMode() const;
  void countMpg(unsigned n, bool oldA, bool oldB, bool newA, bool newB);

  OutputType outputType_;
  bool vinFromField_;
  double vinVolts_;
  std::array<double, kInputs> inputVolts_{};
  std::uint32_t inputBits_ = 0;
  // inputBits_ is what updateInputs() would make of the voltages in the
  // mode where mpgMode() is inputsMpg_ (the last updateInputs() made it so).
  bool inputsCurrent_ = false;
  bool inputsMpg_ = false;
  // analogReading() of inputs 0..3 and the field voltage, and the voltages
  // they are of (NaN: none yet).
  std::array<std::uint8_t, 5> readings_{};
  std::array<double, 5> readVolts_{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                                   std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
                                   std::numeric_limits<double>::quiet_NaN()};
  std::array<double, kOutputs> loadOhms_{};
  std::uint16_t outputsOn_ = 0;
  std::uint16_t tripped_ = 0;  // disabled by short circuit until a fault clear
  std::array<bool, kChips> chipOff_{};
  std::array<bool, kChips> chipHot_{};
  std::array<std::int32_t, kMpgs> mpgCounts_{};
  std::array<ElementId, kMpgs> nvEncMode_{};  // NVEncMode0/1 (gtoc_parameters.hpp)
  // Counter modes (0 = 1X, 1 = 2X, 2 = 4X), from NVEncMode0/1 at power-up.
  std::array<std::uint8_t, kMpgs> encMode_{};
};

}  // namespace lbpkit::model::remote
