// SPDX-License-Identifier: MIT
#include "remote/remote_device.hpp"

#include <algorithm>
#include <cstring>
#include <utility>
#include <stdexcept>

namespace lbpkit::model::remote {

using lbp::byteSize;
using lbp::isNonVolatile;
namespace status = lbp::status;

namespace {

// The Standard parameters' names, in the Standard enum's order: rows of
// the parameter table that both processors list.
constexpr std::string_view kStandardNames[] = {"SwRevision", "NVBaudRate",   "NVUnitNumber", "NVWatchDogTimeout",
                                               "UnitNumber", "WatchDogTime", "Fault"};
static_assert(std::size(kStandardNames) == kStandardParameterCount &&
              static_cast<unsigned>(Standard::Fault) + 1 == kStandardParameterCount);
constexpr bool everyStandardRowIsForBoth() {
  for (const auto name : kStandardNames) {
    bool found = false;
    for (const auto& row : kGtocParameters) found |= row.descriptor.name == name && row.processors == kBothProcessors;
    if (!found) return false;
  }
  return true;
}
static_assert(everyStandardRowIsForBoth(), "kGtocParameters must hold every Standard parameter, for both processors");

constexpr lbp::ParserConfig parserConfig(bool setup, std::uint32_t baud) {
  return lbp::ParserConfig{memory::kRpcSize, 0x01, true, setup ? kSetupCommandTimeout : kOperateCommandTimeout, baud};
}

void putLe16(std::vector<std::uint8_t>& v, std::uint16_t x) {
  v.push_back(static_cast<std::uint8_t>(x & 0xFFU));
  v.push_back(static_cast<std::uint8_t>(x >> 8));
}
void putFloat(std::vector<std::uint8_t>& v, float f) {
  std::uint32_t bits = 0;
  static_assert(sizeof bits == sizeof f);
  std::memcpy(&bits, &f, sizeof f);
  for (int i = 0; i < 4; ++i) v.push_back(static_cast<std::uint8_t>(bits >> (8 * i)));
}
void putString(std::vector<std::uint8_t>& v, std::string_view s) {
  v.insert(v.end(), s.begin(), s.end());
  v.push_back(0);
}
bool sendsToHost(Direction d) { return d == Direction::Input || d == Direction::Bidirectional; }
bool receivesFromHost(Direction d) { return d == Direction::Output || d == Direction::Bidirectional; }

}  // namespace

RemoteDevice::RemoteDevice(Identity identity, std::span<const ProcessDataDescriptor> elements,
                           std::span<const SoftwareMode> modes, std::filesystem::path nvFile, std::string nvOwner,
                           NvReporter nvReport)
    : identity_(identity),
      modes_(modes),
      ownElements_(elements.size()),
      parser_(*this, parserConfig(false, kBaudRates[kDefaultBaudIndex])),
      nv_(memory::kEepromSize, nvFile, nvOwner, nvReport),
      // The program flash beside the EEPROM: FILE.program.
      flash_(nvFile.empty() ? std::filesystem::path() : std::filesystem::path(nvFile.string() + ".program"),
             std::move(nvOwner), std::move(nvReport)) {
  if (modes_.empty()) throw std::logic_error("a remote needs at least one software mode");
  buildTables(elements);
}

void RemoteDevice::buildTables(std::span<const ProcessDataDescriptor> own) {
  // Variables: RAM for working values, EEPROM for NV ones, in table order.
  std::uint16_t ram = memory::kRam;
  std::uint16_t eeprom = memory::kEeprom;
  auto place = [&](const ProcessDataDescriptor& d) {
    if (d.type == DataType::Pad) return std::uint16_t{0};
    std::uint16_t& cursor = isNonVolatile(d.type) ? eeprom : ram;
    const std::uint16_t at = cursor;
    cursor = static_cast<std::uint16_t>(cursor + byteSize(d));
    return at;
  };
  for (const auto& d : own) elements_.push_back({d, place(d)});
  for (const auto& row : kGtocParameters)
    if (row.processors & identity_.processor) elements_.push_back({row.descriptor, place(row.descriptor)});
  if (ram > memory::kRam + memory::kRamSize || eeprom > memory::kEeprom + memory::kEepromSize)
    throw std::logic_error("remote variables do not fit the memory map");
  // Each element's bytes, as storage() finds them (a pad has none).
  for (auto& e : elements_) {
    e.bytes = static_cast<std::uint8_t>(byteSize(e.d));
    e.mask = e.d.bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << e.d.bits) - 1;
    if (e.address >= memory::kRam && e.address < memory::kRam + memory::kRamSize) {
      e.store = Store::Ram;
      e.offset = static_cast<std::uint16_t>(e.address - memory::kRam);
    } else if (e.address >= memory::kEeprom && e.address < memory::kEeprom + memory::kEepromSize) {
      e.store = Store::Eeprom;
      e.offset = static_cast<std::uint16_t>(e.address - memory::kEeprom);
    }
  }
  for (std::size_t s = 0; s < kStandardParameterCount; ++s) standardIds_[s] = parameter(kStandardNames[s]);
  const Element& watchdog = elements_[standard(Standard::WatchdogTime)];
  if (watchdog.store != Store::Ram || watchdog.d.bits != 16)
    throw std::logic_error("WatchDogTime must be 16 bits of RAM");
  watchdogOffset_ = watchdog.offset;

