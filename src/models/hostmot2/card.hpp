// A 7I92-style HostMot2 Ethernet card with 7I77 daughtercards: the register
// file drivers see (over LBP16 on the real card), its modules, and the 7I77
// processors on its smart-serial channels. Deterministic simulated time: the
// caller says what time every access happens at.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "hostmot2/idrom.hpp"
#include "hostmot2/ioport.hpp"
#include "hostmot2/muxed_encoder.hpp"
#include "hostmot2/sslbp.hpp"
#include "hostmot2/watchdog.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

namespace hm2 {

// One 7I77 on a connector: its two LBP processors. Its six encoder inputs
// are the card's muxed counters (6 per 7I77).
struct SevenI77 {
  remote::FieldIoProcessor fieldIo;
  remote::AnalogProcessor analog;
  SevenI77(remote::FieldIoProcessor::Options io, remote::AnalogProcessor::Options an)
      : fieldIo(std::move(io)), analog(std::move(an)) {}
};

class HostMot2Card {
 public:
  struct DaughterOptions {
    remote::FieldIoProcessor::Options fieldIo;
    remote::AnalogProcessor::Options analog;
  };
  struct Options {
    BoardIdentity board;
    // A 7I77 on the first connector (IO0..16) always; on the second
    // (IO17..33) optionally, else those pins are plain GPIO.
    DaughterOptions first;
    std::optional<DaughterOptions> second;
  };

  explicit HostMot2Card(Options options);
  HostMot2Card() : HostMot2Card(Options{}) {}

  // --- The register file -------------------------------------------------------
  std::uint32_t read32(std::uint16_t address, SimTime now);
  void write32(std::uint16_t address, std::uint32_t value, SimTime now);
  // Let simulated time pass (watchdogs, encoders, SSLBP, remotes).
  void advance(SimTime now);

  // --- Parts -----------------------------------------------------------------------
  SmartSerial& smartSerial() { return *sserial_; }
  MuxedEncoder& encoders() { return *encoders_; }
  Watchdog& watchdog() { return *watchdog_; }
  IoPort& ioPort() { return *ioport_; }
  Led& led() { return *led_; }
  SevenI77& daughtercard(unsigned connector) { return *sevenI77s_.at(connector); }
  [[nodiscard]] unsigned daughtercards() const { return static_cast<unsigned>(sevenI77s_.size()); }
  [[nodiscard]] const BoardIdentity& board() const { return options_.board; }
  [[nodiscard]] const std::array<std::uint32_t, idrom::kWords>& idromWords() const { return idrom_; }
  [[nodiscard]] std::vector<ModuleDescriptor> moduleDescriptors() const;
  [[nodiscard]] SimTime now() const { return now_; }

  // Accesses no module answers: reads give 0, writes are dropped; counted.
  [[nodiscard]] std::uint64_t unmappedReads() const { return unmappedReads_; }
  [[nodiscard]] std::uint64_t unmappedWrites() const { return unmappedWrites_; }

 private:
  Module* moduleAt(std::uint16_t address);

  Options options_;
  std::vector<std::unique_ptr<SevenI77>> sevenI77s_;
  std::unique_ptr<Watchdog> watchdog_;
  std::unique_ptr<IoPort> ioport_;
  std::unique_ptr<MuxedEncoder> encoders_;
  std::unique_ptr<MuxedEncoderSelect> encoderSelect_;
  std::unique_ptr<SmartSerial> sserial_;
  std::unique_ptr<Led> led_;
  std::vector<Module*> modules_;  // IDROM order
  std::array<Module*, 256> byBlock_{};  // address >> 8 -> module
  std::array<std::uint32_t, idrom::kWords> idrom_{};
  std::uint64_t unmappedReads_ = 0;
  std::uint64_t unmappedWrites_ = 0;
  SimTime now_{};
};

}  // namespace hm2
