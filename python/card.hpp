// SPDX-License-Identifier: MIT
// What `lbpkit.Card` is to Python: the host library on one card, reached by
// LBP16 over UDP (a 7I92 and kin, or `lbpkit sim`) or in process (the
// virtual 7I92 + 7I77 of lbpkit::SimTransport, optionally with a machine
// behind its terminals). Discovery, parameters by name (RPD/WPD), the
// normal-mode cycle with process data by name, and the card's encoders.
//
// One servo period per cycle(): the exchange, then the rest of `period` is
// let pass, in simulated time in process (the card and the machine in
// lockstep: deterministic, no wall clock) and on the steady clock over the
// network, so a Python loop of cycle() is a servo thread either way.
//
// Not thread-safe, as the host library is not: every call takes the card's
// lock or fails saying it is busy (run() holds it without the GIL).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "lbpkit/encoders.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/transport.hpp"
#include "machine/machine.hpp"
#include "sim_card/sim_transport.hpp"

namespace pylbpkit {

// A process data value as Python sees it: BOOLEAN elements as bool, bit
// fields and other raw types as int (signed ones sign-extended), numeric
// ones with a range (NUMERIC PROCESS DATA SCALING) as float in their unit.
using Value = std::variant<bool, std::int64_t, std::uint64_t, double>;
// What a caller may give: an int for a numeric element is a number too.
using Input = std::variant<bool, std::int64_t, double>;

class Card {
 public:
  struct SimOptions {
    std::string machine;      // "" (none), "mill", "lathe", "gantry" or a machine file
    unsigned daughtercards = 1;  // 7I77s (1 or 2)
    bool sinking = false;        // 7I77D
    std::string state;           // EEPROM file of the first 7I77's field I/O processor ("" : in memory)
    double fieldVoltage = 24.0;
    std::string card;    // "" : the 7I92; "7I92T" (7I77+7I76 firmware by default), ...: lbpkit sim --card
    std::string pinout;  // "" : the card's default firmware; "7I77+7I76", ...: as the sim's TOML `pinout`
  };

  // LBP16 over UDP; `timeout`: how long set-up waits for a reply (seconds).
  static std::shared_ptr<Card> openNetwork(const std::string& address, std::uint16_t port, double timeout);
  static std::shared_ptr<Card> openSim(const SimOptions& options);

  // --- What the card is ---------------------------------------------------------
  [[nodiscard]] const lbpkit::CardInfo& info() const { return info_; }
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] bool inProcess() const { return sim_ != nullptr; }
  // Time as the card sees it, in seconds (simulated in process).
  [[nodiscard]] double time();

  // --- Smart serial -----------------------------------------------------------------
  // STOP ALL, setup START and discovery of the remotes on `channels` (all
  // the card's when empty), each in its mode from `modes` (as `--modes`: a
  // digit per channel from 0, x to skip one). The channels stay in setup
  // mode until start().
  std::vector<lbpkit::ChannelIdentity> discover(const std::vector<unsigned>& channels, const std::string& modes);
  [[nodiscard]] std::vector<unsigned> channels() const;  // discovered remotes' channels
  [[nodiscard]] const lbpkit::RemoteDescription& description(unsigned channel) const;
  [[nodiscard]] const lbpkit::ChannelIdentity& identity(unsigned channel) const;
  // Normal START of the discovered remotes (discovering first if needed),
  // and the encoders' set-up: cycles may run.
  void start();
  [[nodiscard]] bool running() const { return mode_ == Mode::Normal; }

  // --- Parameters (RPD/WPD: setup mode) -----------------------------------------------
  // A running card is stopped for it and started again, outputs kept. A
  // non-volatile parameter written counts only once the EEPROM has it, and
  // takes effect at the next power-up (manual: NON-VOLATILE FIELD I/O PARAMETERS).
  Value readParameter(const std::string& name, std::optional<unsigned> channel);
  void writeParameter(const std::string& name, const Input& value, std::optional<unsigned> channel);

