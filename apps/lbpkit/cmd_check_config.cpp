// SPDX-License-Identifier: MIT
// lbpkit check-config FILE.ini|FILE.hal: every hostmot2 pin and parameter a
// LinuxCNC configuration names, checked against what the driver will create
// (no LinuxCNC, no card, no root needed: the card's IDROM and its remotes'
// discovery come from the in-process virtual card).
#include <fmt/core.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "linuxcnc/config_check.hpp"
#include "linuxcnc/hal_name.hpp"
#include "hal_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace hm2 = lbpkit::model::hm2;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct CheckOptions {
  std::string file;
  bool json = false;
  std::string card;    // --card: only this card of the catalogue
  std::string pinout;  // --pinout: only this firmware
};

// The configuration with every channel it enables in mode `digit`.
lbpkit::linuxcnc::Hm2Config inMode(lbpkit::linuxcnc::Hm2Config c, char digit) {
  for (unsigned port = 0; port < 4; ++port) {
    std::string modes;
    for (unsigned ch = 0; ch < 8; ++ch) modes += c.mode(port, ch) == 'x' ? 'x' : digit;
    if (c.sserialPorts.count(port) || !c.sserialPortGiven) c.sserialPorts[port] = modes;
  }
  c.sserialPortGiven = true;
  return c;
}

// What a board of the configuration may be. hm2_eth boards: every card of
// the catalogue with that LinuxCNC name (hm2_7i92: the 7I92 and the 7I92T),
// each firmware, in catalogue order (--card and --pinout narrow it down);
// hm2_pci: the 5I25 and 6I25 with Mesa's 7I77x2 firmware (PIN_7I77x2_34, the
// pinout of the 7I92's 7I77x2 firmware: the same modules on the same 34 IO
// pins).
std::vector<lbpkit::linuxcnc::Board> boardsOfCatalogue(const CheckOptions& o, const lbpkit::linuxcnc::Board& loaded,
                                                       const lbpkit::linuxcnc::Hm2Config& config, unsigned sevenI77s,
                                                       std::string& whyNot) {
  const auto name = lbpkit::linuxcnc::hal_name::parse(loaded.prefix);
  if (!name) {
    whyNot = "its name has no board number";
    return {};
  }
  const auto& kind = name->board;
  const unsigned index = name->index;
  struct Candidate {
    const hm2::cards::Card* card;
    const hm2::cards::Firmware* firmware;
  };
  std::vector<Candidate> candidates;
  std::string pciName;
  if (kind == "5i25" || kind == "6i25") {
    pciName = kind == "5i25" ? "5I25" : "6I25";
    const auto& card = hm2::cards::defaultCard();
    candidates.push_back({&card, hm2::cards::firmware(card, hm2::cards::Pinout::SevenI77x2)});
  } else {
    std::string known;
    for (const auto& card : hm2::cards::all()) {
      known += fmt::format("{}{} ({})", known.empty() ? "" : ", ", lbpkit::linuxcnc::boardPrefix(std::string(card.halName), 0),
                           card.name);
      if (card.halName != kind) continue;
      if (!o.card.empty() && hm2::cards::find(o.card) != &card) continue;
      for (const auto& firmware : card.firmwares)
        if (o.pinout.empty() || hm2::cards::firmware(card, o.pinout) == &firmware) candidates.push_back({&card, &firmware});
    }
    if (candidates.empty()) {
      whyNot = !o.card.empty() || !o.pinout.empty()
                   ? fmt::format("no card{}{} of the catalogue is {} (lbpkit knows {})",
                                 o.card.empty() ? "" : " " + o.card, o.pinout.empty() ? "" : " with firmware " + o.pinout,
                                 loaded.prefix, known)
                   : fmt::format("lbpkit knows {} (hm2_eth) and the 5I25 and 6I25 with the 7I77x2 firmware (hm2_pci)",
                                 known);
      return {};
    }
  }
  const auto driver = pciName.empty() ? lbpkit::linuxcnc::Driver::Eth : lbpkit::linuxcnc::Driver::Pci;
  std::vector<lbpkit::linuxcnc::Board> out;
  for (const auto& c : candidates) {
    auto items = [&](const lbpkit::linuxcnc::Hm2Config& hm2Config, lbpkit::linuxcnc::Board* board) {
      auto card = app::virtualCard(*c.card, *c.firmware, sevenI77s, hm2Config);
      if (!pciName.empty()) card.info.boardName = "MESA" + pciName;
      if (board) {
        board->model = fmt::format("{} ({} firmware)", pciName.empty() ? std::string(c.card->name) : pciName,
                                   c.firmware->name);
        board->description = board->model;
        board->modules = lbpkit::linuxcnc::moduleInstances(card.info);
        for (const auto& r : card.remotes)
          if (hm2Config.mode(r.port, r.channel) != 'x')
            board->description += fmt::format(", {} on channel {} (mode {})", r.name, r.channel, r.mode);
        board->loadProblems = lbpkit::linuxcnc::hm2CountProblems(card.info, hm2Config);
      }
      return lbpkit::linuxcnc::hostmot2Items(card.info, hm2Config, card.remotes, driver, index,
                                        pciName.empty() ? card.halName : std::string());
    };
    auto b = loaded;
    b.items = items(config, &b);
    for (char d = '0'; d <= '3'; ++d) b.itemsInMode[d] = items(inMode(config, d), nullptr);
    out.push_back(std::move(b));
  }
  return out;
}

