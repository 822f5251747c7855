// SPDX-License-Identifier: MIT
#include "hostmot2/card.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace lbpkit::model::hm2 {

namespace {
// The identification area and the IDROM: read only (HostMot2 regmap;
// docs/protocol-facts.md#identification-area-and-idrom).
constexpr bool readOnlyIdentification(std::uint16_t address) {
  return (address >= wire::hm2::idrom::kIdromAddress &&
          address < wire::hm2::idrom::kIdromAddress + idrom::kWords * 4) ||
         address == wire::hm2::idrom::kCookieAddress || address == wire::hm2::idrom::kConfigName ||
         address == wire::hm2::idrom::kConfigName + 4 || address == wire::hm2::idrom::kIdromPointer;
}

constexpr AccessKind refusal(WriteResult r) {
  switch (r) {
    case WriteResult::ReadOnly: return AccessKind::ReadOnlyWrite;
    case WriteResult::IgnoredCommand: return AccessKind::IgnoredCommand;
    case WriteResult::LostCommand: return AccessKind::LostCommand;
    case WriteResult::Accepted:
    case WriteResult::Unmapped: break;
  }
  return AccessKind::UnmappedWrite;
}
}  // namespace

std::string_view accessKindName(AccessKind kind) {
  switch (kind) {
    case AccessKind::UnmappedRead: return "unmapped_read";
    case AccessKind::UnmappedWrite: return "unmapped_write";
    case AccessKind::ReadOnlyWrite: return "read_only_write";
    case AccessKind::IgnoredCommand: return "ignored_command";
    case AccessKind::LostCommand: return "lost_command";
  }
  return "unknown";
}

HostMot2Card::HostMot2Card(Options options)
    : options_(std::move(options)), card_(options_.card != nullptr ? options_.card : &cards::defaultCard()) {
  firmware_ = options_.pinout ? cards::firmware(*card_, *options_.pinout) : &card_->firmwares.front();
  if (firmware_ == nullptr)
    throw std::invalid_argument("the " + std::string(card_->name) + " has no such firmware here (it has " +
                                cards::firmwareNames(*card_) + ")");
  if (options_.second && firmware_->sevenI77s.size() < 2)
    throw std::invalid_argument("the " + std::string(firmware_->name) + " pinout of the " + std::string(card_->name) +
                                " has no second 7I77 connector (use the 7I77x2 pinout)");
  sevenI77s_.push_back(std::make_unique<SevenI77>(options_.first.fieldIo, options_.first.analog));
  if (options_.second) sevenI77s_.push_back(std::make_unique<SevenI77>(options_.second->fieldIo, options_.second->analog));
  // The modules of the firmware, not of what is plugged in (PIN_7I77x2_34.vhd
  // declares 12 MuxedQCount and 6 SSerial channels with one 7I77 or two;
  // LinuxCNC counts channels from the pins). Each 7I77 uses three channels
  // (field I/O, analog, and the TB6 RS-422 expansion port with nothing
  // attached) and six muxed counters.
  for (const auto& entry : firmware_->modules) build(entry);
  if (module<Watchdog>() == nullptr || module<IoPort>() == nullptr || module<MuxedEncoder>() == nullptr ||
      module<Sslbp>() == nullptr || module<Led>() == nullptr)
    throw std::logic_error("a firmware in the catalogue lacks a module every card here has");
  auto& sserial = part<Sslbp>();
  // A 7I77 slot without a 7I77 leaves its channels unattached: START finds
  // no remote there.
  for (unsigned i = 0; i < sevenI77s_.size(); ++i) {
    const auto& slot = firmware_->sevenI77s[i];
    sserial.link(slot.firstChannel + 0U).attach(&sevenI77s_[i]->fieldIo);
    sserial.link(slot.firstChannel + 1U).attach(&sevenI77s_[i]->analog);
  }
  // The 7I76 beside the 7I77: its field I/O processor on its channel, its
  // expansion port (the next channel) with nothing attached.
  if (const auto channel = cards::sevenI76Channel(*firmware_)) {
    sevenI76_ = std::make_unique<remote::SevenI76FieldIo>(remote::SevenI76FieldIo::Options{});
    sserial.link(*channel).attach(sevenI76_.get());
  }
  for (Module* m : modules_)
    for (unsigned block = 0; block < 256; ++block)
      for (unsigned off = 0; off < 256; off += 4)
        if (m->decodes(static_cast<std::uint16_t>(block << 8 | off))) byBlock_[block] = m;
  for (unsigned block = 0; block < 256; ++block)
    if (Module* m = byBlock_[block]) {
      for (unsigned off = 0; off < 256; off += 4)
        if (m->decodes(static_cast<std::uint16_t>(block << 8 | off))) decoded_[block] |= std::uint64_t{1} << (off / 4);
      blockAccess_[block] = m->accessAt(static_cast<std::uint16_t>(block << 8));
    }
  // read32() asks the module map first: no module may decode the
  // identification area (the cookie's words up to the IDROM's end).
  static_assert(wire::hm2::idrom::kCookieAddress < wire::hm2::idrom::kConfigName &&
                wire::hm2::idrom::kIdromPointer < wire::hm2::idrom::kIdromAddress);
  for (unsigned reg = wire::hm2::idrom::kCookieAddress; reg < wire::hm2::idrom::kIdromAddress + idrom::kWords * 4U;
       reg += 4)
    if (readOnlyIdentification(static_cast<std::uint16_t>(reg)) && moduleAt(static_cast<std::uint16_t>(reg)) != nullptr)
      throw std::logic_error("a module of the " + std::string(firmware_->name) + " firmware decodes the identification area");

  const auto& b = card_->idrom;
  std::vector<PinDescriptor> pins(static_cast<std::size_t>(b.ioPorts) * b.portWidth);  // GPIO unless the firmware says
  firmware_->pins(pins);
  // The InM reads the I/O pins its pin descriptors give it (input n: pin n + 1).
  if (InM* inm = module<InM>())
    for (std::size_t p = 0; p < pins.size(); ++p)
      if (pins[p].secondaryTag == InM::kKind.tag && pins[p].secondaryPin >= 1 && pins[p].secondaryPin <= inm->inputs())
        inm->connect(&part<IoPort>(), pins[p].secondaryUnit, pins[p].secondaryPin - 1U, static_cast<unsigned>(p / b.portWidth),
                      static_cast<unsigned>(p % b.portWidth));
  if (const StepGen* sg = module<StepGen>()) {
    stepPins_.assign(sg->instances(), -1);
    for (std::size_t p = 0; p < pins.size(); ++p)
      if (pins[p].secondaryTag == StepGen::kKind.tag && pins[p].secondaryPin == pincode::kStep &&
          pins[p].secondaryUnit < stepPins_.size())
        stepPins_[pins[p].secondaryUnit] = static_cast<int>(p);
  }
  const auto mds = moduleDescriptors();
  idrom_ = buildIdrom(b, mds, pins);
}