  // Discovery records in ROM: every PDD, the hardware mode, each software mode.
  std::vector<std::uint8_t>& rom = rom_;
  auto here = [&]() { return static_cast<std::uint16_t>(memory::kRom + rom.size()); };
  std::vector<std::uint16_t> pdd;
  for (const auto& e : elements_) {
    pdd.push_back(here());
    rom.push_back(lbp::kProcessDataRecord);
    rom.push_back(e.d.bits);
    rom.push_back(static_cast<std::uint8_t>(e.d.type));
    rom.push_back(static_cast<std::uint8_t>(e.d.direction));
    putFloat(rom, e.d.min);
    putFloat(rom, e.d.max);
    putLe16(rom, e.address);
    putString(rom, e.d.unit);
    putString(rom, e.d.name);
  }
  const std::uint16_t hwRecord = here();
  rom.insert(rom.end(), {lbp::kModeRecord, identity_.hwMode, lbp::kHwMode, 0});
  putString(rom, identity_.hwModeName);
  std::vector<std::uint16_t> swRecord;
  for (std::size_t m = 0; m < modes_.size(); ++m) {
    swRecord.push_back(here());
    rom.insert(rom.end(), {lbp::kModeRecord, static_cast<std::uint8_t>(m), lbp::kSwMode, 0});
    putString(rom, modes_[m].name);
  }
  // Per mode: PTOC = its process data, then the two mode records (manual:
  // MODE DESCRIPTOR: the current hardware and software modes). GTOC = the
  // same process data, the hardware mode, every software mode the processor
  // has (mesaflash walks each software mode it finds there; LinuxCNC only
  // prints them, and makes pins from the PTOC alone), then its parameters.
  // Both end with a 0 sentinel. (A GTOC entry at the same PARAM_ADD as a
  // PTOC entry is process data to LinuxCNC, so the shared pointers do not
  // turn into HAL parameters; other modes' process data is not listed, as
  // no sibling board shows it as parameters.)
  for (std::size_t m = 0; m < modes_.size(); ++m) {
    ModeTables t{};
    unsigned rxBits = 0;
    unsigned txBits = 0;
    for (ElementId id : modes_[m].processData) {
      const auto& d = elements_.at(id).d;
      const bool pad = d.type == DataType::Pad;
      if (sendsToHost(d.direction)) {
        if (!pad) t.toHost.push_back({id, d.bits, static_cast<std::uint16_t>(rxBits)});
        rxBits += d.bits;
      }
      if (receivesFromHost(d.direction)) {
        if (!pad) t.fromHost.push_back({id, d.bits, static_cast<std::uint16_t>(txBits)});
        txBits += d.bits;
      }
    }
    t.rxSize = static_cast<std::uint8_t>(1 + (rxBits + 7) / 8);  // fault byte first
    t.txSize = static_cast<std::uint8_t>((txBits + 7) / 8);
    t.ptoc = here();
    for (ElementId id : modes_[m].processData) putLe16(rom, pdd[id]);
    putLe16(rom, hwRecord);
    putLe16(rom, swRecord[m]);
    putLe16(rom, 0);
    t.gtoc = here();
    for (ElementId id : modes_[m].processData) putLe16(rom, pdd[id]);
    putLe16(rom, hwRecord);
    for (const auto record : swRecord) putLe16(rom, record);
    for (std::size_t e = ownElements_; e < elements_.size(); ++e) putLe16(rom, pdd[e]);
    putLe16(rom, 0);
    modeTables_.push_back(t);
  }
  if (rom.size() > memory::kRomSize) throw std::logic_error("discovery tables do not fit the ROM");
}

