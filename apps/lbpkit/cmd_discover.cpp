// SPDX-License-Identifier: MIT
// lbpkit discover: every smart-serial remote, its modes and process data.
#include <fmt/core.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "lbpkit/faults.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct DiscoverOptions {
  app::CardOptions card;
  bool json = false;
};

nlohmann::json elementJson(const lbpkit::ProcessDataElement& e) {
  nlohmann::json j{{"name", e.name},
                   {"unit", e.unit},
                   {"type", lbpkit::typeName(e.type)},
                   {"direction", lbpkit::directionName(e.direction)},
                   {"bits", e.bits},
                   {"address", fmt::format("0x{:04X}", e.address)}};
  if (e.numeric() || e.type == lbpkit::DataType::Encoder) {
    j["min"] = e.min;
    j["max"] = e.max;
  }
  return j;
}

int runDiscover(const DiscoverOptions& o) {
  auto card = app::openCard(o.card);
  const auto options = o.card.serialOptions();
  lbpkit::SmartSerial ss(*card.transport, card.info, options);
  const auto exchanges0 = card.transport->exchanges();
  const auto found = ss.discover(options.channelMask);
  const auto& stats = ss.discoveryStats();

  nlohmann::json out;
  out["card"] = card.info.boardName;
  out["transport"] = card.transport->describe();
  unsigned bytewise = 0;
  for (unsigned s = 0; s < ss.slots(); ++s) bytewise += ss.description(s).bytewiseReads();
  out["discovery"] = {{"doits", stats.doits},
                      {"bytewise_doits", bytewise},
                      {"time_ms", std::chrono::duration<double, std::milli>(stats.time).count()},
                      {"exchanges", card.transport->exchanges() - exchanges0}};
  out["channels"] = nlohmann::json::array();
  unsigned slot = 0;
  for (const auto& id : found) {
    nlohmann::json c{{"channel", id.channel}, {"present", id.present}, {"mode", options.modes[id.channel]}};
    if (id.present) {
      const auto& d = ss.description(slot++);
      c["name"] = id.name;
      c["function"] = id.function();
      c["unit_number"] = fmt::format("0x{:08X}", id.unitNumber);
      c["ptoc"] = fmt::format("0x{:04X}", id.ptoc);
      c["gtoc"] = fmt::format("0x{:04X}", id.gtoc);
      c["rx_bytes"] = d.rxBytes();
      c["tx_bytes"] = d.txBytes();
      c["modes"] = nlohmann::json::array();
      for (const auto& m : d.modes)
        c["modes"].push_back({{"index", m.index}, {"type", m.type == 0 ? "hardware" : "software"}, {"name", m.name}});
      c["process_data"] = nlohmann::json::array();
      for (const auto& e : d.processData) c["process_data"].push_back(elementJson(e));
      c["parameters"] = nlohmann::json::array();
      for (const auto& e : d.parameters) c["parameters"].push_back(elementJson(e));
    } else {
      c["status"] = lbpkit::describeCs(id.cs);
    }
    out["channels"].push_back(c);
  }
  if (o.json) {
    fmt::print("{}\n", out.dump(2));
    return 0;
  }
  fmt::print("{} ({}): discovery took {} DOITs ({} at one byte per DOIT), {:.1f} ms\n", card.info.boardName,
             card.transport->describe(), stats.doits, bytewise,
             std::chrono::duration<double, std::milli>(stats.time).count());
  slot = 0;
  for (const auto& id : found) {
    if (!id.present) {
      fmt::print("channel {}: no remote ({})\n", id.channel, lbpkit::describeCs(id.cs));
      continue;
    }
    const auto& d = ss.description(slot++);
    fmt::print("channel {}: {} {} unit 0x{:08X}, mode {}, {} bytes in, {} out\n", id.channel, id.name, id.function(),
               id.unitNumber, options.modes[id.channel], d.rxBytes(), d.txBytes());
    for (const auto& m : d.modes)
      fmt::print("  {} mode {}: {}\n", m.type == 0 ? "hardware" : "software", m.index, m.name);
    for (const auto& e : d.processData)
      fmt::print("  pd    {:<14} {:<3} {:>2} bits {:<8} {:>8} .. {:<8} {}\n", e.name, lbpkit::directionName(e.direction),
                 e.bits, lbpkit::typeName(e.type), e.min, e.max, e.unit);
    for (const auto& e : d.parameters)
      fmt::print("  param {:<18} {:<3} {:>2} bits {:<16} {}\n", e.name, lbpkit::directionName(e.direction), e.bits,
                 lbpkit::typeName(e.type), e.unit);
  }
  return 0;
}

}  // namespace

void addDiscoverCommand(CLI::App& app) {
  auto o = std::make_shared<DiscoverOptions>();
  auto* cmd = app.add_subcommand("discover", "Start the smart-serial channels in setup mode and list every remote's "
                                             "modes, process data and parameters");
  o->card.add(*cmd);
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->callback([o] { app::gRun = [o] { return runDiscover(*o); }; });
}
