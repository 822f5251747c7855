// lbpkit check-config FILE.ini|FILE.hal: every hostmot2 pin and parameter a
// LinuxCNC configuration names, checked against what the driver will create
// (no LinuxCNC, no card, no root needed: the card's IDROM and its remotes'
// discovery come from the in-process virtual card).
#include <fmt/core.h>

#include <functional>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "hal/config_check.hpp"
#include "hal_card.hpp"

namespace app {
extern std::function<int()> gRun;
}

namespace {

struct CheckOptions {
  std::string file;
  bool json = false;
};

// The configuration with every channel it enables in mode `digit`.
lbpkit::hal::Hm2Config inMode(lbpkit::hal::Hm2Config c, char digit) {
  for (unsigned port = 0; port < 4; ++port) {
    std::string modes;
    for (unsigned ch = 0; ch < 8; ++ch) modes += c.mode(port, ch) == 'x' ? 'x' : digit;
    if (c.sserialPorts.count(port) || !c.sserialPortGiven) c.sserialPorts[port] = modes;
  }
  c.sserialPortGiven = true;
  return c;
}

// The boards lbpkit knows: the 7I92 it simulates, and the 5I25 and 6I25 PCI
// cards with Mesa's 7I77x2 firmware (PIN_7I77x2_34, the pinout the virtual
// 7I92 serves: the same modules on the same 34 IO pins).
bool model(lbpkit::hal::Board& b, const lbpkit::hal::Hm2Config& config, unsigned sevenI77s) {
  const auto dot = b.prefix.find('.');
  const auto kind = b.prefix.substr(4, dot - 4);
  unsigned index = 0;
  try {
    index = static_cast<unsigned>(std::stoul(b.prefix.substr(dot + 1)));
  } catch (const std::exception&) {
    b.description = "its name has no board number";
    return false;
  }
  std::string boardName;
  lbpkit::hal::Driver driver = lbpkit::hal::Driver::Eth;
  if (kind == "7i92") {
    boardName = "MESA7I92";
  } else if (kind == "5i25" || kind == "6i25") {
    boardName = kind == "5i25" ? "MESA5I25" : "MESA6I25";
    driver = lbpkit::hal::Driver::Pci;
  } else {
    b.description = "lbpkit knows the 7I92 (hm2_eth) and the 5I25 and 6I25 with the 7I77x2 firmware (hm2_pci)";
    return false;
  }
  auto items = [&](const lbpkit::hal::Hm2Config& c, std::string* description) {
    auto card = app::virtualCard(sevenI77s, c);
    card.info.boardName = boardName;
    if (description) {
      *description = boardName.substr(4) + (driver == lbpkit::hal::Driver::Pci ? " (7I77x2 firmware)" : "");
      for (const auto& r : card.remotes)
        if (c.mode(r.port, r.channel) != 'x')
          *description += fmt::format(", {} on channel {} (mode {})", r.name, r.channel, r.mode);
    }
    return lbpkit::hal::hostmot2Items(card.info, c, card.remotes, driver, index);
  };
  b.items = items(config, &b.description);
  for (char d = '0'; d <= '3'; ++d) b.itemsInMode[d] = items(inMode(config, d), nullptr);
  return true;
}

int runCheck(const CheckOptions& o) {
  const auto result = lbpkit::hal::checkConfig(o.file, model);
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
  cmd->callback([o] { app::gRun = [o] { return runCheck(*o); }; });
}