ElementId RemoteDevice::parameter(std::string_view name) const {
  for (std::size_t e = ownElements_; e < elements_.size(); ++e)
    if (elements_[e].d.name == name) return static_cast<ElementId>(e);
  throw std::logic_error("no GTOC parameter row for this processor");
}

std::vector<std::uint8_t> RemoteDevice::factoryEeprom() const {
  std::vector<std::uint8_t> image(memory::kEepromSize, 0x00);
  auto put = [&](Standard s, std::uint64_t value) {
    const auto& e = elements_[standard(s)];
    for (unsigned i = 0; i < byteSize(e.d); ++i)
      image[e.address - memory::kEeprom + i] = static_cast<std::uint8_t>(value >> (8 * i));
  };
  put(Standard::NvBaudRate, kDefaultBaudIndex);
  put(Standard::NvUnitNumber, identity_.factoryUnitNumber);
  put(Standard::NvWatchdogTimeout, kDefaultWatchdogMs);
  return image;
}

// --- Power -------------------------------------------------------------------

void RemoteDevice::powerUp(SimTime now) {
  powered_ = true;
  now_ = now;
  rpcTable_.fill(0);
  ram_.fill(0);
  if (nv_.load()) {
    std::copy(nv_.image().begin(), nv_.image().end(), eeprom_.begin());
  } else {
    // Blank EEPROM: the factory defaults, programmed if the medium takes them
    // (and used this power-up either way).
    const auto image = factoryEeprom();
    nv_.commit(image);
    std::copy(image.begin(), image.end(), eeprom_.begin());
  }
  eepromDirty_ = false;
  // The boot block checks the program: a good one for this processor runs
  // (lbpkit's image; a blank flash file holds the factory program).
  flash_.load(ProgramFlash::image(identity_.cardName, identity_.processor, identity_.swRevision, {}));
  program_ = ProgramFlash::programRevision(flash_.contents(), identity_.cardName, identity_.processor);
  if (!program_) {
    const auto where = flash_.store().file().empty() ? std::string("its flash")
                                                     : flash_.store().file().string();
    flash_.report(NvEvent::Kind::NoProgram,
                  "the " + std::string(identity_.cardName) + " " +
                      (identity_.processor == kFieldIoProcessor ? "field I/O" : "analog") + " processor's program in " +
                      where +
                      " is not valid (an update was cut?): it stays in its boot block, which answers LBP but has no "
                      "process data; lbpkit flash-remote puts a new image in it (setup mode: W12 for the field I/O "
                      "processor, W4 for the analog one)");
  }
  // NV values become working values only here (manual: NON-VOLATILE FIELD I/O PARAMETERS).
  const auto baudIndex = raw(standard(Standard::NvBaudRate));
  const std::uint32_t baud = setupJumper_                      ? kSetupBaud
                             : baudIndex < kBaudRates.size() ? kBaudRates[baudIndex]
                                                             : kBaudRates[kDefaultBaudIndex];
  parser_.setConfig(parserConfig(setupJumper_, baud));
  parser_.reset();
  setRaw(standard(Standard::UnitNumber), raw(standard(Standard::NvUnitNumber)));
  setRaw(standard(Standard::WatchdogTime), raw(standard(Standard::NvWatchdogTimeout)));
  setRaw(standard(Standard::SwRevision), softwareRevision());
  swMode_ = 0;
  nvAccess_ = 0;
  // Startup condition: the watchdog fault is set until the host clears it
  // (manual: WATCHDOG AND FAULTS; CR16 is on at power-up).
  faults_ = fault::kWatchdog;
  parser_.raiseStatus(status::kWatchdogTimeout);
  lastHostCommand_ = now;
  processDataCount_ = 0;
  onPowerUp();
  sampleInputs();
  setRaw(standard(Standard::Fault), faults_);
  driveOutputs();
  wake_ = nextEvent();
}

