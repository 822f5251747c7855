// SPDX-License-Identifier: MIT
// The bench's actions on the virtual card's terminals (terminals.hpp), one
// model call each, for the control API and Python alike.
#include "hostmot2/terminals.hpp"

#include "hostmot2/muxed_encoder.hpp"
#include "hostmot2/sslbp.hpp"
#include "remote/seven_i76.hpp"

namespace lbpkit::model::hm2 {

template <typename Action>
void Terminals::onFieldIo(FieldIoAt at, Action&& action) {
  if (at.sevenI76)
    action(*card_.sevenI76());
  else
    action(card_.daughtercard(at.connector).fieldIo);
}

void Terminals::setInput(FieldIoAt at, unsigned input, bool on) {
  onFieldIo(at, [&](auto& io) { io.setInputVoltage(input, on ? io.fieldVoltage() : 0.0); });
}

void Terminals::setInputVoltage(FieldIoAt at, unsigned input, double volts) {
  onFieldIo(at, [&](auto& io) { io.setInputVoltage(input, volts); });
}

void Terminals::setFieldVoltage(FieldIoAt at, double volts) {
  onFieldIo(at, [&](auto& io) { io.setFieldVoltage(volts, card_.now()); });
}

void Terminals::setVin(unsigned connector, double volts) {
  card_.daughtercard(connector).fieldIo.setVin(volts, card_.now());
}

void Terminals::setOutputLoad(FieldIoAt at, unsigned output, double ohms) {
  onFieldIo(at, [&](auto& io) { io.setOutputLoad(output, ohms); });
}

void Terminals::setDriverOverTemperature(unsigned connector, unsigned chip, bool hot) {
  card_.daughtercard(connector).fieldIo.setDriverOverTemperature(chip, hot);
}

void Terminals::setEncoder(unsigned encoder, std::optional<double> countsPerSecond,
                           std::optional<std::uint32_t> countsPerRev) {
  auto& enc = card_.part<MuxedEncoder>();
  if (countsPerRev) enc.setIndexPeriod(encoder, *countsPerRev);
  if (countsPerSecond) enc.setVelocity(encoder, *countsPerSecond, card_.now());
}

void Terminals::setCable(unsigned channel, bool connected) {
  card_.part<Sslbp>().link(channel).setConnected(connected);
}

}  // namespace lbpkit::model::hm2
