// SPDX-License-Identifier: MIT
// What `card.board` and `card.machine` are to Python: the in-process
// virtual 7I92 + 7I77 seen from the outside world (the terminals a user
// wires and measures, the faults a user provokes), and the machine behind
// its terminals. Both are views of a Card (they keep it alive) and take its
// lock; neither reads a clock: time passes only through cycle() and step().
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "card.hpp"

namespace pylbpkit {

class VirtualBoard {
 public:
  // Throws lbpkit::Error for a card on the network.
  explicit VirtualBoard(std::shared_ptr<Card> card);
  [[nodiscard]] const std::shared_ptr<Card>& card() const { return card_; }

  [[nodiscard]] unsigned daughtercards();

  // --- Field I/O (manual: FIELD I/O): TB6..TB8 of the 7I77 on `connector` --------
  // An input switched to field power (on) or to field ground (off), or any voltage.
  void setInput(unsigned input, bool on, unsigned connector);
  void setInputVoltage(unsigned input, double volts, unsigned connector);
  // What the field I/O processor reads (thresholds and hysteresis applied).
  [[nodiscard]] bool input(unsigned input, unsigned connector);
  [[nodiscard]] double inputVoltage(unsigned input, unsigned connector);
  [[nodiscard]] bool output(unsigned output, unsigned connector);
  [[nodiscard]] double outputVoltage(unsigned output, unsigned connector);
  [[nodiscard]] double outputCurrent(unsigned output, unsigned connector);
  [[nodiscard]] bool outputTripped(unsigned output, unsigned connector);
  // A resistive load on an output (infinity: open; 0: a dead short).
  void setOutputLoad(unsigned output, double ohms, unsigned connector);
  void setFieldVoltage(double volts, unsigned connector);
  [[nodiscard]] double fieldVoltage(unsigned connector);
  void setDriverOverTemperature(unsigned chip, bool hot, unsigned connector);
  // The processors' fault bytes (manual: FAULT; bit names lbpkit.FAULT_NAMES).
  [[nodiscard]] std::uint8_t fieldIoFaults(unsigned connector);
  [[nodiscard]] std::uint8_t analogFaults(unsigned connector);

  // --- Analog (manual: ANALOG SERVO DRIVE INTERFACE): TB5 ----------------------------
  [[nodiscard]] double analogOutput(unsigned channel, unsigned connector);
  [[nodiscard]] bool enable(unsigned channel, unsigned connector);  // ENA0..5

  // --- The 7I92 --------------------------------------------------------------------------
  [[nodiscard]] bool watchdogBitten();
  // The RS-422 cable of a smart-serial channel plugged in or pulled.
  void setCable(unsigned channel, bool connected);
  // An encoder input turning at `countsPerSecond`, with an index every
  // `countsPerRev` counts (0: none). Not on the inputs a machine drives.
  void setEncoder(unsigned encoder, std::optional<double> countsPerSecond, std::optional<std::uint32_t> countsPerRev);
  [[nodiscard]] std::uint16_t encoderCount(unsigned encoder);  // the card's 16-bit count register

 private:
  lbpkit::model::hm2::SevenI77& daughter(unsigned connector);
  // An input that may be set to `volts`: on a 7I77 there, in range, not a
  // machine's switch (the lock held).
  void checkInputVoltage(unsigned input, double volts, unsigned connector);
  // `read` of the field I/O processor on `connector`, under the card's lock.
  template <typename Read>
  auto readFieldIo(unsigned connector, Read&& read);
  void checkInput(unsigned input) const;
  void checkOutput(unsigned output) const;
  void checkEncoder(unsigned encoder);
  std::shared_ptr<Card> card_;
};

// The 7I76 beside the 7I77 on the 7I77+7I76 firmwares (Card.sim(card="7I92T")):
// its field I/O processor on its SSerial channel, from the outside: 32
// inputs, 16 sourcing outputs, field power and the spindle interface
// (SpinOut volts, SpinEna, SpinDir; docs/cards.md#the-7i76-field-io).
class VirtualSevenI76 {
 public:
  // Throws lbpkit::Error when the card's firmware has no 7I76.
  explicit VirtualSevenI76(std::shared_ptr<Card> card);

  [[nodiscard]] unsigned channel();  // its SSerial channel (3)
  void setInput(unsigned input, bool on);
  void setInputVoltage(unsigned input, double volts);
  [[nodiscard]] bool input(unsigned input);
  [[nodiscard]] std::uint32_t inputs();
  [[nodiscard]] bool output(unsigned output);
  [[nodiscard]] std::uint16_t outputs();
  [[nodiscard]] double outputVoltage(unsigned output);
  void setFieldVoltage(double volts);
  [[nodiscard]] double fieldVoltage();
  [[nodiscard]] double spindleVolts();
  [[nodiscard]] bool spindleEnable();
  [[nodiscard]] bool spindleDirection();
  [[nodiscard]] std::uint8_t faults();
  [[nodiscard]] bool powered();

 private:
  lbpkit::model::remote::SevenI76FieldIo& io();  // the lock held
  // A 7I76 there and `input` not a machine's switch (the lock held).
  void checkUnwired(unsigned input);
  void checkInput(unsigned input) const;
  void checkOutput(unsigned output) const;
  std::shared_ptr<Card> card_;
};

class VirtualMachine {
 public:
  // Throws lbpkit::Error when the card has no machine.
  explicit VirtualMachine(std::shared_ptr<Card> card);

  [[nodiscard]] std::string name();
  [[nodiscard]] std::vector<std::string> axes();
  [[nodiscard]] double position(const std::string& axis);  // machine units (mm)
  [[nodiscard]] double velocity(const std::string& axis);
  [[nodiscard]] double followingError(const std::string& axis);
  [[nodiscard]] bool brakeEngaged(const std::string& axis);
  [[nodiscard]] std::optional<double> spindleRpm();
  [[nodiscard]] lbpkit::model::machine::Machine::State state();
  // A stepper axis' StepGen steps, lost steps and stall (None for a servo axis).
  [[nodiscard]] std::optional<lbpkit::model::machine::Machine::State::Stepper> stepper(const std::string& axis);

  // Faults and the operator (the daemon's POST /api/machine actions).
  void setSwitch(const std::string& name, bool tripped);
  void estop(bool pressed);
  void probe(bool touching);
  void push(const std::string& axis, double distance, double speed);
  void jam(const std::string& axis, bool jammed);
  // "A", "B" or "index" of drive `drive`'s encoder on `axis` ("spindle": its encoder).
  void breakEncoder(const std::string& axis, const std::string& channel, bool broken, unsigned drive);

 private:
  lbpkit::model::machine::Machine& m();
  std::size_t axis(const std::string& name);
  std::shared_ptr<Card> card_;
};

}  // namespace pylbpkit
