// SPDX-License-Identifier: MIT
#include "virtual_board.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "hostmot2/terminals.hpp"
#include "lbpkit/error.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace remote = lbpkit::model::remote;

namespace pylbpkit {

namespace {
using lbpkit::Error;
using remote::FieldIoProcessor;

constexpr double kMaxVolts = 100.0;  // as the control API allows

void checkVolts(double v, const char* what) {
  if (!std::isfinite(v) || v < 0 || v > kMaxVolts)
    throw std::invalid_argument(fmt::format("{}: {} V is not from 0 to {} V", what, v, kMaxVolts));
}
}  // namespace

// --- VirtualSevenI76 --------------------------------------------------------------------------

VirtualSevenI76::VirtualSevenI76(std::shared_ptr<Card> card) : card_(std::move(card)) {
  auto l = card_->lock();
  (void)io();
}

remote::SevenI76FieldIo& VirtualSevenI76::io() {
  auto* i76 = card_->board().sevenI76();
  if (i76 == nullptr)
    throw Error(fmt::format("this card's firmware ({}) has no 7I76: Card.sim(card=\"7I92T\") or "
                            "pinout=\"7I77+7I76\" has one",
                            card_->board().firmware().name));
  return *i76;
}

void VirtualSevenI76::checkInput(unsigned input) const {
  if (input >= remote::SevenI76FieldIo::kInputs)
    throw std::out_of_range(
        fmt::format("input {}: the 7I76 has inputs 0..{}", input, remote::SevenI76FieldIo::kInputs - 1));
}

void VirtualSevenI76::checkOutput(unsigned output) const {
  if (output >= remote::SevenI76FieldIo::kOutputs)
    throw std::out_of_range(
        fmt::format("output {}: the 7I76 has outputs 0..{}", output, remote::SevenI76FieldIo::kOutputs - 1));
}

unsigned VirtualSevenI76::channel() {
  auto l = card_->lock();
  (void)io();
  return hm2::cards::sevenI76Channel(card_->board().firmware()).value_or(0);
}

void VirtualSevenI76::setInput(unsigned input, bool on) {
  auto l = card_->lock();
  checkInput(input);
  checkVolts(io().fieldVoltage(), "input voltage");
  checkUnwired(input);
  hm2::Terminals(card_->board()).setInput(hm2::FieldIoAt::theSevenI76(), input, on);
}

void VirtualSevenI76::setInputVoltage(unsigned input, double volts) {
  auto l = card_->lock();
  checkInput(input);
  checkVolts(volts, "input voltage");
  checkUnwired(input);
  hm2::Terminals(card_->board()).setInputVoltage(hm2::FieldIoAt::theSevenI76(), input, volts);
}

void VirtualSevenI76::checkUnwired(unsigned input) {
  (void)io();
  // The machine sets its switches' inputs at every plant span (as on the 7I77).
  if (const auto* m = card_->machine())
    for (const auto& s : m->description().switches)
      if (s.daughtercard == machine::Daughtercard::SevenI76 && s.input == input)
        throw Error(fmt::format("7I76 input {} is wired to the machine's switch \"{}\": trip it with "
                                "machine.set_switch(\"{}\", True) instead",
                                input, s.name, s.name));
}

bool VirtualSevenI76::input(unsigned input) {
  auto l = card_->lock();
  checkInput(input);
  return io().input(input);
}
std::uint32_t VirtualSevenI76::inputs() {
  auto l = card_->lock();
  return io().inputs();
}
bool VirtualSevenI76::output(unsigned output) {
  auto l = card_->lock();
  checkOutput(output);
  return io().outputOn(output);
}
std::uint16_t VirtualSevenI76::outputs() {
  auto l = card_->lock();
  return io().outputs();
}
double VirtualSevenI76::outputVoltage(unsigned output) {
  auto l = card_->lock();
  checkOutput(output);
  return io().outputVoltage(output);
}
void VirtualSevenI76::setFieldVoltage(double volts) {
  auto l = card_->lock();
  checkVolts(volts, "field voltage");
  (void)io();
  hm2::Terminals(card_->board()).setFieldVoltage(hm2::FieldIoAt::theSevenI76(), volts);
}
double VirtualSevenI76::fieldVoltage() {
  auto l = card_->lock();
  return io().fieldVoltage();
}
double VirtualSevenI76::spindleVolts() {
  auto l = card_->lock();
  return io().spindleVolts();
}
bool VirtualSevenI76::spindleEnable() {
  auto l = card_->lock();
  return io().spindleEnable();
}
bool VirtualSevenI76::spindleDirection() {
  auto l = card_->lock();
  return io().spindleDirection();
}
std::uint8_t VirtualSevenI76::faults() {
  auto l = card_->lock();
  return io().faults();
}
bool VirtualSevenI76::powered() {
  auto l = card_->lock();
  return io().powered();
}

// --- VirtualBoard ---------------------------------------------------------------------------

VirtualBoard::VirtualBoard(std::shared_ptr<Card> card) : card_(std::move(card)) {
  auto l = card_->lock();
  (void)card_->board();  // says so for a card on the network
}

hm2::SevenI77& VirtualBoard::daughter(unsigned connector) {
  auto& b = card_->board();
  if (connector >= b.daughtercards())
    throw std::out_of_range(fmt::format("connector {}: the virtual 7I92 has a 7I77 on connector{} {}", connector,
                                        b.daughtercards() > 1 ? "s 0 and" : "", b.daughtercards() - 1));
  return b.daughtercard(connector);
}

void VirtualBoard::checkInput(unsigned input) const {
  if (input >= FieldIoProcessor::kInputs)
    throw std::out_of_range(fmt::format("input {}: the 7I77 has field inputs 0..{}", input, FieldIoProcessor::kInputs - 1));
}

void VirtualBoard::checkOutput(unsigned output) const {
  if (output >= FieldIoProcessor::kOutputs)
    throw std::out_of_range(
        fmt::format("output {}: the 7I77 has field outputs 0..{}", output, FieldIoProcessor::kOutputs - 1));
}

unsigned VirtualBoard::daughtercards() {
  auto l = card_->lock();
  return card_->board().daughtercards();
}

void VirtualBoard::setInput(unsigned input, bool on, unsigned connector) {
  auto l = card_->lock();
  checkInputVoltage(input, daughter(connector).fieldIo.fieldVoltage(), connector);
  hm2::Terminals(card_->board()).setInput(hm2::FieldIoAt::sevenI77On(connector), input, on);
}

void VirtualBoard::setInputVoltage(unsigned input, double volts, unsigned connector) {
  auto l = card_->lock();
  checkInputVoltage(input, volts, connector);
  hm2::Terminals(card_->board()).setInputVoltage(hm2::FieldIoAt::sevenI77On(connector), input, volts);
}

void VirtualBoard::checkInputVoltage(unsigned input, double volts, unsigned connector) {
  (void)daughter(connector);
  checkInput(input);
  checkVolts(volts, "input voltage");
  // The machine sets its switches' inputs at every plant span: a value
  // given here would last a span at most.
  if (const auto* m = card_->machine(); m != nullptr && connector == 0)
    for (const auto& s : m->description().switches)
      if (s.input == input)
        throw Error(fmt::format("input {} is wired to the machine's switch \"{}\": trip it with "
                                "machine.set_switch(\"{}\", True) instead",
                                input, s.name, s.name));
}

template <typename Read>
auto VirtualBoard::readFieldIo(unsigned connector, Read&& read) {
  auto l = card_->lock();
  return read(static_cast<const FieldIoProcessor&>(daughter(connector).fieldIo));
}

bool VirtualBoard::input(unsigned i, unsigned connector) {
  checkInput(i);
  return readFieldIo(connector, [i](const FieldIoProcessor& io) { return io.input(i); });
}
double VirtualBoard::inputVoltage(unsigned i, unsigned connector) {
  checkInput(i);
  return readFieldIo(connector, [i](const FieldIoProcessor& io) { return io.inputVoltage(i); });
}
bool VirtualBoard::output(unsigned o, unsigned connector) {
  checkOutput(o);
  return readFieldIo(connector, [o](const FieldIoProcessor& io) { return io.outputOn(o); });
}
double VirtualBoard::outputVoltage(unsigned o, unsigned connector) {
  checkOutput(o);
  return readFieldIo(connector, [o](const FieldIoProcessor& io) { return io.outputVoltage(o); });
}
double VirtualBoard::outputCurrent(unsigned o, unsigned connector) {
  checkOutput(o);
  return readFieldIo(connector, [o](const FieldIoProcessor& io) { return io.outputCurrent(o); });
}
bool VirtualBoard::outputTripped(unsigned o, unsigned connector) {
  checkOutput(o);
  return readFieldIo(connector, [o](const FieldIoProcessor& io) { return io.outputTripped(o); });
}
double VirtualBoard::fieldVoltage(unsigned connector) {
  return readFieldIo(connector, [](const FieldIoProcessor& io) { return io.fieldVoltage(); });
}
std::uint8_t VirtualBoard::fieldIoFaults(unsigned connector) {
  return readFieldIo(connector, [](const FieldIoProcessor& io) { return io.faults(); });
}

void VirtualBoard::setOutputLoad(unsigned output, double ohms, unsigned connector) {
  auto l = card_->lock();
  checkOutput(output);
  if (std::isnan(ohms) || ohms < 0)
    throw std::invalid_argument(fmt::format("output {}: a load of {} ohms (0 is a short, inf an open output)", output, ohms));
  (void)daughter(connector);
  hm2::Terminals(card_->board()).setOutputLoad(hm2::FieldIoAt::sevenI77On(connector), output, ohms);
}

void VirtualBoard::setFieldVoltage(double volts, unsigned connector) {
  auto l = card_->lock();
  checkVolts(volts, "field voltage");
  (void)daughter(connector);
  hm2::Terminals(card_->board()).setFieldVoltage(hm2::FieldIoAt::sevenI77On(connector), volts);
}

void VirtualBoard::setDriverOverTemperature(unsigned chip, bool hot, unsigned connector) {
  auto l = card_->lock();
  if (chip >= FieldIoProcessor::kChips)
    throw std::out_of_range(fmt::format("chip {}: the 7I77 has output driver chips 0..{}", chip, FieldIoProcessor::kChips - 1));
  (void)daughter(connector);
  hm2::Terminals(card_->board()).setDriverOverTemperature(connector, chip, hot);
}

std::uint8_t VirtualBoard::analogFaults(unsigned connector) {
  auto l = card_->lock();
  return daughter(connector).analog.faults();
}

double VirtualBoard::analogOutput(unsigned channel, unsigned connector) {
  auto l = card_->lock();
  if (channel >= remote::AnalogProcessor::kChannels)
    throw std::out_of_range(fmt::format("analog output {}: the 7I77 has 0..5", channel));
  return daughter(connector).analog.outputVoltage(channel);
}

bool VirtualBoard::enable(unsigned channel, unsigned connector) {
  auto l = card_->lock();
  if (channel >= remote::AnalogProcessor::kChannels)
    throw std::out_of_range(fmt::format("ENA{}: the 7I77 has ENA0..5", channel));
  return daughter(connector).analog.enable(channel);
}

bool VirtualBoard::watchdogBitten() {
  auto l = card_->lock();
  return card_->board().part<hm2::Watchdog>().bitten();
}

void VirtualBoard::setCable(unsigned channel, bool connected) {
  auto l = card_->lock();
  const unsigned channels = card_->board().part<hm2::Sslbp>().channels();
  if (channel >= channels)
    throw std::out_of_range(fmt::format("channel {}: the card has smart-serial channels 0..{}", channel, channels - 1));
  hm2::Terminals(card_->board()).setCable(channel, connected);
}

void VirtualBoard::checkEncoder(unsigned encoder) {
  const unsigned n = card_->board().part<hm2::MuxedEncoder>().counters();
  if (encoder >= n) throw std::out_of_range(fmt::format("encoder {}: the card has encoders 0..{}", encoder, n - 1));
}

void VirtualBoard::setEncoder(unsigned encoder, std::optional<double> countsPerSecond,
                              std::optional<std::uint32_t> countsPerRev) {
  auto l = card_->lock();
  checkEncoder(encoder);
  if (const auto* m = card_->machine(); m != nullptr) {
    for (const auto& a : m->description().axes)
      for (const auto& d : a.drives)
        if (d.encoderInput == encoder)
          throw Error(fmt::format("encoder {} is the machine's axis {}: it turns with the axis", encoder, a.name));
    if (m->description().spindle && m->description().spindle->encoderInput == encoder)
      throw Error(fmt::format("encoder {} is the machine's spindle encoder", encoder));
  }
  if (countsPerSecond && (!std::isfinite(*countsPerSecond) || std::abs(*countsPerSecond) > 1e8))
    throw std::invalid_argument(fmt::format("encoder {}: {} counts per second", encoder, *countsPerSecond));
  hm2::Terminals(card_->board()).setEncoder(encoder, countsPerSecond, countsPerRev);
}

std::uint16_t VirtualBoard::encoderCount(unsigned encoder) {
  auto l = card_->lock();
  checkEncoder(encoder);
  return card_->board().part<hm2::MuxedEncoder>().count(encoder);
}

// --- VirtualMachine -----------------------------------------------------------------------------

VirtualMachine::VirtualMachine(std::shared_ptr<Card> card) : card_(std::move(card)) {
  auto l = card_->lock();
  (void)m();
}

machine::Machine& VirtualMachine::m() {
  auto* m = card_->machine();
  if (m == nullptr)
    throw Error("this card has no machine: open it with lbpkit.Card.sim(machine=\"mill\") (or lathe, gantry, a file)");
  return *m;
}

std::size_t VirtualMachine::axis(const std::string& name) {
  if (const auto i = m().axisIndex(name)) return *i;
  std::string have;
  for (std::size_t i = 0; i < m().axes(); ++i) have += (i ? ", " : "") + m().description().axes[i].name;
  throw Error(fmt::format("this machine has no axis \"{}\" (it has {})", name, have));
}

std::string VirtualMachine::name() {
  auto l = card_->lock();
  return m().description().name;
}

std::vector<std::string> VirtualMachine::axes() {
  auto l = card_->lock();
  std::vector<std::string> out;
  for (const auto& a : m().description().axes) out.push_back(a.name);
  return out;
}

// A servo axis' mechanics or a stepper's motor (Machine::position; a
// stepper axis' Axis holds only its faults).
double VirtualMachine::position(const std::string& name) {
  auto l = card_->lock();
  return m().position(axis(name));
}

double VirtualMachine::velocity(const std::string& name) {
  auto l = card_->lock();
  return m().state().axes.at(axis(name)).velocity;
}

double VirtualMachine::followingError(const std::string& name) {
  auto l = card_->lock();
  return m().followingError(axis(name));
}

bool VirtualMachine::brakeEngaged(const std::string& name) {
  auto l = card_->lock();
  const auto i = axis(name);
  return m().state().axes.at(i).brakeEngaged;
}

std::optional<double> VirtualMachine::spindleRpm() {
  auto l = card_->lock();
  if (const auto* s = m().spindle()) return s->rpm();
  return std::nullopt;
}

machine::Machine::State VirtualMachine::state() {
  auto l = card_->lock();
  return m().state();
}

std::optional<machine::Machine::State::Stepper> VirtualMachine::stepper(const std::string& name) {
  auto l = card_->lock();
  const auto a = axis(name);
  return m().state().axes.at(a).stepper;
}

void VirtualMachine::setSwitch(const std::string& name, bool tripped) {
  auto l = card_->lock();
  if (!m().setSwitch(name, tripped)) {
    std::string have;
    for (const auto& s : m().description().switches) have += (have.empty() ? "" : ", ") + s.name;
    throw Error(fmt::format("this machine has no switch \"{}\" (it has {})", name, have));
  }
}

void VirtualMachine::estop(bool pressed) {
  auto l = card_->lock();
  if (m().setSwitches(machine::SwitchKind::Estop, pressed) == 0) throw Error("this machine has no E-stop switch");
}

void VirtualMachine::probe(bool touching) {
  auto l = card_->lock();
  if (m().setSwitches(machine::SwitchKind::Probe, touching) == 0) throw Error("this machine has no probe");
}

void VirtualMachine::push(const std::string& name, double distance, double speed) {
  auto l = card_->lock();
  if (!std::isfinite(distance) || std::abs(distance) > 1e6)
    throw std::invalid_argument(fmt::format("push: distance {} is not from -1e6 to 1e6 machine units", distance));
  if (!std::isfinite(speed) || speed <= 0 || speed > 1e5)
    throw std::invalid_argument(fmt::format("push: speed {} is not above 0 and at most 1e5 units/s", speed));
  m().push(axis(name), distance, speed);
}

void VirtualMachine::jam(const std::string& name, bool jammed) {
  auto l = card_->lock();
  m().setJammed(axis(name), jammed);
}

void VirtualMachine::breakEncoder(const std::string& name, const std::string& channel, bool broken, unsigned drive) {
  auto l = card_->lock();
  machine::EncoderChannel c{};
  if (channel == "A" || channel == "a")
    c = machine::EncoderChannel::A;
  else if (channel == "B" || channel == "b")
    c = machine::EncoderChannel::B;
  else if (channel == "index")
    c = machine::EncoderChannel::Index;
  else
    throw std::invalid_argument(fmt::format("encoder channel \"{}\": \"A\", \"B\" or \"index\"", channel));
  if (name == "spindle") {
    if (!m().setSpindleEncoderBroken(c, broken))
      throw Error(m().spindle() ? "this machine's spindle has no encoder" : "this machine has no spindle");
    return;
  }
  const auto a = axis(name);
  if (m().stepper(a) != nullptr) throw Error(fmt::format("axis {} is a stepper axis: it has no encoder", name));
  if (drive >= m().drives(a))
    throw std::out_of_range(fmt::format("axis {} has drives 0..{}", name, m().drives(a) - 1));
  m().setEncoderBroken(a, drive, c, broken);
}

}  // namespace pylbpkit
