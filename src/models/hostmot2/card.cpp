#include "hostmot2/card.hpp"

#include <algorithm>
#include <stdexcept>

namespace hm2 {

namespace {
constexpr std::uint32_t kConfigHost = 0x54534F48;  // "HOST"
constexpr std::uint32_t kConfigMot2 = 0x32544F4D;  // "MOT2"

// The identification area and the IDROM: read only (HostMot2 regmap;
// docs/protocol-facts.md#identification-area-and-idrom).
constexpr bool readOnlyIdentification(std::uint16_t address) {
  return (address >= idrom::kIdromAddress && address < idrom::kIdromAddress + idrom::kWords * 4) ||
         address == idrom::kCookieAddress || address == idrom::kConfigName || address == idrom::kConfigName + 4 ||
         address == idrom::kIdromPointer;
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

HostMot2Card::HostMot2Card(Options options) : options_(std::move(options)) {
  const bool x2 = options_.pinout == Pinout::SevenI77x2;
  if (options_.second && !x2)
    throw std::invalid_argument("the 7I77 + GPIO pinout has no second 7I77 connector (use the 7I77x2 pinout)");
  sevenI77s_.push_back(std::make_unique<SevenI77>(options_.first.fieldIo, options_.first.analog));
  if (options_.second) sevenI77s_.push_back(std::make_unique<SevenI77>(options_.second->fieldIo, options_.second->analog));
  const auto& b = options_.board;
  // The modules of the firmware, not of what is plugged in: PIN_7I77x2_34.vhd
  // declares 12 MuxedQCount and one SSerial instance with 6 channels (its
  // highest SSerial pin, SS5 on IO17..19; LinuxCNC counts channels from the
  // pins). Each 7I77 uses three channels (field I/O, analog, and the TB6
  // RS-422 expansion port with nothing attached) and six muxed counters.
  const unsigned connectors7I77 = x2 ? 2 : 1;

  ioport_ = std::make_unique<IoPort>(b.ioPorts, b.portWidth);
  watchdog_ = std::make_unique<Watchdog>(b.clockLow, [this] { ioport_->releaseOutputs(); });
  encoders_ = std::make_unique<MuxedEncoder>(6 * connectors7I77, b.clockLow);
  encoderSelect_ = std::make_unique<MuxedEncoderSelect>();
  sserial_ = std::make_unique<SmartSerial>(3 * connectors7I77);
  led_ = std::make_unique<Led>(4);  // CR1..CR4 on a 7I92
  // A connector without a 7I77 leaves its channels unattached: START finds
  // no remote there.
  for (unsigned i = 0; i < sevenI77s_.size(); ++i) {
    sserial_->link(3 * i + 0).attach(&sevenI77s_[i]->fieldIo);
    sserial_->link(3 * i + 1).attach(&sevenI77s_[i]->analog);
  }
  modules_ = {watchdog_.get(), ioport_.get(), encoders_.get(), encoderSelect_.get(), sserial_.get(), led_.get()};
  for (Module* m : modules_)
    for (unsigned block = 0; block < 256; ++block)
      for (unsigned off = 0; off < 256; off += 4)
        if (m->decodes(static_cast<std::uint16_t>(block << 8 | off))) byBlock_[block] = m;
  for (unsigned block = 0; block < 256; ++block)
    if (Module* m = byBlock_[block])
      for (unsigned off = 0; off < 256; off += 4)
        if (m->decodes(static_cast<std::uint16_t>(block << 8 | off))) decoded_[block] |= std::uint64_t{1} << (off / 4);

  std::vector<PinDescriptor> pins;
  for (unsigned connector = 0; connector < b.ioPorts; ++connector) {
    if (connector < connectors7I77) {
      // PIN_7I77x2_34.vhd gives the second connector's ENCMUX the unit 6 (the
      // firmware drives every select pin from the one select line whatever
      // its unit; LinuxCNC claims it only with num_encoders > 6).
      const auto p = sevenI77Pins(3 * connector, 3 * connector, 6 * connector);
      pins.insert(pins.end(), p.begin(), p.end());
    } else {
      pins.insert(pins.end(), b.portWidth, PinDescriptor{});  // GPIO only
    }
  }
  const auto mds = moduleDescriptors();
  idrom_ = buildIdrom(b, mds, pins);
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
}

std::uint32_t HostMot2Card::read32(std::uint16_t address, SimTime now) {
  advance(now);
  const auto reg = static_cast<std::uint16_t>(address & 0xFFFCU);
  if (reg >= idrom::kIdromAddress && reg < idrom::kIdromAddress + idrom::kWords * 4)
    return idrom_[static_cast<unsigned>(reg - idrom::kIdromAddress) / 4];
  switch (reg) {
    case idrom::kCookieAddress: return idrom::kCookie;
    case idrom::kConfigName: return kConfigHost;
    case idrom::kConfigName + 4: return kConfigMot2;
    case idrom::kIdromPointer: return idrom::kIdromAddress;
    default: break;
  }
  if (Module* m = moduleAt(reg)) return m->read(reg, now_);
  noteAccess(AccessKind::UnmappedRead, address, 0);
  return 0;
}

void HostMot2Card::write32(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const auto reg = static_cast<std::uint16_t>(address & 0xFFFCU);
  if (Module* m = moduleAt(reg)) {
    const WriteResult r = m->write(reg, value, now_);
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

}  // namespace hm2
