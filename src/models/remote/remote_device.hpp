// SPDX-License-Identifier: MIT
// An LBP remote device: what every SSLBP remote processor has in common.
//
// A byte-addressed memory (manual: LBP, RPC COMMANDS; layout below), the
// local LBP registers, process data elements and parameters with their
// descriptors, a PTOC and GTOC per software mode (PROCESS DATA DISCOVERY),
// the three special RPCs, a fault byte (CS REGISTER AFTER DOIT), a watchdog
// (FIELD I/O WATCHDOG AND FAULTS) and non-volatile parameters in an EEPROM
// that are copied to the working values only at power-up
// (NON-VOLATILE FIELD I/O PARAMETERS). Concrete processors (field_io.hpp,
// analog.hpp) declare their process data in one table and model the
// electrical world behind it.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lbp/parser.hpp"
#include "lbp/sim_time.hpp"
#include "lbp/target.hpp"
#include "lbp/protocol.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "remote/gtoc_parameters.hpp"
#include "remote/nv_store.hpp"
#include "remote/program_flash.hpp"

namespace lbpkit::model::remote {

using lbp::SimTime;
using lbp::DataType;
using lbp::Direction;
using lbp::ProcessDataDescriptor;

// The memory map of our remote processors. The manual fixes only the RPC
// table (0..RPCSize-1); the rest is this implementation's choice, and hosts
// find everything through the discovery tables.
namespace memory {
inline constexpr std::uint16_t kRpcTable = 0x0000;  // 64 RPCs x pitch 8
inline constexpr std::uint16_t kRpcSize = 0x0200;
inline constexpr std::uint16_t kRam = 0x0200;  // working parameters and process data
inline constexpr std::uint16_t kRamSize = 0x0100;
inline constexpr std::uint16_t kEeprom = 0x0300;  // NV parameters (write with NV access = EEPROM)
inline constexpr std::uint16_t kEepromSize = 0x0040;
inline constexpr std::uint16_t kRom = 0x0400;  // discovery tables (read only)
inline constexpr std::uint16_t kRomSize = 0x0C00;
}  // namespace memory

// The remote fault byte, baud rate table and defaults are wire facts
// (manual: CS REGISTER AFTER DOIT, OPERATE MODE BAUD RATE).
namespace fault = lbpkit::wire::i7i77::fault;
using lbpkit::wire::i7i77::kBaudRates;
using lbpkit::wire::i7i77::kDefaultBaudIndex;
using lbpkit::wire::i7i77::kDefaultWatchdogMs;
using lbpkit::wire::i7i77::kSetupBaud;
// Command timeout at power-up in tenths of a character (manual: FRAMING).
inline constexpr std::uint8_t kSetupCommandTimeout = 255;
inline constexpr std::uint8_t kOperateCommandTimeout = 40;

using ElementId = std::uint8_t;

// A software process data mode: its name and its process data in PTOC order.
struct SoftwareMode {
  std::string_view name;
  std::span<const ElementId> processData;
};

// Parameters every remote here carries: the kGtocParameters rows both
// processors list (gtoc_parameters.hpp), by name.
enum class Standard : std::uint8_t {
  SwRevision,
  NvBaudRate,
  NvUnitNumber,
  NvWatchdogTimeout,
  UnitNumber,
  WatchdogTime,
  Fault,
};

class RemoteDevice : public lbp::Target {
 public:
  struct Identity {
    std::string_view cardName;       // 4 characters at 0xD0..0xD3
    std::uint32_t factoryUnitNumber;  // NVUNITNUMBER when the EEPROM is blank
    std::uint8_t swRevision;
    std::uint8_t hwMode;
    std::string_view hwModeName;
    std::uint8_t processor;  // kFieldIoProcessor or kAnalogProcessor: its rows of kGtocParameters
  };

  // `elements`: the device's own process data, declared once. `modes`: its
  // software modes (PTOC contents). Its GTOC parameters are its rows of
  // kGtocParameters, added after its own elements.
  RemoteDevice(Identity identity, std::span<const ProcessDataDescriptor> elements,
               std::span<const SoftwareMode> modes, std::filesystem::path nvFile = {}, std::string nvOwner = {},
               NvReporter nvReport = {});
  ~RemoteDevice() override = default;
  RemoteDevice(const RemoteDevice&) = delete;
  RemoteDevice& operator=(const RemoteDevice&) = delete;