bool HostMot2Card::stepGenDriven(unsigned n) const {
  if (n >= stepPins_.size() || stepPins_[n] < 0) return true;
  const auto p = static_cast<unsigned>(stepPins_[n]);
  return !part<IoPort>().released(p / card_->idrom.portWidth, p % card_->idrom.portWidth);
}

void HostMot2Card::build(const cards::ModuleEntry& entry) {
  using cards::Part;
  const auto& b = card_->idrom;
  // The DPLL comes first in the "d" firmwares: encoder.timer-number and
  // stepgen.timer-number latch on its timers.
  Dpll* dpll = module<Dpll>();
  std::unique_ptr<Module> m;
  switch (entry.part) {
    case Part::Watchdog:
      m = std::make_unique<Watchdog>(b.clockLow, [this] { part<IoPort>().releaseOutputs(); });
      break;
    case Part::IoPort: m = std::make_unique<IoPort>(entry.count, b.portWidth); break;
    case Part::MuxedQCount: {
      auto encoders = std::make_unique<MuxedEncoder>(entry.count, b.clockLow);
      encoders->attachDpll(dpll);
      m = std::move(encoders);
      break;
    }
    case Part::MuxedQCountSel: m = std::make_unique<MuxedEncoderSelect>(); break;
    case Part::SSerial: m = std::make_unique<Sslbp>(entry.count); break;
    case Part::Led: m = std::make_unique<Led>(entry.count); break;
    case Part::Dpll: m = std::make_unique<Dpll>(Dpll::kKind.base, entry.count, b.clockLow); break;
    case Part::StepGen: {
      auto stepgens = std::make_unique<StepGen>(StepGen::kKind.base, entry.count, b.clockLow);
      stepgens->attachDpll(dpll);
      m = std::move(stepgens);
      break;
    }
    case Part::PwmGen: m = std::make_unique<PwmGen>(PwmGen::kKind.base, entry.count, b.clockHigh); break;
    case Part::InM: m = std::make_unique<InM>(InM::kKind.base, 1, entry.count, b.clockLow); break;
    case Part::Ssr: m = std::make_unique<Ssr>(Ssr::kKind.base, entry.count, b.clockLow); break;
    case Part::OutM: m = std::make_unique<OutM>(OutM::kKind.base, entry.count); break;
  }
  // The modules whose state moves with time (the others' advance() does nothing).
  switch (entry.part) {
    case Part::Watchdog:
    case Part::MuxedQCount:
    case Part::SSerial:
    case Part::Dpll:
    case Part::StepGen:
    case Part::InM:
      if (timedCount_ == timed_.size()) throw std::logic_error("a firmware with more timed modules than the card calls");
      timed_[timedCount_++] = m.get();
      break;
    default: break;
  }
  modules_.push_back(m.get());
  owned_.push_back(std::move(m));
}

