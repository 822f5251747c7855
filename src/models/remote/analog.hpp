// SPDX-License-Identifier: MIT
// The 7I77's analog output processor: SSLBP channel 1 (manual: ANALOG SERVO
// DRIVE INTERFACE, SERVO ENABLE OUTPUTS, ANALOG SECTION WATCHDOG).
//
// Six +-10 V outputs at 13-bit resolution, ENA0..4 switched together by
// AnalogEna and ENA5 by SpinEna. Outputs are 0 V and enables off at power-up
// and whenever the watchdog bites (more than 50 ms between host
// communications).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>

#include "remote/remote_device.hpp"

namespace lbpkit::model::remote {

class AnalogProcessor final : public RemoteDevice {
 public:
  static constexpr unsigned kChannels = 6;
  static constexpr int kDacMax = 4095;  // 13-bit signed: -4096..4095
  static constexpr double kFullScaleVolts = 10.0;

  struct Options {
    std::uint32_t unitNumber = 0x11000AEE;  // top byte 0x11: 7I77 analog (docs/protocol-facts.md#unit-numbers-and-names)
    std::filesystem::path nvFile;
    std::string nvOwner;   // who holds nvFile, told to a second user (nv_store.hpp)
    NvReporter nvReport;   // what the EEPROM file has to say (the model cannot log)
    bool setupMode = false;  // W4 right
  };

  // What an observer sees at TB5 and of the processor.
  struct State {
    struct Output {
      double volts = 0.0;
      std::int16_t code = 0;  // DAC code
      bool enable = false;    // ENA0..ENA5
    };
    DeviceState device;
    std::array<Output, kChannels> outputs{};
  };

  explicit AnalogProcessor(Options options, SimTime now = SimTime{0});
  AnalogProcessor() : AnalogProcessor(Options{}) {}

  // 5 V logic power (host cable or TB1).
  void setLogicPower(bool on, SimTime now);

  // TB5 terminals.
  [[nodiscard]] double outputVoltage(unsigned channel) const { return volts_.at(channel); }
  [[nodiscard]] bool enable(unsigned channel) const { return enables_.at(channel); }  // ENA0..ENA5
  [[nodiscard]] std::int16_t dacCode(unsigned channel) const { return codes_.at(channel); }
  [[nodiscard]] State state() const;

  // The DAC: code 4095 is +10 V (manual: NUMERIC PROCESS DATA SCALING maps
  // PARAM_MAX to 2^(N-1)-1), clamped to the +-10 V output range.
  static double dacVolts(std::int64_t code);

 protected:
  void sampleInputs() override {}
  void driveOutputs() override;

 private:
  std::array<double, kChannels> volts_{};
  std::array<bool, kChannels> enables_{};
  std::array<std::int16_t, kChannels> codes_{};
};

}  // namespace lbpkit::model::remote