void RemoteDevice::powerDown() {
  powered_ = false;
  driveOutputs();
}

void RemoteDevice::powerCycle(SimTime now) {
  if (!powered_) return;
  powerDown();
  powerUp(now);
}

void RemoteDevice::resetProcessor() { powerUp(now_); }

// --- Time ----------------------------------------------------------------------

void RemoteDevice::catchUp(SimTime now) {
  parser_.advance(now);
  checkWatchdog(now);
  wake_ = nextEvent();
}

void RemoteDevice::checkWatchdog(SimTime now) {
  if (faults_ & fault::kWatchdog) return;  // already bitten
  const auto ms = watchdogTimeMs();        // 0 disables the watchdog
  if (ms == 0) return;
  if (now - lastHostCommand_ <= std::chrono::milliseconds(ms)) return;
  raiseFault(fault::kWatchdog);
  parser_.raiseStatus(status::kWatchdogTimeout);
  setRaw(standard(Standard::Fault), faults_);
  discardOutputs();
  driveOutputs();
}

void RemoteDevice::beginCommand(SimTime now) {
  now_ = now;
  eepromBefore_ = eeprom_;
  checkWatchdog(now);
  lastHostCommand_ = now;
  sampleInputs();
  setRaw(standard(Standard::Fault), faults_);
}

void RemoteDevice::endCommand(SimTime) {
  if (eepromDirty_) {
    eepromDirty_ = false;
    // One command's NV bytes are written as one EEPROM commit, so a
    // multi-byte parameter is never half old, half new.
    if (!nv_.commit(eeprom_)) {
      if (nv_.lostPower()) {
        powerDown();  // power went away in the middle of the write
        return;
      }
      // The medium refused the write (a read-only or full disk): the old
      // values stay, and the host learns the write did not take.
      eeprom_ = eepromBefore_;
      parser_.raiseStatus(status::kInvalidWrite);
    }
  }
  if (outputsBlocked()) discardOutputs();  // what was written while faulted is not set
  driveOutputs();  // may trip outputs: the fault byte follows
  setRaw(standard(Standard::Fault), faults_);
}

// --- Faults --------------------------------------------------------------------

void RemoteDevice::discardOutputs() {
  for (std::size_t e = 0; e < ownElements_; ++e)
    if (elements_[e].d.direction == Direction::Output) setRaw(static_cast<ElementId>(e), 0);
}

void RemoteDevice::clearFaults() {
  faults_ = 0;
  parser_.clearStatus(status::kWatchdogTimeout);
  if (swMode_ >= modes_.size()) raiseFault(fault::kIllegalMode);
  reassertFaults();
  setRaw(standard(Standard::Fault), faults_);
}

// --- Memory --------------------------------------------------------------------

const RemoteDevice::Element* RemoteDevice::elementAt(std::uint16_t address) const {
  for (const auto& e : elements_) {
    if (e.d.type != DataType::Pad && address >= e.address && address < e.address + byteSize(e.d)) return &e;
  }
  return nullptr;
}

