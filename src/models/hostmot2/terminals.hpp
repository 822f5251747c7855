// SPDX-License-Identifier: MIT
// The virtual card's terminals as a person at the bench reaches them: a
// 7I77's field inputs, outputs, field power and VIN (7I77 manual: FIELD I/O,
// VIN AND FIELD POWER SUPPLY), its output drivers' overtemperature, the 7I76's
// field I/O on the firmwares that carry one, an encoder turning, a smart-serial
// cable plugged or pulled. Each action is written here once for whatever asks
// for it (the sim's control API, Python's VirtualBoard); the callers check and
// translate their own arguments first, in their own words, so the indexes
// given here are in range.
#pragma once

#include <cstdint>
#include <optional>

#include "hostmot2/card.hpp"

namespace lbpkit::model::hm2 {

// Whose field I/O: the 7I77 on a connector, or the card's 7I76.
struct FieldIoAt {
  bool sevenI76 = false;
  unsigned connector = 0;  // the 7I77's
  static FieldIoAt sevenI77On(unsigned connector) { return {false, connector}; }
  static FieldIoAt theSevenI76() { return {true, 0}; }
};

class Terminals {
 public:
  explicit Terminals(HostMot2Card& card) : card_(card) {}

  // A field input switched to field power (on) or left open; a voltage on it.
  void setInput(FieldIoAt at, unsigned input, bool on);
  void setInputVoltage(FieldIoAt at, unsigned input, double volts);
  // Field power (the 7I76 runs its processor from it too) and a 7I77's VIN.
  void setFieldVoltage(FieldIoAt at, double volts);
  void setVin(unsigned connector, double volts);
  // The load on a field output: 0 is a short, infinity an open output.
  void setOutputLoad(FieldIoAt at, unsigned output, double ohms);
  // A 7I77 output driver chip hot (its outputs trip: manual, SHORT CIRCUIT /
  // OVER-TEMPERATURE PROTECTION).
  void setDriverOverTemperature(unsigned connector, unsigned chip, bool hot);
  // Muxed encoder `encoder` turning at countsPerSecond, with an index every
  // countsPerRev counts (0: none); what is not given is left as it is.
  void setEncoder(unsigned encoder, std::optional<double> countsPerSecond, std::optional<std::uint32_t> countsPerRev);
  // The smart-serial cable of `channel` plugged in or pulled.
  void setCable(unsigned channel, bool connected);

 private:
  template <typename Action>
  void onFieldIo(FieldIoAt at, Action&& action);
  HostMot2Card& card_;
};

}  // namespace lbpkit::model::hm2
