// SPDX-License-Identifier: MIT
// A HostMot2 Ethernet card (a 7I92 unless told which: cards/catalogue.hpp)
// with 7I77 daughtercards: the register file drivers see (over LBP16 on the
// real card), the modules of the firmware it runs, and the 7I77 processors on
// its smart-serial channels. Deterministic simulated time: the caller says
// what time every access happens at.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hostmot2/cards/catalogue.hpp"
#include "hostmot2/dpll.hpp"
#include "hostmot2/idrom.hpp"
#include "hostmot2/inm.hpp"
#include "hostmot2/ioport.hpp"
#include "hostmot2/led.hpp"
#include "hostmot2/muxed_encoder.hpp"
#include "hostmot2/muxed_encoder_select.hpp"
#include "hostmot2/outm.hpp"
#include "hostmot2/pwmgen.hpp"
#include "hostmot2/sslbp.hpp"
#include "hostmot2/ssr.hpp"
#include "hostmot2/stepgen.hpp"
#include "hostmot2/watchdog.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"
#include "remote/seven_i76.hpp"

namespace lbpkit::model::hm2 {

// One 7I77 on a connector: its two LBP processors. Its six encoder inputs
// are the card's muxed counters (6 per 7I77).
struct SevenI77 {
  remote::FieldIoProcessor fieldIo;
  remote::AnalogProcessor analog;
  SevenI77(remote::FieldIoProcessor::Options io, remote::AnalogProcessor::Options an)
      : fieldIo(std::move(io)), analog(std::move(an)) {}
};

// Accesses nothing decodes, and writes a module refuses. The card counts
// them per kind and keeps the last few, so a driver developer can see that
// "hm2_eth wrote 0x00005A04 to 0x1234, which nothing decodes"; models do no
// I/O, so logging them is for whoever observes the card (setAccessObserver).
enum class AccessKind : std::uint8_t {
  UnmappedRead,    // no module answers there: reads 0
  UnmappedWrite,   // no module (or no register in a module's block) there: dropped
  ReadOnlyWrite,   // the ID area and IDROM (docs/protocol-facts.md#identification-area-and-idrom),
                   // or another read-only register: dropped
  IgnoredCommand,  // SSLBP COMMAND with bit 31 set (manual: COMMAND REGISTER WRITE IGNORE)
  LostCommand,     // SSLBP command written while one runs (manual: COMMAND REGISTER): lost
};
// "unmapped_read", "unmapped_write", "read_only_write", "ignored_command", "lost_command".
[[nodiscard]] std::string_view accessKindName(AccessKind kind);

struct AccessEvent {
  SimTime at{};
  std::uint16_t address = 0;  // as the host gave it
  std::uint32_t value = 0;    // the value written; 0 for a read
  AccessKind kind = AccessKind::UnmappedRead;
};

struct AccessCounters {
  std::uint64_t unmappedReads = 0;
  std::uint64_t unmappedWrites = 0;
  std::uint64_t readOnlyWrites = 0;
  std::uint64_t ignoredCommands = 0;
  std::uint64_t lostCommands = 0;
};

// The most recent events, oldest first (a fixed-size copy: no allocation).
struct RecentAccesses {
  static constexpr std::size_t kCapacity = 8;
  std::array<AccessEvent, kCapacity> events{};
  std::size_t size = 0;
  [[nodiscard]] const AccessEvent* begin() const { return events.data(); }
  [[nodiscard]] const AccessEvent* end() const { return events.data() + size; }
};

// Told of every event as it is counted, on the thread making the access and
// in the middle of it: it must not call back into the card, and should be
// quick (the daemon's card thread runs it). Events are rare by nature, but a
// driver that writes bit-31 COMMAND placeholders every cycle makes one a cycle.
using AccessObserver = void (*)(void* context, const AccessEvent& event);

class HostMot2Card {
 public:
  struct DaughterOptions {
    remote::FieldIoProcessor::Options fieldIo;
    remote::AnalogProcessor::Options analog;
  };
  // The firmware the FPGA runs: its IDROM (module list and pin functions).
  // SevenI77x2 is Mesa's two-7I77 firmware for 34-pin cards
  // (PIN_7I77x2_34.vhd, shipped as 7i92_7i77x2): 12 muxed encoders, 6
  // SSerial channels, the second 7I77's signals on IO17..33 whether or not
  // one is plugged in there (its channels then answer "no remote").
  // SevenI77Gpio is lbpkit's one 7I77 with 17 plain GPIO on IO17..33. The
  // others and which card has which: cards/catalogue.hpp, docs/cards.md.
  using Pinout = cards::Pinout;
  struct Options {
    // The card (nullptr: the 7I92) and its firmware (none: the card's
    // first, its default).
    const cards::Card* card = nullptr;
    std::optional<Pinout> pinout;
    // A 7I77 where the firmware has its first (always) and optionally where
    // it has a second (firmwares with two 7I77 slots only).
    DaughterOptions first;
    std::optional<DaughterOptions> second;
  };

  // Throws std::invalid_argument naming what the card or firmware lacks.
  explicit HostMot2Card(Options options);
  HostMot2Card() : HostMot2Card(Options{}) {}