Module* HostMot2Card::module(std::uint8_t gtag) const {
  for (Module* m : modules_)
    if (m->descriptor().gtag == gtag) return m;
  return nullptr;
}

std::vector<ModuleDescriptor> HostMot2Card::moduleDescriptors() const {
  std::vector<ModuleDescriptor> v;
  for (const Module* m : modules_) v.push_back(m->descriptor());
  return v;
}

Module* HostMot2Card::moduleAt(std::uint16_t address) {
  // `address` is a register's (a multiple of 4).
  return ((decoded_[address >> 8] >> ((address & 0xFFU) / 4)) & 1U) ? byBlock_[address >> 8] : nullptr;
}

void HostMot2Card::powerCycle(SimTime now) {
  advance(now);  // everything up to the moment the power goes
  for (Module* m : modules_) m->reset();
  // The 7I77's processors boot again: logic power comes from the card (W5
  // left), field I/O power from VIN, both off and on with the machine
  // (manual: CABLE 5V POWER, VIN AND FIELD POWER SUPPLY). One whose supply is
  // absent stays off.
  for (auto& d : sevenI77s_) {
    d->fieldIo.powerCycle(now_);
    d->analog.powerCycle(now_);
  }
  if (sevenI76_) sevenI76_->powerCycle(now_);
}

void HostMot2Card::reconfigure(SimTime now) {
  advance(now);
  for (Module* m : modules_) m->reset();
}

std::uint32_t HostMot2Card::read32(std::uint16_t address, SimTime now) {
  advance(now);
  const auto reg = static_cast<std::uint16_t>(address & 0xFFFCU);
  // What Module::read does, with the map's answers looked up once per block
  // (no module decodes the identification area: the constructor checks).
  if (Module* m = moduleAt(reg)) return blockAccess_[reg >> 8] == map::Access::WriteOnly ? 0 : m->readRegister(reg, now_);
  if (reg >= wire::hm2::idrom::kIdromAddress && reg < wire::hm2::idrom::kIdromAddress + idrom::kWords * 4)
    return idrom_[static_cast<unsigned>(reg - wire::hm2::idrom::kIdromAddress) / 4];
  switch (reg) {
    case wire::hm2::idrom::kCookieAddress: return wire::hm2::idrom::kCookie;
    case wire::hm2::idrom::kConfigName: return wire::hm2::idrom::kConfigNameHost;
    case wire::hm2::idrom::kConfigName + 4: return wire::hm2::idrom::kConfigNameMot2;
    case wire::hm2::idrom::kIdromPointer: return wire::hm2::idrom::kIdromAddress;
    default: break;
  }
  noteAccess(AccessKind::UnmappedRead, address, 0);
  return 0;
}

void HostMot2Card::write32(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const auto reg = static_cast<std::uint16_t>(address & 0xFFFCU);
  if (Module* m = moduleAt(reg)) {
    const WriteResult r = blockAccess_[reg >> 8] == map::Access::ReadOnly ? WriteResult::ReadOnly
                                                                           : m->writeRegister(reg, value, now_);
    if (r != WriteResult::Accepted) [[unlikely]]
      noteAccess(refusal(r), address, value);
    return;
  }
  noteAccess(readOnlyIdentification(reg) ? AccessKind::ReadOnlyWrite : AccessKind::UnmappedWrite, address, value);
}

// Off the per-access path: only for the rare accesses it counts.
void HostMot2Card::noteAccess(AccessKind kind, std::uint16_t address, std::uint32_t value) {
  switch (kind) {
    case AccessKind::UnmappedRead: ++access_.unmappedReads; break;
    case AccessKind::UnmappedWrite: ++access_.unmappedWrites; break;
    case AccessKind::ReadOnlyWrite: ++access_.readOnlyWrites; break;
    case AccessKind::IgnoredCommand: ++access_.ignoredCommands; break;
    case AccessKind::LostCommand: ++access_.lostCommands; break;
  }
  const AccessEvent event{now_, address, value, kind};
  recent_[events_ % recent_.size()] = event;
  ++events_;
  if (observer_ != nullptr) observer_(observerContext_, event);
}

RecentAccesses HostMot2Card::recentAccesses() const {
  RecentAccesses r;
  r.size = static_cast<std::size_t>(std::min<std::uint64_t>(events_, recent_.size()));
  const std::uint64_t first = events_ - r.size;
  for (std::size_t i = 0; i < r.size; ++i) r.events[i] = recent_[(first + i) % recent_.size()];
  return r;
}

}  // namespace lbpkit::model::hm2
