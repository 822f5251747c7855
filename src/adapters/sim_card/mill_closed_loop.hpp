// The in-process 7I92 + 7I77 with the built-in mill behind it, and a host
// closing a P position loop on X, Y and Z at 1 kHz, as a LinuxCNC servo
// thread would, the spindle turning: one scenario for `lbpkit bench`'s
// "board + mill" row and the BM_MillClosedLoop benchmark, so the figure
// docs/performance.md quotes and the benchmark that guards it run the same code.
#pragma once

#include <array>
#include <cstdint>

#include "lbpkit/encoders.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "machine/machine_file.hpp"
#include "sim_card/sim_transport.hpp"

namespace lbpkit {

class MillClosedLoop {
 public:
  // Both 7I77 channels discovered and started in normal mode, the drives
  // enabled, the Z brake released and the spindle turning.
  explicit MillClosedLoop(machine::MachineDescription mill = machine::mill());

  // One servo period from now: the loop's outputs, one exchange, the inputs
  // and encoders, then the plant up to the period's end (the caller lets
  // the card's time reach it). Targets move back and forth over 40 mm every
  // 2 s, so the axes always work.
  CycleStatus cycle();

  SimTransport& transport() { return card_.t; }
  [[nodiscard]] const machine::Machine& machine() const { return machine_; }

 private:
  static constexpr unsigned kAxes = 3;  // X, Y, Z
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
  machine::Machine machine_;
  std::array<ElementRef, 6> aout_{};
  std::array<double, kAxes> offset_{};  // the encoders' counts at the first cycle
  std::uint64_t cycles_ = 0;
};

}  // namespace lbpkit
