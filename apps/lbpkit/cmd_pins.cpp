// SPDX-License-Identifier: MIT
// lbpkit pins: the HAL pins and parameters LinuxCNC's hostmot2 driver will
// create for this card and its remotes in the configured modes.
#include <fmt/core.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "hal_card.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/lbp16_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace hm2 = lbpkit::model::hm2;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct PinsOptions {
  app::CardOptions card;
  std::string config = "sserial_port_0=00000000";
  unsigned sevenI77s = 1;
  std::string cardName;  // --card: the in-process card of the catalogue
  std::string pinout;    // --pinout: its firmware
  bool json = false;
  bool params = true;
  bool pins = true;
};

int runPins(const PinsOptions& o) {
  std::vector<std::string> problems;
  const auto config = lbpkit::linuxcnc::parseHm2Config(o.config, &problems);
  if (!problems.empty()) throw lbpkit::Error("--config: " + problems.front());
  if (!o.card.modes.empty()) throw lbpkit::Error("--modes: give the modes in --config as sserial_port_0=... (as LinuxCNC)");
  lbpkit::CardInfo info;
  std::vector<lbpkit::linuxcnc::Remote> remotes;
  std::string halName;
  if (!o.card.addr.empty()) {
    if (o.sevenI77s != 1) throw lbpkit::Error("--7i77s is for the in-process card: a card on the network is what it is");
    if (!o.cardName.empty() || !o.pinout.empty())
      throw lbpkit::Error("--card and --pinout are for the in-process card: a card on the network is what it is");
    auto card = app::openCard(o.card);
    info = card.info;
    // hm2_eth names the board from its LBP16 board name, not the IDROM's.
    if (auto* lbp16 = dynamic_cast<lbpkit::Lbp16Transport*>(card.transport.get()))
      halName = lbpkit::linuxcnc::hm2EthBoardName(lbp16->boardName());
    remotes = app::discoverRemotes(*card.transport, info, config);
  } else {
    const auto [c, firmware] = app::catalogueChoice(o.cardName, o.pinout);
    if (o.sevenI77s < 1 || o.sevenI77s > firmware->sevenI77s.size())
      throw lbpkit::Error(fmt::format("--7i77s: the {}'s {} firmware carries {} 7I77{}", c->name, firmware->name,
                                      firmware->sevenI77s.size() == 1 ? "one" : "1 or 2",
                                      firmware->sevenI77s.size() == 1 ? "" : "s"));
    auto card = app::virtualCard(*c, *firmware, o.sevenI77s, config);
    info = card.info;
    remotes = std::move(card.remotes);
    halName = card.halName;
  }
  const auto items = lbpkit::linuxcnc::hostmot2Items(info, config, remotes, lbpkit::linuxcnc::Driver::Eth, 0, halName);
  if (o.json) {
    nlohmann::json out;
    out["board"] = halName.empty() ? lbpkit::linuxcnc::boardPrefix(info) : lbpkit::linuxcnc::boardPrefix(halName, 0);
    out["config"] = o.config;
    out["pins"] = nlohmann::json::array();
    out["params"] = nlohmann::json::array();
    for (const auto& i : items) {
      nlohmann::json j{{"name", i.name}, {"type", lbpkit::linuxcnc::typeName(i.type)}, {"dir", lbpkit::linuxcnc::dirName(i.dir)},
                       {"origin", i.origin.text}};
      if (!i.alsoNamed.empty()) j["also_named"] = i.alsoNamed;
      out[i.kind == lbpkit::linuxcnc::Kind::Pin ? "pins" : "params"].push_back(j);
    }
    fmt::print("{}\n", out.dump(2));
    return 0;
  }
  for (const auto kind : {lbpkit::linuxcnc::Kind::Pin, lbpkit::linuxcnc::Kind::Param}) {
    if ((kind == lbpkit::linuxcnc::Kind::Pin && !o.pins) || (kind == lbpkit::linuxcnc::Kind::Param && !o.params)) continue;
    fmt::print("{}:\n", kind == lbpkit::linuxcnc::Kind::Pin ? "Pins" : "Parameters");
    for (const auto& i : items)
      if (i.kind == kind)
        fmt::print("  {:<5} {:<3}  {}\n", lbpkit::linuxcnc::typeName(i.type), lbpkit::linuxcnc::dirName(i.dir), i.name);
  }
  return 0;
}

}  // namespace

void addPinsCommand(CLI::App& app) {
  auto o = std::make_shared<PinsOptions>();
  auto* cmd = app.add_subcommand("pins", "List the HAL pins and parameters LinuxCNC's hostmot2 driver creates for the "
                                         "card and its smart-serial remotes (from the IDROM and each remote's "
                                         "discovery, in the configured modes)");
  o->card.add(*cmd);
  cmd->add_option("--config", o->config,
                  "hostmot2's config= string, e.g. \"num_encoders=6 sserial_port_0=00xxxx\" (default: every module, "
                  "every channel in mode 0)");
  cmd->add_option("--7i77s", o->sevenI77s,
                  "With the in-process card: how many 7I77s it carries (2 on a 7I77x2 firmware)");
  cmd->add_option("--card", o->cardName,
                  "With the in-process card: which card of the catalogue (" + hm2::cards::names() +
                      "; docs/cards.md), as lbpkit sim --card");
  cmd->add_option("--pinout", o->pinout, "With the in-process card: its firmware (default: the card's first)");
  cmd->add_flag("!--no-params", o->params, "Pins only");
  cmd->add_flag("!--no-pins", o->pins, "Parameters only");
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->callback([o] { app::gRun = [o] { return runPins(*o); }; });
}