  // --- The serial face -----------------------------------------------------
  // A character from the host; returns the reply it completes (may be empty).
  std::span<const std::uint8_t> receive(std::uint8_t byte, SimTime now) {
    if (!powered_) return {};
    advance(now);
    const auto reply = parser_.receive(byte, now);
    wake_ = nextEvent();  // the command may have fed or set the watchdog, or be half received
    return reply;
  }
  // A frame of characters `ch` apart, the first ending at `first`, that is
  // one special RPC, received between commands with nothing due before its
  // last character (no watchdog bite, no gap): the reply receive() of each
  // character would give, at once. nullopt, with nothing changed, otherwise.
  std::optional<std::span<const std::uint8_t>> receiveSpecialRpc(std::span<const std::uint8_t> frame, SimTime first,
                                                                 SimTime ch) {
    if (!powered_ || frame.empty() || first + ch * static_cast<SimTime::rep>(frame.size() - 1) >= wake_)
      return std::nullopt;
    const auto reply = parser_.receiveSpecialRpc(frame, first, ch);
    if (reply) wake_ = nextEvent();
    return reply;
  }
  // Let simulated time pass (watchdog, framing gaps). Inline and cheap until
  // something is due: the card advances both processors at every host access.
  void advance(SimTime now) {
    if (!powered_) return;
    now_ = now;
    if (now >= wake_) catchUp(now);
  }
  [[nodiscard]] std::uint32_t baud() const { return parser_.baud(); }

  // --- Power and jumpers ---------------------------------------------------
  void powerUp(SimTime now);
  void powerDown();
  // Its supply off and on again (the machine power-cycled): a processor that
  // was running boots, NV values becoming working values again; one that
  // was off stays off.
  virtual void powerCycle(SimTime now);
  [[nodiscard]] bool powered() const { return powered_; }
  // W4 / W12: setup mode (115.2 kBaud fixed). Read at power-up.
  void setSetupJumper(bool setup) { setupJumper_ = setup; }
  [[nodiscard]] bool setupJumper() const { return setupJumper_; }

  // --- Observation ---------------------------------------------------------
  [[nodiscard]] std::uint8_t faults() const { return faults_; }
  [[nodiscard]] std::uint8_t lbpStatus() const { return parser_.status(); }
  [[nodiscard]] std::uint8_t crcErrorCount() const { return parser_.crcErrorCount(); }
  [[nodiscard]] std::uint8_t softwareMode() const { return swMode_; }
  [[nodiscard]] std::uint32_t unitNumber() const;
  [[nodiscard]] std::uint16_t watchdogTimeMs() const {
    // raw(standard(Standard::WatchdogTime)) without the look-up: asked at
    // every character. A 16-bit working parameter, so in RAM.
    return static_cast<std::uint16_t>(ram_[watchdogOffset_] | (ram_[watchdogOffset_ + 1U] << 8));
  }
  [[nodiscard]] std::string_view cardName() const { return identity_.cardName; }
  [[nodiscard]] const Identity& identity() const { return identity_; }
  // CR15 (activity: toggles every 512 process data transfers, about 1 Hz at
  // a 1 kHz update) and CR16 (fault) (manual: STATUS LEDs).
  [[nodiscard]] bool activityLed() const { return (processDataCount_ >> 9) & 1U; }
  [[nodiscard]] bool faultLed() const { return powered_ && faults_ != 0; }
  [[nodiscard]] std::uint32_t processDataCount() const { return processDataCount_; }
  [[nodiscard]] const NvStore& nvStore() const { return nv_; }
  [[nodiscard]] const ProgramFlash& programFlash() const { return flash_; }
  // Whether its program runs (a good image in its flash at power-up), and
  // the software revision it reports.
  [[nodiscard]] bool programRuns() const { return program_.has_value(); }
  [[nodiscard]] std::uint8_t softwareRevision() const { return program_.value_or(0); }
  NvStore& nvStore() { return nv_; }
  ProgramFlash& programFlash() { return flash_; }
  [[nodiscard]] const lbp::Parser& parser() const { return parser_; }