std::uint8_t* RemoteDevice::storage(std::uint16_t address) {
  return const_cast<std::uint8_t*>(std::as_const(*this).storage(address));
}

const std::uint8_t* RemoteDevice::storage(std::uint16_t address) const {
  if (address >= memory::kRam && address < memory::kRam + memory::kRamSize) return &ram_[address - memory::kRam];
  if (address >= memory::kEeprom && address < memory::kEeprom + memory::kEepromSize)
    return &eeprom_[address - memory::kEeprom];
  return nullptr;
}

bool RemoteDevice::rpcTableOverlaid() const { return nvAccess_ == lbp::nonvolatile::kFlash; }

std::uint8_t RemoteDevice::readMemory(std::uint16_t address) {
  if (nvAccess_ == lbp::nonvolatile::kFlash && ProgramFlash::maps(address)) return flash_.read(address);
  if (address < memory::kRpcSize) return rpcTable_[address];
  if (const auto* p = storage(address)) return *p;
  if (address >= memory::kRom && address - memory::kRom < static_cast<int>(rom_.size())) return rom_[address - memory::kRom];
  return 0;  // unmapped: reads as 0
}

bool RemoteDevice::writeMemory(std::uint16_t address, std::uint8_t value) {
  if (nvAccess_ == lbp::nonvolatile::kFlash && ProgramFlash::maps(address)) return flash_.write(address, value);
  if (address < memory::kRpcSize) {  // the parser has checked the RPCMEM flag
    rpcTable_[address] = value;
    return true;
  }
  const Element* e = elementAt(address);
  if (e == nullptr) return false;  // unmapped
  if (isNonVolatile(e->d.type)) {
    // NV parameters are written with NV access set to EEPROM (LinuxCNC and
    // mesaflash write 0xEC = 1 first), whatever their process direction.
    if (nvAccess_ != lbp::nonvolatile::kEeprom) return false;
    eeprom_[address - memory::kEeprom] = value;
    eepromDirty_ = true;
    return true;
  }
  if (e->d.direction == Direction::Input) return false;  // read only
  *storage(address) = value;
  return true;
}

std::uint32_t RemoteDevice::unitNumber() const {
  return static_cast<std::uint32_t>(raw(standard(Standard::UnitNumber)));
}

// --- Local registers -------------------------------------------------------------

std::optional<std::uint8_t> RemoteDevice::readLocal(std::uint8_t command) {
  namespace r = lbp::local_read;
  switch (command) {
    case r::kUnitAddress: return 0;
    case r::kRemoteSwMode: return swMode_;
    case r::kClearFault: return 0;  // the clear is done by the time it can be read
    case r::kNonVolatile: return nvAccess_;
    case r::kCapability: return lbp::capability::kCrc | lbp::capability::kEeprom | lbp::capability::kFlash;
    case r::kSwRevision: return softwareRevision();
    case r::kHwMode: return identity_.hwMode;
    case r::kFaultStatus: return faults_;
    default: break;
  }
  if (command >= r::kCardName0 && command < r::kCardName0 + 4) {
    const auto i = static_cast<std::size_t>(command - r::kCardName0);
    return i < identity_.cardName.size() ? static_cast<std::uint8_t>(identity_.cardName[i]) : 0;
  }
  return std::nullopt;
}

bool RemoteDevice::writeLocal(std::uint8_t command, std::uint8_t value) {
  namespace w = lbp::local_write;
  switch (command) {
    case w::kRemoteSwMode:
      swMode_ = value;
      if (swMode_ >= modes_.size()) raiseFault(fault::kIllegalMode);
      return true;
    case w::kClearFault:
      if (value != 0) clearFaults();
      return true;
    case w::kNonVolatile:
      // EEPROM always; the program flash in setup mode only (manual: RPD,
      // WPD, AND UFLBP: "the 7I77 MUST be in setup mode for UFLBP").
      if (value == lbp::nonvolatile::kFlash && !setupJumper_) return false;
      if (value != lbp::nonvolatile::kNone && value != lbp::nonvolatile::kEeprom && value != lbp::nonvolatile::kFlash)
        return false;
      nvAccess_ = value;
      return true;
    case w::kLeds:
      return true;  // CR15/CR16 are the firmware's: a host LED write changes nothing visible
    default:
      return false;
  }
}