  // --- The register file -------------------------------------------------------
  std::uint32_t read32(std::uint16_t address, SimTime now);
  void write32(std::uint16_t address, std::uint32_t value, SimTime now);
  // Let simulated time pass (watchdogs, encoders, SSLBP, remotes). Inline:
  // every access does it, and each part's advance() is a comparison or two
  // until something is due.
  void advance(SimTime now) {
    if (now < now_) now = now_;  // time never runs backwards
    now_ = now;
    // The modules whose state moves with time, in IDROM order (the others'
    // advance() does nothing).
    for (unsigned i = 0; i < timedCount_; ++i) timed_[i]->advance(now);
    for (auto& d : sevenI77s_) {
      d->fieldIo.advance(now);
      d->analog.advance(now);
    }
    if (sevenI76_) sevenI76_->advance(now);
  }
  // Switch the machine off and on at `now`: every module back to its
  // power-up state (Module::reset()) and both processors of every 7I77
  // booted again, so their NV parameters become working values again
  // (manual: NON-VOLATILE FIELD I/O PARAMETERS). The IDROM, the world at the
  // terminals, the cables and the access counters stay.
  void powerCycle(SimTime now);
  // The FPGA loads its firmware again at `now` (mesaflash --reload asks the
  // card's LBP16 processor for it): every module back to its power-up state
  // as powerCycle() puts them, while the 7I77s, powered by the cable and by
  // field power, keep running. The firmware is the one it ran (the flash's
  // content is not read), the IDROM and the access counters stay.
  void reconfigure(SimTime now);

  // --- Modules and daughtercards --------------------------------------------------
  // The firmware's module of type T (a module class: its kKind's tag names
  // it), e.g. module<StepGen>(); nullptr when the firmware has none.
  template <typename T>
  [[nodiscard]] T* module() const {
    for (Module* m : modules_)
      if (m->kind().tag == T::kKind.tag) return static_cast<T*>(m);
    return nullptr;
  }
  // One every firmware here has (Watchdog, IoPort, MuxedEncoder,
  // Sslbp, Led): the card will not build without them.
  template <typename T>
  [[nodiscard]] T& part() const {
    T* m = module<T>();
    if (m == nullptr) throw std::logic_error("the firmware has no " + std::string(T::kKind.name));
    return *m;
  }
  // Whether StepGen `n`'s step output drives its pin: not while a
  // watchdog bite has left that pin an input (IoPort::released), so a
  // drive behind it sees no steps until the host sets the DDR again.
  [[nodiscard]] bool stepGenDriven(unsigned n) const;
  SevenI77& daughtercard(unsigned connector) { return *sevenI77s_.at(connector); }
  [[nodiscard]] unsigned daughtercards() const { return static_cast<unsigned>(sevenI77s_.size()); }
  // The 7I76's field I/O processor on the firmwares that carry a 7I76
  // (cards::sevenI76Channel); nullptr on the others.
  remote::SevenI76FieldIo* sevenI76() { return sevenI76_.get(); }
  [[nodiscard]] Pinout pinout() const { return firmware_->pinout; }
  [[nodiscard]] const cards::Card& description() const { return *card_; }
  [[nodiscard]] const cards::Firmware& firmware() const { return *firmware_; }
  [[nodiscard]] const BoardIdentity& board() const { return card_->idrom; }
  // The firmware's modules in IDROM order.
  [[nodiscard]] std::span<Module* const> modules() const { return modules_; }
  // The first module with this IDROM tag; nullptr when the firmware has none.
  [[nodiscard]] Module* module(std::uint8_t gtag) const;
  [[nodiscard]] const std::array<std::uint32_t, idrom::kWords>& idromWords() const { return idrom_; }
  [[nodiscard]] std::vector<ModuleDescriptor> moduleDescriptors() const;
  [[nodiscard]] SimTime now() const { return now_; }

  // Accesses no module answers and writes a module refuses (AccessKind).
  [[nodiscard]] const AccessCounters& accessCounters() const { return access_; }
  [[nodiscard]] RecentAccesses recentAccesses() const;
  // Set up before the card runs (not thread-safe against accesses); nullptr
  // removes it.
  void setAccessObserver(AccessObserver observer, void* context) {
    observer_ = observer;
    observerContext_ = context;
  }
  // Reads no module answers (they give 0), and writes that changed nothing
  // because nothing writable is there: holes and read-only registers.
  [[nodiscard]] std::uint64_t unmappedReads() const { return access_.unmappedReads; }
  [[nodiscard]] std::uint64_t unmappedWrites() const { return access_.unmappedWrites + access_.readOnlyWrites; }

 private:
  Module* moduleAt(std::uint16_t address);
  void noteAccess(AccessKind kind, std::uint16_t address, std::uint32_t value);

  void build(const cards::ModuleEntry& entry);

  Options options_;
  const cards::Card* card_;
  const cards::Firmware* firmware_;
  std::vector<std::unique_ptr<SevenI77>> sevenI77s_;
  std::unique_ptr<remote::SevenI76FieldIo> sevenI76_;
  // Each StepGen's step pin (its pin descriptor's index), from the firmware's
  // pin descriptors; -1 where it has none.
  std::vector<int> stepPins_;
  std::vector<std::unique_ptr<Module>> owned_;  // the firmware's modules
  // The modules whose state moves with time, IDROM order.
  std::array<Module*, 16> timed_{};
  unsigned timedCount_ = 0;
  std::vector<Module*> modules_;  // IDROM order
  std::array<Module*, 256> byBlock_{};  // address >> 8 -> module
  // Which registers byBlock_'s module decodes: bit (address & 0xFF) / 4 of
  // decoded_[address >> 8] (the modules' decodes(), asked once), and what
  // the map says of each block's register (read-only, write-only).
  std::array<std::uint64_t, 256> decoded_{};
  std::array<map::Access, 256> blockAccess_{};
  std::array<std::uint32_t, idrom::kWords> idrom_{};
  AccessCounters access_;
  std::array<AccessEvent, RecentAccesses::kCapacity> recent_{};  // a ring
  std::uint64_t events_ = 0;  // ever noted; the next goes to recent_[events_ % kCapacity]
  AccessObserver observer_ = nullptr;
  void* observerContext_ = nullptr;
  SimTime now_{};
};

}  // namespace lbpkit::model::hm2
