#include "hostmot2/card.hpp"

namespace hm2 {

namespace {
constexpr std::uint32_t kConfigHost = 0x54534F48;  // "HOST"
constexpr std::uint32_t kConfigMot2 = 0x32544F4D;  // "MOT2"
}  // namespace

HostMot2Card::HostMot2Card(Options options) : options_(std::move(options)) {
  sevenI77s_.push_back(std::make_unique<SevenI77>(options_.first.fieldIo, options_.first.analog));
  if (options_.second) sevenI77s_.push_back(std::make_unique<SevenI77>(options_.second->fieldIo, options_.second->analog));
  const auto n = static_cast<unsigned>(sevenI77s_.size());
  const auto& b = options_.board;

  ioport_ = std::make_unique<IoPort>(b.ioPorts, b.portWidth);
  watchdog_ = std::make_unique<Watchdog>(b.clockLow, [this] { ioport_->reset(); });
  encoders_ = std::make_unique<MuxedEncoder>(6 * n, b.clockLow);
  encoderSelect_ = std::make_unique<MuxedEncoderSelect>();
  // Each 7I77 uses three SSerial channels: field I/O, analog, and the TB6
  // RS-422 expansion port (nothing attached).
  sserial_ = std::make_unique<SmartSerial>(3 * n);
  led_ = std::make_unique<Led>(4);  // CR1..CR4 on a 7I92
  for (unsigned i = 0; i < n; ++i) {
    sserial_->link(3 * i + 0).attach(&sevenI77s_[i]->fieldIo);
    sserial_->link(3 * i + 1).attach(&sevenI77s_[i]->analog);
  }
  modules_ = {watchdog_.get(), ioport_.get(), encoders_.get(), encoderSelect_.get(), sserial_.get(), led_.get()};
  for (Module* m : modules_)
    for (unsigned block = 0; block < 256; ++block)
      for (unsigned off = 0; off < 256; off += 4)
        if (m->decodes(static_cast<std::uint16_t>(block << 8 | off))) byBlock_[block] = m;

  std::vector<PinDescriptor> pins;
  for (unsigned connector = 0; connector < b.ioPorts; ++connector) {
    if (connector < n) {
      const auto p = sevenI77Pins(3 * connector, 3 * connector, connector);
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
  // Two 7I77s: two select outputs.
  if (sevenI77s_.size() > 1) v[3].instances = static_cast<std::uint8_t>(sevenI77s_.size());
  return v;
}

Module* HostMot2Card::moduleAt(std::uint16_t address) {
  Module* m = byBlock_[address >> 8];
  return (m && m->decodes(address)) ? m : nullptr;
}

void HostMot2Card::advance(SimTime now) {
  if (now < now_) now = now_;  // time never runs backwards
  now_ = now;
  for (Module* m : modules_) m->advance(now);
  for (auto& d : sevenI77s_) {
    d->fieldIo.advance(now);
    d->analog.advance(now);
  }
}

std::uint32_t HostMot2Card::read32(std::uint16_t address, SimTime now) {
  advance(now);
  address &= 0xFFFCU;
  if (address >= idrom::kIdromAddress && address < idrom::kIdromAddress + idrom::kWords * 4)
    return idrom_[static_cast<unsigned>(address - idrom::kIdromAddress) / 4];
  switch (address) {
    case idrom::kCookieAddress: return idrom::kCookie;
    case idrom::kConfigName: return kConfigHost;
    case idrom::kConfigName + 4: return kConfigMot2;
    case idrom::kIdromPointer: return idrom::kIdromAddress;
    default: break;
  }
  if (Module* m = moduleAt(address)) return m->read(address, now_);
  ++unmappedReads_;
  return 0;
}

void HostMot2Card::write32(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  address &= 0xFFFCU;
  if (Module* m = moduleAt(address)) {
    m->write(address, value, now_);
    return;
  }
  ++unmappedWrites_;  // ID area, IDROM and holes are read only
}

}  // namespace hm2