  // What every processor shows an observer; each processor's State adds its
  // own terminals.
  struct DeviceState {
    bool powered = false;
    std::uint32_t unitNumber = 0;
    std::uint8_t faults = 0;  // fault:: bits
    std::uint8_t softwareMode = 0;
    std::uint16_t watchdogMs = 0;
    std::uint32_t baud = 0;
    bool activityLed = false;  // CR15
    bool faultLed = false;     // CR16
  };
  [[nodiscard]] DeviceState deviceState() const {
    return DeviceState{powered(), unitNumber(), faults(), softwareMode(),
                       watchdogTimeMs(), baud(), activityLed(), faultLed()};
  }

  // Discovery facts for the current mode (what the 0xBB RPC answers).
  struct Discovery {
    std::uint8_t rxSize;  // bytes to the host, fault byte included
    std::uint8_t txSize;  // bytes from the host
    std::uint16_t ptoc;
    std::uint16_t gtoc;
  };
  [[nodiscard]] Discovery discovery() const;

  // Element access by id: the device's own elements are 0..n-1, the standard
  // parameters follow (see standard()).
  [[nodiscard]] std::uint64_t raw(ElementId id) const {
    const auto& e = elements_[id];
    const std::uint8_t* p = bytesOf(e);
    if (p == nullptr) return 0;
    std::uint64_t v = 0;
    for (unsigned i = 0; i < e.bytes; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
    return v & e.mask;
  }
  [[nodiscard]] std::int64_t rawSigned(ElementId id) const { return lbp::signExtend(raw(id), elements_[id].d.bits); }
  [[nodiscard]] ElementId standard(Standard s) const { return standardIds_[static_cast<unsigned>(s)]; }
  [[nodiscard]] const ProcessDataDescriptor& descriptor(ElementId id) const { return elements_[id].d; }
  [[nodiscard]] std::uint16_t address(ElementId id) const { return elements_[id].address; }
  [[nodiscard]] std::size_t elementCount() const { return elements_.size(); }

  // --- lbp::Target ---------------------------------------------------------
  [[nodiscard]] bool rpcTableOverlaid() const override;
  std::uint8_t readMemory(std::uint16_t address) override;
  bool writeMemory(std::uint16_t address, std::uint8_t value) override;
  std::optional<std::uint8_t> readLocal(std::uint8_t command) override;
  bool writeLocal(std::uint8_t command, std::uint8_t value) override;
  std::optional<RpcSizes> specialRpc(std::uint8_t command) override;
  void runSpecialRpc(std::uint8_t command, std::span<const std::uint8_t> fromHost,
                     std::span<std::uint8_t> toHost) override;
  void beginCommand(SimTime now) override;
  void endCommand(SimTime now) override;
  void resetProcessor() override;

 protected:
  // Working (RAM) value of an element; NV elements live in the EEPROM.
  void setRaw(ElementId id, std::uint64_t value) {
    const auto& e = elements_[id];
    auto* p = const_cast<std::uint8_t*>(bytesOf(e));  // this device's own memory
    if (p == nullptr) return;
    value &= e.mask;
    for (unsigned i = 0; i < e.bytes; ++i) p[i] = static_cast<std::uint8_t>(value >> (8 * i));
  }
  void raiseFault(std::uint8_t bits) { faults_ = static_cast<std::uint8_t>(faults_ | bits); }
  // While the watchdog fault (or an illegal mode) is set, outputs cannot be
  // set: they stay off, and what the host writes meanwhile is discarded, so a
  // fault clear alone turns nothing on (manual: FIELD I/O WATCHDOG AND FAULTS,
  // "When a fault flag is set, outputs can not longer be set and the host
  // must first clear the fault"; ANALOG SECTION WATCHDOG). Over-current and
  // over-temperature switch off only what they affect (SHORT CIRCUIT
  // PROTECTION, OVER-TEMPERATURE PROTECTION): docs/protocol-facts.md#faults-and-outputs.
  [[nodiscard]] bool outputsBlocked() const { return (faults_ & (fault::kWatchdog | fault::kIllegalMode)) != 0; }
  // The id of one of this processor's kGtocParameters rows, by name (at
  // construction; throws std::logic_error when the table has no such row).
  [[nodiscard]] ElementId parameter(std::string_view name) const;

  // The world behind the processor.
  virtual void sampleInputs() = 0;  // terminals -> input elements
  virtual void driveOutputs() = 0;  // output elements -> terminals (respecting faults)
  // Conditions that are still present after a fault clear raise their bit again.
  virtual void reassertFaults() {}
  virtual void onPowerUp() {}

 private:
  // Where an element's value lives, worked out once (raw() and setRaw() run
  // for every element of every process data exchange).
  enum class Store : std::uint8_t { None, Ram, Eeprom };
  struct Element {
    ProcessDataDescriptor d;
    std::uint16_t address;
    Store store = Store::None;
    std::uint16_t offset = 0;  // into ram_ or eeprom_
    std::uint8_t bytes = 0;
    std::uint64_t mask = 0;  // the element's bits
  };
  // Where one element of a mode's process data sits in the process data
  // RPC's bytes (manual: PROCESS DATA RPC: packed in PTOC order, LSB first).
  struct Packed {
    ElementId id;
    std::uint8_t bits;
    std::uint16_t bit;  // offset from the first byte (after the fault byte, going to the host)
  };
  struct ModeTables {
    std::uint16_t ptoc;
    std::uint16_t gtoc;
    std::uint8_t rxSize;
    std::uint8_t txSize;
    std::vector<Packed> fromHost;  // outputs, pads left out
    std::vector<Packed> toHost;    // inputs, pads left out (the answer starts cleared)
  };

  void buildTables(std::span<const ProcessDataDescriptor> own);
  void clearFaults();
  // Output elements back to 0 while outputs are blocked (outputsBlocked()).
  void discardOutputs();
  void checkWatchdog(SimTime now);
  void catchUp(SimTime now);
  // The earliest time advance() can change anything (a framing gap ending a
  // half-received command, the watchdog biting): kept in wake_, worked out
  // again after everything that can bring it closer (a character received,
  // power-up, a catch-up), all of which go through receive(), powerUp() or
  // advance().
  [[nodiscard]] SimTime nextEvent() const {
    SimTime t = parser_.gapDeadline();
    // checkWatchdog() bites once now - lastHostCommand_ > ms.
    const auto ms = watchdogTimeMs();
    if (powered_ && !(faults_ & fault::kWatchdog) && ms != 0) {
      const SimTime bite = lastHostCommand_ + std::chrono::milliseconds(ms) + SimTime{1};
      if (bite < t) t = bite;
    }
    return t;
  }
  [[nodiscard]] const SoftwareMode& currentMode() const;
  [[nodiscard]] const ModeTables& currentTables() const;
  [[nodiscard]] std::uint8_t* storage(std::uint16_t address);
  [[nodiscard]] const std::uint8_t* storage(std::uint16_t address) const;
  [[nodiscard]] const Element* elementAt(std::uint16_t address) const;
  [[nodiscard]] const std::uint8_t* bytesOf(const Element& e) const {
    return e.store == Store::Ram      ? ram_.data() + e.offset
           : e.store == Store::Eeprom ? eeprom_.data() + e.offset
                                      : nullptr;
  }
  std::vector<std::uint8_t> factoryEeprom() const;

  // First: what advance() looks at, at every host access of the card.
  bool powered_ = false;
  SimTime now_{};
  SimTime wake_{SimTime::min()};  // nextEvent() as last worked out

  Identity identity_;
  std::span<const SoftwareMode> modes_;
  std::size_t ownElements_ = 0;
  std::vector<Element> elements_;
  std::vector<ModeTables> modeTables_;

  std::array<std::uint8_t, memory::kRpcSize> rpcTable_{};
  std::array<std::uint8_t, memory::kRamSize> ram_{};
  std::array<std::uint8_t, memory::kEepromSize> eeprom_{};  // pending image of this command
  std::array<std::uint8_t, memory::kEepromSize> eepromBefore_{};  // as it was before this command
  bool eepromDirty_ = false;
  std::vector<std::uint8_t> rom_;

  lbp::Parser parser_;
  NvStore nv_;
  ProgramFlash flash_;
  // The program flash holds a good program for this processor: it runs,
  // with this revision. Otherwise only the boot block runs (program_flash.hpp).
  std::optional<std::uint8_t> program_;

  bool setupJumper_ = false;
  std::uint8_t faults_ = 0;
  std::uint8_t swMode_ = 0;
  std::uint8_t nvAccess_ = 0;
  SimTime lastHostCommand_{};
  std::uint16_t watchdogOffset_ = 0;  // WatchDogTime's bytes in ram_
  std::array<ElementId, kStandardParameterCount> standardIds_{};  // by Standard
  std::uint32_t processDataCount_ = 0;
};

}  // namespace lbpkit::model::remote
