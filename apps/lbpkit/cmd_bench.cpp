// SPDX-License-Identifier: MIT
// lbpkit bench: the performance figures on the machine at hand, each
// beside what it is compared against in the same run (bench.hpp).
#include <fmt/core.h>

#include <functional>
#include <set>
#include <sstream>

#include "bench.hpp"
#include "common.hpp"
#include "lbpkit/error.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct BenchCommand {
  app::bench::Options options;
  std::string only = "inprocess,network,replies,discovery,boards";
  std::string rates = "1000,2000,4000,10000";
  std::string boards = "1,10,50";
};

std::vector<std::string> list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<unsigned> numbers(const std::string& text, const char* option, unsigned low, unsigned high) {
  std::vector<unsigned> out;
  for (const auto& item : list(text)) {
    if (item.find_first_not_of("0123456789") != std::string::npos || item.size() > 6)
      throw lbpkit::Error(fmt::format("{}: \"{}\" is not a whole number", option, item));
    const auto v = static_cast<unsigned>(std::stoul(item));
    if (v < low || v > high) throw lbpkit::Error(fmt::format("{}: {} is outside {}..{}", option, v, low, high));
    out.push_back(v);
  }
  if (out.empty()) throw lbpkit::Error(fmt::format("{}: give at least one number", option));
  return out;
}

int runBench(BenchCommand& c) {
  static const std::vector<std::string> kParts = {"inprocess", "network", "replies", "discovery", "boards"};
  std::set<std::string> parts;
  for (const auto& p : list(c.only)) {
    if (std::find(kParts.begin(), kParts.end(), p) == kParts.end())
      throw lbpkit::Error(fmt::format("--only: \"{}\" is not a part (inprocess, network, replies, discovery, boards)", p));
    parts.insert(p);
  }
  if (parts.empty()) throw lbpkit::Error("--only: name at least one part");
  if (!(c.options.seconds > 0) || c.options.seconds > 3600) throw lbpkit::Error("--seconds: above 0, at most 3600");
  c.options.rates = numbers(c.rates, "--rates", 100, 20000);
  c.options.boards = numbers(c.boards, "--boards", 1, 1000);
  app::installSignalHandlers();

  nlohmann::json out;
  out["machine"] = app::bench::machine();
  out["seconds"] = c.options.seconds;
  if (!c.options.json) {
    const auto& m = out["machine"];
    fmt::print("lbpkit bench: {} ({} CPUs), {}, load average {:.2f} at start{}\n\n", m["cpu"].get<std::string>(),
               m["cpus"].get<unsigned>(), m["kernel"].get<std::string>(), m["load_average"].get<double>(),
               m["root"].get<bool>() ? "" : "; not root: the LinuxCNC parts are skipped");
    std::fflush(stdout);
  }
  struct Part {
    const char* name;
    std::function<nlohmann::json(const app::bench::Options&)> run;
    std::function<void(const nlohmann::json&)> print;
  };
  const Part all[] = {{"inprocess", app::bench::runInProcess, app::bench::printInProcess},
                      {"network", app::bench::runNetwork, app::bench::printNetwork},
                      {"replies", app::bench::runReplies, app::bench::printReplies},
                      {"discovery", app::bench::runDiscovery, app::bench::printDiscovery},
                      {"boards", app::bench::runBoards, app::bench::printBoards}};
  for (const auto& part : all) {
    if (parts.count(part.name) == 0) continue;
    out[part.name] = part.run(c.options);
    if (!c.options.json) {
      part.print(out[part.name]);
      std::fflush(stdout);
    }
  }
  out["machine"]["load_average_at_end"] = app::bench::loadAverage();
  if (c.options.json) fmt::print("{}\n", out.dump(2));
  else fmt::print("load average {:.2f} at end\n", out["machine"]["load_average_at_end"].get<double>());
  return 0;
}

}  // namespace

void addBenchCommand(CLI::App& app) {
  auto c = std::make_shared<BenchCommand>();
  auto* cmd = app.add_subcommand(
      "bench", "Measure the performance figures on this machine, each beside its comparison: in process, "
               "LinuxCNC on the network (root), replies beside an echo server, discovery (root), many boards");
  cmd->add_option("--only", c->only, "Parts to run, comma-separated: inprocess, network, replies, discovery, boards")
      ->capture_default_str();
  cmd->add_option("--seconds", c->options.seconds,
                  "Seconds per measured point (in process: simulated seconds per row)")
      ->capture_default_str();
  cmd->add_option("--rates", c->rates, "network: the LinuxCNC servo thread's rates, Hz")->capture_default_str();
  cmd->add_option("--boards", c->boards, "boards: how many sims side by side, per point")->capture_default_str();
  cmd->add_option("--cpu-latency", c->options.cpuLatencyUs,
                  "replies, network at 1 kHz: rows with the sim holding the CPUs' wake-up latency at this many us "
                  "(lbpkit sim --cpu-latency, root); -1: none")
      ->check(CLI::Range(-1, 100000))
      ->capture_default_str();
  cmd->add_flag("--json", c->options.json, "Machine-readable output");
  cmd->callback([c] { app::gRun = [c] { return runBench(*c); }; });
}
