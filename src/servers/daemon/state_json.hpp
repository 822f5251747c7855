// SPDX-License-Identifier: MIT
// GET /api/state: the models' observable state as JSON.
//
// The models expose what can be observed as plain State structs next to
// their registers; the daemon collects them into a SimState on the card
// thread, and this is the only code that knows how they look in JSON. The
// keys and values are an interface (tests, scripts and docs/control-api.md use them):
// add keys, never rename or reshape one.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hostmot2/card.hpp"
#include "hostmot2/ioport.hpp"
#include "hostmot2/muxed_encoder.hpp"
#include "hostmot2/sslbp.hpp"
#include "hostmot2/watchdog.hpp"
#include "lbp16/lbp16_card.hpp"
#include "machine/machine.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"
#include "remote/seven_i76.hpp"

namespace lbpkit::server {

// Everything GET /api/state shows, taken at one simulated instant.
struct SimState {
  model::lbp::SimTime time{};
  struct Clock {
    double speed = 1.0;
    bool paused = false;
    // How far simulated time has fallen behind the wall clock in all, and
    // how many times, because the card could not keep up.
    model::lbp::SimTime behind{0};
    std::uint64_t slips = 0;
    // `--clock host`: time moves a period per host cycle (sim_clock.hpp);
    // driven: it does right now (not paused, the period known, the host not
    // silent beyond the bound); silences: returns after such a silence;
    // cyclesLeft: times the host left its cycle for another command;
    // heldBack: how long (and how often) the card thread itself was held
    // back while a host drove time, which no silence counts; runningHolds:
    // silences beyond the bound held because the host's process was seen
    // runnable (late, not stopped), and hostPid that process (0: not found).
    bool host = false;
    model::lbp::SimTime period{0};
    bool driven = false;
    std::uint64_t hostCycles = 0;
    std::uint64_t silences = 0;
    std::chrono::nanoseconds heldBack{0};
    std::uint64_t heldBackTimes = 0;
    std::uint64_t cyclesLeft = 0;
    std::uint64_t runningHolds = 0;
    int hostPid = 0;
  } clock;
  // Who the card says it is on the network, and where it listens.
  struct Card {
    std::string name;
    std::string address;
    std::uint16_t port = 0;
    std::array<std::uint8_t, 6> mac{};
    // The Ethernet EEPROM as it now holds them (mesaflash writes them; the
    // card goes by them after its next power-up).
    Lbp16Card::Eeprom eeprom;
  } card;
  Lbp16Card::Counters lbp16;
  // The UDP server's own figures: server-side time per datagram.
  struct Server {
    std::uint64_t datagrams = 0;
    std::string scheduling;
    double medianUs = 0;
    double p99Us = 0;
    double maxUs = 0;
    // Of that, the time datagrams waited in the socket before being read.
    double queueMedianUs = 0;
    double queueP99Us = 0;
    double queueMaxUs = 0;
    // For `lbpkit bench`: the 99.9th percentiles, and how many
    // datagrams took at least each of kAtLeastUs (hm2_eth's read timeout, 80 %
    // of its period, at 10, 4, 2 and 1 kHz).
    static constexpr std::array<unsigned, 4> kAtLeastUs{80, 200, 400, 800};
    double p999Us = 0;
    double queueP999Us = 0;
    std::array<std::uint64_t, kAtLeastUs.size()> atLeast{};
  } server;
  model::hm2::Watchdog::State watchdog;
  model::hm2::Led::State cardLeds;
  model::hm2::Sslbp::State sserial;
  // Register accesses the card did not carry out, per kind.
  model::hm2::AccessCounters accessCounters;
  // One 7I77 and the card's muxed encoder counters for its connector
  // (counters 6d..6d+5 for connector d, as HostMot2Card lays them out).
  static constexpr unsigned kEncodersPerDaughtercard = 6;
  struct Daughtercard {
    model::remote::FieldIoProcessor::State fieldIo;
    model::remote::AnalogProcessor::State analog;
    std::array<model::hm2::MuxedEncoder::State::Counter, kEncodersPerDaughtercard> encoders{};
  };
  std::vector<Daughtercard> daughtercards;
  // The 7I76 on the 7I77+7I76 firmwares: its field I/O
  // processor, on SSerial channel `channel`, the card's connector
  // `connector` (IO17..33: PIN_7I77_7I76_34.vhd). Listed after the 7I77s in
  // "daughtercards", with "type": "7I76".
  struct SevenI76 {
    static constexpr unsigned kConnector = 1;  // IO17..33
    unsigned connector = kConnector;
    std::string connectorName;  // as mesaflash names it ("P1" on a 7I92)
    unsigned channel = 3;
    model::remote::SevenI76FieldIo::State fieldIo;
  };
  std::optional<SevenI76> sevenI76;
  // The machine behind connector 0's 7I77 (`lbpkit sim --machine`), if any.
  std::optional<model::machine::Machine::State> machine;
};

// Each part as it appears under its key in GET /api/state.
nlohmann::json toJson(const model::hm2::Watchdog::State& s);
nlohmann::json toJson(const model::hm2::Sslbp::State& s);
nlohmann::json toJson(const model::hm2::MuxedEncoder::State::Counter& s);
nlohmann::json toJson(const model::remote::FieldIoProcessor::State& s);
nlohmann::json toJson(const model::remote::AnalogProcessor::State& s);
nlohmann::json toJson(const Lbp16Card::Counters& s);
nlohmann::json toJson(const model::hm2::AccessCounters& s);
nlohmann::json toJson(const SimState::Server& s);
// A daughtercard on connector `connector`, with its LEDs.
nlohmann::json toJson(const SimState::Daughtercard& s, unsigned connector);
// The 7I76: its inputs, outputs, field voltage and spindle interface.
nlohmann::json toJson(const SimState::SevenI76& s);
// The remote fault byte as the names of its set bits, lowest bit first.
nlohmann::json faultNames(std::uint8_t faults);
// GET /api/machine (and "machine" in GET /api/state): axes with their
// drives and switches, spindle, E-stop chain, probe, switches, outputs.
nlohmann::json toJson(const model::machine::Machine::State& s);
nlohmann::json toJson(const model::machine::Switches::State& s);

// The whole document.
nlohmann::json toJson(const SimState& s);
std::string stateJson(const SimState& s);

}  // namespace lbpkit::server
