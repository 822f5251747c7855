// SPDX-License-Identifier: MIT
// The in-process mill at 1 kHz, as one object: the 7I92 (Mesa's
// 7i92_7i77x2 firmware, as `lbpkit sim` runs it) with one 7I77, the built-in
// mill behind it, and the host library cycling as a LinuxCNC servo thread
// would (SSLBP outputs and inputs on both channels, the muxed encoders, a P
// position loop closed on every axis). All six of the 7I77's encoders turn:
// the mill uses four (X, Y, Z, the spindle on encoder 5 at 12 000 rpm), two
// rotary tables on AOUT3/ENC3 and AOUT4/ENC4 (ENA3 and ENA4 follow
// AnalogEna with the others: manual, SERVO ENABLE OUTPUTS) the other two.
// Every axis follows a triangle wave (+-20 mm or degrees at 20 mm/s,
// turning every 2 s), so no encoder stands still.
//
// One scenario for what the in-process figures measure: `lbpkit bench`'s
// "board + mill" row, BM_MillClosedLoop and lbpkit_inprocess_profile run it
// (docs/performance.md#in-process).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>

#include "lbpkit/encoders.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "machine/machine_file.hpp"
#include "sim_card/sim_transport.hpp"

namespace lbpkit {

// The built-in mill plus rotary tables A and B (10 degrees per motor
// revolution, no switches), its plant's longest span `step`.
[[nodiscard]] model::machine::MachineDescription millWithRotaryTables(std::chrono::microseconds step);

class MillClosedLoop {
 public:
  static constexpr unsigned kAxes = 5;  // X, Y, Z, A, B (encoders 0..4); the spindle is encoder 5

  // Both 7I77 channels discovered and started in normal mode, the drives
  // enabled, the Z brake released and the spindle turning.
  explicit MillClosedLoop(std::chrono::microseconds plantStep = std::chrono::microseconds(1000));

  // One servo period: the loops' outputs, one exchange, the inputs and
  // encoders, then the plant and the card up to the period's end.
  CycleStatus cycle();

  SimTransport& transport() { return card_.t; }
  [[nodiscard]] const model::machine::Machine& machine() const { return machine_; }
  [[nodiscard]] const MuxedEncoders& encoders() const { return card_.enc; }
  [[nodiscard]] const CycleStatus& status() const { return status_; }
  [[nodiscard]] std::uint64_t cycles() const { return cycles_; }
  // Simulated time since the first cycle could start.
  [[nodiscard]] double simulatedSeconds() {
    return std::chrono::duration<double>(card_.t.now() - begin_).count();
  }

 private:
  // Discovered, started and its encoders set up before the machine is
  // made: the machine starts at the card's time after all that.
  struct StartedCard {
    SimTransport t;
    CardInfo info;
    SmartSerial ss;
    MuxedEncoders enc;
    StartedCard();
  };
  StartedCard card_;
  model::machine::Machine machine_;
  std::array<ElementRef, 6> aout_{};
  std::array<double, kAxes> initial_{};  // where each axis started
  std::array<double, kAxes> offset_{};   // the encoders' positions at the first cycle
  CycleStatus status_{};
  Nanoseconds begin_{};
  std::uint64_t cycles_ = 0;
};

}  // namespace lbpkit