int runCheck(const CheckOptions& o) {
  const auto result = lbpkit::linuxcnc::checkConfig(o.file, app::catalogueBoardModel(o.card, o.pinout));
  unsigned errors = 0, warnings = 0;
  for (const auto& f : result.findings) (f.severity == "error" ? errors : warnings)++;
  if (o.json) {
    nlohmann::json out;
    out["file"] = o.file;
    out["ok"] = result.ok();
    out["references"] = result.references;
    out["hal_files"] = result.files;
    out["boards"] = nlohmann::json::array();
    for (const auto& b : result.boards)
      out["boards"].push_back({{"board", b.prefix},
                               {"driver", b.driver},
                               {"config", b.config},
                               {"loaded_at", fmt::format("{}:{}", b.file, b.line)},
                               {"model", b.description},
                               {"candidates", b.candidates},
                               {"pins_and_params", b.items.size()}});
    out["findings"] = nlohmann::json::array();
    for (const auto& f : result.findings) {
      nlohmann::json j{{"file", f.file}, {"line", f.line}, {"severity", f.severity}, {"name", f.name}, {"reason", f.reason}};
      if (!f.suggestion.empty()) j["nearest"] = f.suggestion;
      out["findings"].push_back(j);
    }
    fmt::print("{}\n", out.dump(2));
    return result.ok() ? 0 : 1;
  }
  for (const auto& b : result.boards)
    fmt::print("{}: {} by {} config=\"{}\" ({}:{}): {}\n", o.file, b.prefix, b.driver, b.config, b.file, b.line,
               b.description);
  for (const auto& f : result.findings) {
    fmt::print("{}:{}: {}: {}\n", f.file, f.line, f.severity, f.reason);
    if (!f.suggestion.empty()) fmt::print("    nearest existing name: {}\n", f.suggestion);
  }
  fmt::print("{}: {} hostmot2 name{} checked in {} HAL file{}: {}\n", o.file, result.references,
             result.references == 1 ? "" : "s", result.files.size(), result.files.size() == 1 ? "" : "s",
             errors == 0 ? (warnings == 0 ? std::string("no problems")
                                          : fmt::format("no errors, {} warning{}", warnings, warnings == 1 ? "" : "s"))
                         : fmt::format("{} error{}, {} warning{}", errors, errors == 1 ? "" : "s", warnings,
                                       warnings == 1 ? "" : "s"));
  return result.ok() ? 0 : 1;
}

}  // namespace

void addCheckConfigCommand(CLI::App& app) {
  auto o = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand("check-config",
                                 "Check a LinuxCNC configuration (an .ini and its HAL files, or one .hal) against the "
                                 "hostmot2 pins and parameters the card will have; exit status 1 on a problem");
  cmd->add_option("file", o->file, "FILE.ini or FILE.hal")->required();
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->add_option("--card", o->card,
                  "The card the hm2_eth board is (" + hm2::cards::names() +
                      "; default: of the cards with the board's LinuxCNC name, the one whose firmware gives the "
                      "fewest errors)");
  cmd->add_option("--pinout", o->pinout, "Its firmware, as lbpkit sim's pinout (default: as --card)");
  cmd->callback([o] {
    if (!o->card.empty() && hm2::cards::find(o->card) == nullptr)
      throw CLI::ValidationError("--card", o->card + ": lbpkit knows " + hm2::cards::names());
    app::gRun = [o] { return runCheck(*o); };
  });
}

namespace lbpkit::app {
lbpkit::linuxcnc::BoardModel catalogueBoardModel(std::string card, std::string pinout) {
  return [o = CheckOptions{{}, false, std::move(card), std::move(pinout)}](
             const lbpkit::linuxcnc::Board& loaded, const lbpkit::linuxcnc::Hm2Config& config, unsigned sevenI77s,
             std::string& whyNot) { return boardsOfCatalogue(o, loaded, config, sevenI77s, whyNot); };
}
}  // namespace lbpkit::app
