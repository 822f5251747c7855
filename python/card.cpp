// SPDX-License-Identifier: MIT
#include "card.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "config/machine_toml.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/parameters.hpp"
#include "lbpkit/servo_cycle.hpp"
#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/names.hpp"
#include "lbpkit/wire/process_data.hpp"
#include "remote/nv_store.hpp"
#include "remote/remote_device.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace remote = lbpkit::model::remote;
namespace config = lbpkit::config;

namespace pylbpkit {

namespace {

using lbpkit::DataType;
using lbpkit::Error;
using lbpkit::Nanoseconds;
using lbpkit::ProcessDataElement;

Nanoseconds fromSeconds(double s, const char* what) {
  if (!std::isfinite(s) || s < 0 || s > 1e6)
    throw std::invalid_argument(fmt::format("{}: {} is not a time from 0 to 1e6 seconds", what, s));
  return Nanoseconds{static_cast<std::int64_t>(std::llround(s * 1e9))};
}

// Scaled in its unit: a numeric element with a range (NUMERIC PROCESS DATA
// SCALING) other than its raw one (WatchDogTime: 0..65535 in 16 bits is the
// raw number); the others are raw integers.
bool scaled(const ProcessDataElement& e) {
  if (!e.numeric() || e.min == e.max) return false;
  const unsigned n = e.width();
  const double top =
      e.isSigned() ? std::ldexp(1.0, static_cast<int>(n) - 1) - 1 : std::ldexp(1.0, static_cast<int>(n)) - 1;
  const bool raw = (e.isSigned() || e.min == 0) && std::abs(static_cast<double>(e.max) - top) <= 1e-6 * top;
  return !raw;
}

Value toValue(const ProcessDataElement& e, std::uint64_t raw) {
  if (e.type == DataType::Boolean) return raw != 0;
  if (scaled(e)) return e.scale(raw);
  if (e.isSigned()) return e.fromRaw(raw);
  return raw;
}

std::uint64_t toRaw(const ProcessDataElement& e, const Input& value) {
  if (e.type == DataType::Boolean) {
    if (const auto* d = std::get_if<double>(&value)) return *d != 0.0;
    if (const auto* i = std::get_if<std::int64_t>(&value)) return *i != 0;
    return std::get<bool>(value);
  }
  if (scaled(e)) {
    const double v = std::holds_alternative<double>(value) ? std::get<double>(value)
                     : std::holds_alternative<bool>(value) ? static_cast<double>(std::get<bool>(value))
                                                            : static_cast<double>(std::get<std::int64_t>(value));
    if (!std::isfinite(v)) throw std::invalid_argument(fmt::format("{}: {} is not a number", e.name, v));
    return e.unscale(v);  // clamped to min..max, as the remote would
  }
  std::int64_t v = 0;
  if (const auto* d = std::get_if<double>(&value)) {
    if (!std::isfinite(*d) || *d != std::floor(*d))
      throw std::invalid_argument(fmt::format("{} is a {} element: give a whole number, not {}", e.name,
                                              lbpkit::typeName(e.type), *d));
    v = static_cast<std::int64_t>(*d);
  } else if (const auto* i = std::get_if<std::int64_t>(&value)) {
    v = *i;
  } else {
    v = std::get<bool>(value) ? 1 : 0;
  }
  if (!e.fits(v)) {
    if (e.isSigned())
      throw std::invalid_argument(fmt::format("{}: {} does not fit its {} signed bits ({} .. {})", e.name, v, e.width(),
                                              e.lowest(), e.highest()));
    throw std::invalid_argument(
        fmt::format("{}: {} does not fit its {} bits (0 .. {})", e.name, v, e.width(), e.highest()));
  }
  return e.toRaw(v);
}

// "channel 0 (Input Output), channel 1 (AnalogOut0 ...)": what there is.
std::string listNames(const lbpkit::SmartSerial& ss, bool parameters) {
  std::string out;
  for (unsigned s = 0; s < ss.slots(); ++s) {
    const auto& d = ss.description(s);
    out += fmt::format("{}channel {}:", out.empty() ? "" : "; ", ss.slotIdentity(s).channel);
    for (const auto& e : d.processData) out += " " + e.name;
    if (parameters)
      for (const auto& e : d.parameters) out += " " + e.name;
  }
  return out.empty() ? "no remotes" : out;
}

}  // namespace

std::shared_ptr<Card> Card::openNetwork(const std::string& address, std::uint16_t port, double timeout) {
  std::shared_ptr<Card> c(new Card());
  auto t = std::make_unique<lbpkit::Lbp16Transport>(address, port, fromSeconds(timeout, "timeout"));
  if (t->boardName().empty()) throw Error(fmt::format("{} answers but gives no board name", t->describe()));
  c->transport_ = std::move(t);
  c->info_ = lbpkit::readCardInfo(*c->transport_);
  return c;
}

std::shared_ptr<Card> Card::openSim(const SimOptions& o) {
  if (o.daughtercards < 1 || o.daughtercards > 2)
    throw std::invalid_argument(fmt::format("daughtercards: {} 7I77s; the virtual 7I92 takes 1 or 2", o.daughtercards));
  if (!std::isfinite(o.fieldVoltage) || o.fieldVoltage < 0 || o.fieldVoltage > 100)
    throw std::invalid_argument(fmt::format("field_voltage: {} V is not from 0 to 100", o.fieldVoltage));
  // The machine file first: its mistakes are the likelier ones.
  std::optional<machine::MachineDescription> description;
  if (!o.machine.empty()) description = config::loadMachine(o.machine);
  hm2::HostMot2Card::Options card;
  if (!o.card.empty()) {
    card.card = hm2::cards::find(o.card);
    if (card.card == nullptr)
      throw std::invalid_argument(fmt::format("card: \"{}\" is not one lbpkit models ({})", o.card, hm2::cards::names()));
  }
  if (!o.pinout.empty()) {
    const auto& which = card.card != nullptr ? *card.card : hm2::cards::defaultCard();
    const auto* firmware = hm2::cards::firmware(which, o.pinout);
    if (firmware == nullptr)
      throw std::invalid_argument(fmt::format("pinout: the {} has no firmware \"{}\" (it has {})", which.name,
                                              o.pinout, hm2::cards::firmwareNames(which)));
    card.pinout = firmware->pinout;
  }
  auto daughter = [&](hm2::HostMot2Card::DaughterOptions& d) {
    if (o.sinking) d.fieldIo.outputs = remote::OutputType::Sinking;
    d.fieldIo.fieldVoltage = o.fieldVoltage;
  };
  daughter(card.first);
  if (!o.state.empty()) {
    // A file the card will not use (a symbolic link, not an EEPROM image,
    // held by another sim) is refused now, as lbpkit sim refuses it, not
    // found out at the first non-volatile write.
    remote::NvStore probe(remote::memory::kEepromSize, o.state);
    probe.load();
    if (!probe.refusal().empty()) throw lbpkit::Error(probe.refusal());
    card.first.fieldIo.nvFile = o.state;
  }
  if (o.daughtercards == 2) {
    card.second.emplace();
    daughter(*card.second);
  }
  std::shared_ptr<Card> c(new Card());
  auto sim = std::make_unique<lbpkit::SimTransport>(std::move(card));
  c->sim_ = sim.get();
  c->transport_ = std::move(sim);
  c->info_ = lbpkit::readCardInfo(*c->transport_);
  if (description) c->machine_ = std::make_unique<machine::Machine>(std::move(*description), c->sim_->card(),
                                                                    c->sim_->now(), 0);
  return c;
}

std::uint32_t Card::read32(std::uint16_t address) {
  const auto v = transport_->read32(address);
  catchUpMachine();
  return v;
}

void Card::write32(std::uint16_t address, std::uint32_t value) {
  // The machine first sees the terminals as they were up to now.
  catchUpMachine();
  transport_->write32(address, value);
}

std::unique_lock<std::mutex> Card::lock() {
  std::unique_lock<std::mutex> l(mutex_, std::try_to_lock);
  if (!l.owns_lock())
    throw Error("this card is busy on another thread (run() holds it): the host library is not thread-safe, "
                "use one card from one thread at a time");
  return l;
}

std::string Card::describe() const {
  return fmt::format("{} ({})", info_.boardName, transport_->describe());
}

double Card::time() { return std::chrono::duration<double>(transport_->now()).count(); }

std::vector<lbpkit::ChannelIdentity> Card::discover(const std::vector<unsigned>& channels, const std::string& modes) {
  const unsigned available = info_.sserialChannels();
  if (available == 0) throw Error(fmt::format("{} has no smart-serial channels", describe()));
  lbpkit::SmartSerial::Options o;
  o.channelMask = 0;
  if (channels.empty()) o.channelMask = static_cast<std::uint8_t>((1U << available) - 1);
  for (const unsigned ch : channels) {
    if (ch >= available)
      throw std::invalid_argument(fmt::format("channel {}: this card has smart-serial channels 0..{}", ch, available - 1));
    o.channelMask = static_cast<std::uint8_t>(o.channelMask | (1U << ch));
  }
  if (modes.size() > available)
    throw std::invalid_argument(fmt::format("modes \"{}\": this card has {} channels", modes, available));
  for (std::size_t ch = 0; ch < modes.size(); ++ch) {
    const char m = modes[ch];
    if (m == 'x' || m == 'X') {
      o.channelMask = static_cast<std::uint8_t>(o.channelMask & ~(1U << ch));
    } else if (m >= '0' && m <= '9') {
      o.modes[ch] = static_cast<std::uint8_t>(m - '0');
    } else {
      throw std::invalid_argument(fmt::format("modes \"{}\": '{}' is neither a mode digit nor x", modes, m));
    }
  }
  catchUpMachine();
  mode_ = Mode::Idle;
  byName_.clear();
  enc_.reset();
  ss_ = std::make_unique<lbpkit::SmartSerial>(*transport_, info_, o);
  serialOptions_ = o;
  auto found = ss_->discover(o.channelMask);
  mode_ = Mode::Setup;
  return found;
}

std::vector<unsigned> Card::channels() const {
  std::vector<unsigned> out;
  if (ss_)
    for (unsigned s = 0; s < ss_->slots(); ++s) out.push_back(ss_->slotIdentity(s).channel);
  return out;
}

unsigned Card::slotOf(unsigned channel) const {
  if (ss_)
    for (unsigned s = 0; s < ss_->slots(); ++s)
      if (ss_->slotIdentity(s).channel == channel) return s;
  std::string have;
  for (const unsigned ch : channels()) have += fmt::format(" {}", ch);
  throw Error(fmt::format("no remote was discovered on channel {} (discovered:{})", channel,
                          have.empty() ? " none; call discover()" : have));
}

const lbpkit::RemoteDescription& Card::description(unsigned channel) const { return ss_->description(slotOf(channel)); }
const lbpkit::ChannelIdentity& Card::identity(unsigned channel) const { return ss_->slotIdentity(slotOf(channel)); }

void Card::start() {
  if (mode_ == Mode::Idle) discover({}, "");
  catchUpMachine();
  ss_->startNormal();
  byName_.clear();
  for (unsigned s = 0; s < ss_->slots(); ++s) {
    const auto channel = ss_->slotIdentity(s).channel;
    for (const auto& e : ss_->description(s).processData) {
      const auto ref = ss_->find(channel, e.name);
      if (ref.valid()) byName_[lbpkit::wire::asciiLower(e.name)].push_back(ref);
    }
  }
  if (!enc_ && info_.module(lbpkit::wire::hm2::tag::kMuxedQCount) != nullptr) {
    enc_ = std::make_unique<lbpkit::MuxedEncoders>(*transport_, info_);
    enc_->initialize();
  }
  mode_ = Mode::Normal;
}

void Card::requireRunning(const char* what) const {
  if (mode_ != Mode::Normal)
    throw Error(fmt::format("{}: the remotes are not running: call start() first", what));
}

void Card::requireSim(const char* what) const {
  if (sim_ == nullptr)
    throw Error(fmt::format("{}: only the in-process virtual card has that; this card is {}", what, describe()));
}

lbpkit::ElementRef Card::element(const std::string& name, std::optional<unsigned> channel) const {
  requireRunning("process data");
  const auto it = byName_.find(lbpkit::wire::asciiLower(name));
  if (it == byName_.end())
    throw Error(fmt::format("no process data element \"{}\" (there are: {})", name, listNames(*ss_, false)));
  const auto& refs = it->second;
  if (channel) {
    for (const auto& r : refs)
      if (ss_->slotIdentity(r.slot).channel == *channel) return r;
    throw Error(fmt::format("channel {} has no process data element \"{}\" (there are: {})", *channel, name,
                            listNames(*ss_, false)));
  }
  if (refs.size() > 1) {
    std::string where;
    for (const auto& r : refs) where += fmt::format(" {}", ss_->slotIdentity(r.slot).channel);
    throw Error(fmt::format("\"{}\" is on channels{}: say which with channel=", name, where));
  }
  return refs.front();
}

const ProcessDataElement& Card::processData(lbpkit::ElementRef e) const {
  return ss_->description(e.slot).processData.at(e.element);
}

void Card::set(const std::string& name, const Input& value, std::optional<unsigned> channel) {
  const auto ref = element(name, channel);
  const auto& e = processData(ref);
  if (!e.toRemote())
    throw Error(fmt::format("{} is an input (the remote sends it): it cannot be set", e.name));
  ss_->setRaw(ref, toRaw(e, value));
}

void Card::setBit(const std::string& name, unsigned bit, bool on, std::optional<unsigned> channel) {
  const auto ref = element(name, channel);
  const auto& e = processData(ref);
  if (!e.toRemote()) throw Error(fmt::format("{} is an input (the remote sends it): it cannot be set", e.name));
  if (bit >= e.bits) throw std::out_of_range(fmt::format("{} has bits 0..{}, not {}", e.name, e.bits - 1, bit));
  ss_->setBit(ref, bit, on);
}

Value Card::get(const std::string& name, std::optional<unsigned> channel) const {
  const auto ref = element(name, channel);
  return toValue(processData(ref), ss_->raw(ref));
}

bool Card::bit(const std::string& name, unsigned bit, std::optional<unsigned> channel) const {
  const auto ref = element(name, channel);
  const auto& e = processData(ref);
  if (bit >= e.bits) throw std::out_of_range(fmt::format("{} has bits 0..{}, not {}", e.name, e.bits - 1, bit));
  return ss_->bit(ref, bit);
}

lbpkit::CycleStatus Card::cycle() { return cycleLocked(); }

lbpkit::CycleStatus Card::cycleLocked() {
  requireRunning("cycle()");
  catchUpMachine();
  const Nanoseconds start = transport_->now();
  const auto status = lbpkit::servoCycle(*transport_, *ss_, enc_.get());
  advanceTo(start + period_);
  return status;
}

double Card::period() const { return std::chrono::duration<double>(period_).count(); }

void Card::setPeriod(double seconds) {
  const auto p = fromSeconds(seconds, "period");
  if (p > std::chrono::seconds(10)) throw std::invalid_argument("period: at most 10 s");
  period_ = p;
}

void Card::catchUpMachine() {
  if (machine_) machine_->advance(transport_->now());
}

void Card::advanceTo(Nanoseconds until) {
  catchUpMachine();
  const Nanoseconds now = transport_->now();
  if (until <= now) return;
  if (!sim_) {
    transport_->sleep(until - now);
    return;
  }
  if (!machine_) {
    sim_->sleep(until - now);
    return;
  }
  const Nanoseconds step = machine_->description().step;
  for (Nanoseconds t = now; t < until;) {
    const Nanoseconds next = std::min(t + step, until);
    machine_->advance(next);
    sim_->sleep(next - t);
    t = next;
  }
}

void Card::step(double seconds) {
  requireSim("step()");
  advanceTo(transport_->now() + fromSeconds(seconds, "step"));
}

void Card::powerCycle() {
  requireSim("power_cycle()");
  catchUpMachine();
  sim_->card().powerCycle(sim_->now());
  // Everything the host knew is gone with the card's state.
  mode_ = Mode::Idle;
  byName_.clear();
  enc_.reset();
  ss_.reset();
}

hm2::HostMot2Card& Card::board() {
  requireSim("board");
  return sim_->card();
}

// slotOf() throws when nothing was discovered, so ss_ is there after it.
std::uint32_t Card::cs(unsigned channel) const {
  const unsigned slot = slotOf(channel);
  return ss_->cs(slot);
}
std::uint8_t Card::remoteFaults(unsigned channel) const {
  const unsigned slot = slotOf(channel);
  return ss_->remoteFaults(slot);
}
std::uint32_t Card::faultCount(unsigned channel) const {
  const unsigned slot = slotOf(channel);
  return ss_->faultCount(slot);
}
bool Card::recover(unsigned channel) {
  requireRunning("recover()");
  return ss_->recover(slotOf(channel));
}

// --- Parameters ------------------------------------------------------------------------

std::pair<unsigned, const ProcessDataElement*> Card::parameter(const std::string& name,
                                                                std::optional<unsigned> channel) const {
  if (!ss_ || ss_->slots() == 0) throw Error("no remotes discovered: call discover() or start() first");
  std::vector<std::pair<unsigned, const ProcessDataElement*>> found;
  for (unsigned s = 0; s < ss_->slots(); ++s) {
    const unsigned ch = ss_->slotIdentity(s).channel;
    if (channel && ch != *channel) continue;
    if (const auto* e = ss_->description(s).find(name)) found.emplace_back(ch, e);
  }
  if (found.empty()) {
    if (channel) (void)slotOf(*channel);  // says so when nothing is on that channel
    throw Error(fmt::format("{}no parameter \"{}\" (there are: {})",
                            channel ? fmt::format("channel {} has ", *channel) : std::string(), name,
                            listNames(*ss_, true)));
  }
  if (found.size() > 1) {
    std::string where;
    for (const auto& f : found) where += fmt::format(" {}", f.first);
    throw Error(fmt::format("\"{}\" is a parameter of channels{}: say which with channel=", name, where));
  }
  return found.front();
}

template <typename Work>
auto Card::withRemote(unsigned channel, Work&& work) {
  catchUpMachine();
  if (mode_ == Mode::Setup) {
    auto access = ss_->remote(channel);
    return work(*access);
  }
  // Running: STOP ALL and a setup START of this channel, as RPD/WPD need
  // (manual: SETUP MODE OPERATION), then the normal START again with the
  // outputs as they were (startNormal() clears them).
  std::vector<std::pair<lbpkit::ElementRef, std::uint64_t>> outputs;
  for (const auto& [name, refs] : byName_)
    for (const auto& r : refs)
      if (processData(r).toRemote()) outputs.emplace_back(r, ss_->raw(r));
  auto restart = [&] {
    ss_->startNormal();
    for (const auto& [ref, raw] : outputs) ss_->setRaw(ref, raw);
  };
  ss_->stopAll();
  if (ss_->start(static_cast<std::uint8_t>(1U << channel), true) != 0) {
    restart();
    throw Error(fmt::format("channel {}: the remote did not start in setup mode", channel));
  }
  try {
    auto access = ss_->remote(channel);
    auto result = work(*access);
    restart();
    return result;
  } catch (...) {
    restart();
    throw;
  }
}

Value Card::readParameter(const std::string& name, std::optional<unsigned> channel) {
  // Not a structured binding: clang 14 cannot capture one in the lambda.
  const auto found = parameter(name, channel);
  const unsigned ch = found.first;
  const ProcessDataElement* e = found.second;
  const std::uint64_t raw = withRemote(ch, [&](lbpkit::RemoteAccess& r) { return lbpkit::readElement(r, *e); });
  return toValue(*e, raw);
}

void Card::writeParameter(const std::string& name, const Input& value, std::optional<unsigned> channel) {
  // Not a structured binding: clang 14 cannot capture one in the lambda.
  const auto found = parameter(name, channel);
  const unsigned ch = found.first;
  const ProcessDataElement* e = found.second;
  if (e->direction == lbpkit::Direction::Input && !lbpkit::isNonVolatile(e->type))
    throw Error(fmt::format("{} is read only", e->name));
  if (scaled(*e)) {
    // A parameter out of its range is a mistake, not a value to clamp (process
    // data is clamped, as the DAC saturates).
    const double v = std::holds_alternative<double>(value) ? std::get<double>(value)
                     : std::holds_alternative<std::int64_t>(value) ? static_cast<double>(std::get<std::int64_t>(value))
                                                                    : static_cast<double>(std::get<bool>(value));
    if (!(v >= e->min && v <= e->max))
      throw std::invalid_argument(fmt::format("{}: {} is outside its range {} .. {}", e->name, v, e->min, e->max));
  }
  const std::uint64_t raw = toRaw(*e, value);
  withRemote(ch, [&](lbpkit::RemoteAccess& r) {
    lbpkit::writeElement(r, *e, raw);
    return 0;
  });
}

// --- Encoders ------------------------------------------------------------------------------

void Card::checkEncoder(unsigned n) const {
  if (!enc_) throw Error("encoders: call start() first (the card's muxed encoders are set up with the remotes)");
  if (n >= enc_->size())
    throw std::out_of_range(fmt::format("encoder {}: this card has encoders 0..{}", n, enc_->size() - 1));
}
std::int64_t Card::encoderCounts(unsigned n) const {
  checkEncoder(n);
  return enc_->counts(n);
}
double Card::encoderPosition(unsigned n) const {
  checkEncoder(n);
  return enc_->position(n);
}
double Card::encoderVelocity(unsigned n) const {
  checkEncoder(n);
  return enc_->velocity(n);
}
void Card::setEncoderScale(unsigned n, double countsPerUnit) {
  checkEncoder(n);
  if (!std::isfinite(countsPerUnit) || countsPerUnit == 0)
    throw std::invalid_argument(fmt::format("encoder {}: scale {} is not a non-zero number", n, countsPerUnit));
  enc_->setScale(n, countsPerUnit);
}
void Card::enableIndex(unsigned n) {
  checkEncoder(n);
  enc_->enableIndex(n);
}
bool Card::indexEnabled(unsigned n) const {
  checkEncoder(n);
  return enc_->indexEnabled(n);
}

}  // namespace pylbpkit