// --- Special RPCs ----------------------------------------------------------------

const SoftwareMode& RemoteDevice::currentMode() const {
  return swMode_ < modes_.size() ? modes_[swMode_] : modes_[0];
}
const RemoteDevice::ModeTables& RemoteDevice::currentTables() const {
  return swMode_ < modes_.size() ? modeTables_[swMode_] : modeTables_[0];
}

RemoteDevice::Discovery RemoteDevice::discovery() const {
  const auto& t = currentTables();
  return {t.rxSize, t.txSize, t.ptoc, t.gtoc};
}

std::optional<lbp::Target::RpcSizes> RemoteDevice::specialRpc(std::uint8_t command) {
  namespace rpc = lbp::special_rpc;
  // The boot block alone answers LBP but has no process data: without a
  // program the special RPCs are not there (SSLBP's start fails at them).
  if (!program_) return std::nullopt;
  switch (command) {
    case rpc::kDiscovery: return RpcSizes{0, 6};
    case rpc::kUnitNumber: return RpcSizes{0, 4};
    case rpc::kProcessData: return RpcSizes{currentTables().txSize, currentTables().rxSize};
    default: return std::nullopt;
  }
}

void RemoteDevice::runSpecialRpc(std::uint8_t command, std::span<const std::uint8_t> fromHost,
                                 std::span<std::uint8_t> toHost) {
  namespace rpc = lbp::special_rpc;
  switch (command) {
    case rpc::kDiscovery: {
      const auto d = discovery();
      const std::uint8_t bytes[6] = {d.rxSize,
                                     d.txSize,
                                     static_cast<std::uint8_t>(d.ptoc & 0xFFU),
                                     static_cast<std::uint8_t>(d.ptoc >> 8),
                                     static_cast<std::uint8_t>(d.gtoc & 0xFFU),
                                     static_cast<std::uint8_t>(d.gtoc >> 8)};
      std::copy_n(bytes, std::min<std::size_t>(6, toHost.size()), toHost.begin());
      return;
    }
    case rpc::kUnitNumber: {
      const std::uint32_t unit = unitNumber();
      for (std::size_t i = 0; i < toHost.size() && i < 4; ++i) toHost[i] = static_cast<std::uint8_t>(unit >> (8 * i));
      return;
    }
    case rpc::kProcessData: {
      // Outputs from the host, then fault byte and inputs back, both packed
      // in PTOC order (manual: PROCESS DATA RPC). The bytes are worked on in
      // a buffer with room past their end (lbp::kPackingRoom), zero as
      // bytes past the data read, so that every element is one word.
      const ModeTables& t = currentTables();
      constexpr std::size_t kRoom = lbp::kPackingRoom;
      std::array<std::uint8_t, 256 + kRoom> buffer;  // only the bytes the spans below cover are set
      std::fill_n(std::copy(fromHost.begin(), fromHost.end(), buffer.begin()), kRoom, std::uint8_t{0});
      const std::span<const std::uint8_t> in{buffer.data(), fromHost.size() + kRoom};
      for (const Packed& p : t.fromHost) setRaw(p.id, lbp::unpackBits(in, p.bit, p.bits));
      if (toHost.empty()) return;
      toHost[0] = faults_;
      std::fill_n(buffer.begin(), toHost.size() - 1 + kRoom, std::uint8_t{0});
      const std::span<std::uint8_t> out{buffer.data(), toHost.size() - 1 + kRoom};
      for (const Packed& p : t.toHost) lbp::packBits(out, p.bit, p.bits, raw(p.id));
      std::copy_n(buffer.begin(), toHost.size() - 1, toHost.begin() + 1);
      ++processDataCount_;
      return;
    }
    default:
      return;
  }
}

}  // namespace lbpkit::model::remote