  // --- The cycle ----------------------------------------------------------------------
  void set(const std::string& name, const Input& value, std::optional<unsigned> channel);
  void setBit(const std::string& name, unsigned bit, bool on, std::optional<unsigned> channel);
  [[nodiscard]] Value get(const std::string& name, std::optional<unsigned> channel) const;
  [[nodiscard]] bool bit(const std::string& name, unsigned bit, std::optional<unsigned> channel) const;
  // One servo period (see the top of this file).
  lbpkit::CycleStatus cycle();
  // `cycles` of them; the caller has released the GIL. `interrupted` is
  // asked every 1000 cycles (Ctrl-C): true stops the run.
  template <typename Interrupted>
  lbpkit::CycleStatus run(std::uint64_t cycles, Interrupted&& interrupted) {
    lbpkit::CycleStatus last;
    for (std::uint64_t n = 0; n < cycles; ++n) {
      if (n % 1000 == 999 && interrupted()) break;
      last = cycleLocked();
    }
    return last;
  }
  [[nodiscard]] double period() const;
  void setPeriod(double seconds);
  [[nodiscard]] std::uint64_t cycles() const { return ss_ ? ss_->cycles() : 0; }
  [[nodiscard]] std::uint64_t lostCycles() const { return ss_ ? ss_->lostCycles() : 0; }
  [[nodiscard]] std::uint32_t cs(unsigned channel) const;
  [[nodiscard]] std::uint8_t remoteFaults(unsigned channel) const;
  [[nodiscard]] std::uint32_t faultCount(unsigned channel) const;
  bool recover(unsigned channel);

  // --- Encoders (the card's muxed counters) ---------------------------------------------
  [[nodiscard]] unsigned encoders() const { return enc_ ? enc_->size() : 0; }
  [[nodiscard]] std::int64_t encoderCounts(unsigned n) const;
  [[nodiscard]] double encoderPosition(unsigned n) const;
  [[nodiscard]] double encoderVelocity(unsigned n) const;
  void setEncoderScale(unsigned n, double countsPerUnit);
  void enableIndex(unsigned n);
  [[nodiscard]] bool indexEnabled(unsigned n) const;

  // --- HostMot2 registers (any card): the raw 32-bit accesses LinuxCNC's
  // hostmot2 makes, e.g. a StepGen's rate (its base from modules).
  [[nodiscard]] std::uint32_t read32(std::uint16_t address);
  void write32(std::uint16_t address, std::uint32_t value);

  // --- In process only ------------------------------------------------------------------
  // The virtual card; throws lbpkit::Error on a card on the network.
  lbpkit::model::hm2::HostMot2Card& board();
  // The machine behind it, or nullptr.
  lbpkit::model::machine::Machine* machine() { return machine_.get(); }
  // Let `seconds` of simulated time pass with no host access (the card and
  // the machine in lockstep).
  void step(double seconds);
  // VIN off and on: every module and processor at power-up; discover() and
  // start() again.
  void powerCycle();

  // The card's lock: every call from Python holds it (see the top).
  std::unique_lock<std::mutex> lock();

  // cycle() without the lock (run() holds it).
  lbpkit::CycleStatus cycleLocked();

 private:
  enum class Mode : std::uint8_t { Idle, Setup, Normal };
  Card() = default;
  void requireRunning(const char* what) const;
  void requireSim(const char* what) const;
  [[nodiscard]] unsigned slotOf(unsigned channel) const;
  // The element `name` on `channel` (or the one remote that has it).
  [[nodiscard]] lbpkit::ElementRef element(const std::string& name, std::optional<unsigned> channel) const;
  [[nodiscard]] const lbpkit::ProcessDataElement& processData(lbpkit::ElementRef e) const;
  // A parameter's channel and element (parameters then process data).
  std::pair<unsigned, const lbpkit::ProcessDataElement*> parameter(const std::string& name,
                                                                   std::optional<unsigned> channel) const;
  // Runs `work` on a setup-mode RemoteAccess to `channel`, restarting a
  // running card afterwards.
  template <typename Work>
  auto withRemote(unsigned channel, Work&& work);
  // Simulated time to `until`: the machine a step ahead of the card, as the
  // daemon does (machine/machine.hpp).
  void advanceTo(lbpkit::Nanoseconds until);
  // The host's set-up accesses (discovery, parameters) advance the card
  // without the machine: it is brought up to the card's time, with the
  // terminals as they were, before anything changes them (the next
  // cycle's outputs) and before time is let pass.
  void catchUpMachine();
  void checkEncoder(unsigned n) const;

  std::unique_ptr<lbpkit::Transport> transport_;
  lbpkit::SimTransport* sim_ = nullptr;
  std::unique_ptr<lbpkit::model::machine::Machine> machine_;
  lbpkit::CardInfo info_;
  lbpkit::SmartSerial::Options serialOptions_;
  std::unique_ptr<lbpkit::SmartSerial> ss_;
  std::unique_ptr<lbpkit::MuxedEncoders> enc_;
  Mode mode_ = Mode::Idle;
  // Lower-case name -> the elements of that name (one per channel).
  std::map<std::string, std::vector<lbpkit::ElementRef>> byName_;
  lbpkit::Nanoseconds period_ = std::chrono::milliseconds(1);
  std::mutex mutex_;
};

}  // namespace pylbpkit
