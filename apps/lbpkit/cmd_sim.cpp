// lbpkit sim: a virtual 7I92 with 7I77s on the network (LBP16 over UDP),
// with an HTTP control API to watch the board and change its world.
#include <fmt/core.h>

#include <cctype>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include <toml++/toml.h>

#include "common.hpp"
#include "lbpkit/error.hpp"
#include "daemon/sim_daemon.hpp"
#include "remote/nv_store.hpp"
#include "remote/remote_device.hpp"

namespace app {
extern std::function<int()> gRun;
}

namespace {

struct SimCommandOptions {
  std::string bind = "127.0.0.1";
  std::string config;
  std::string state;
  std::string api = "127.0.0.1:27182";
  bool noApi = false;
  std::string logLevel = "info";
  double speed = 1.0;
  bool paused = false;
  bool noRealtime = false;
  bool demo = false;
};

int portNumber(const std::string& text, const char* what) {
  if (text.empty() || text.size() > 5 || text.find_first_not_of("0123456789") != std::string::npos ||
      std::stoul(text) > 65535)
    throw lbpkit::Error(fmt::format("{}: \"{}\" is not a port number (0..65535)", what, text));
  return static_cast<int>(std::stoul(text));
}

std::pair<std::string, int> hostPort(const std::string& text, int defaultPort, const char* what) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    // A bare number is a port (for --api), anything else an address.
    if (!text.empty() && text.find_first_not_of("0123456789") == std::string::npos) return {"127.0.0.1", portNumber(text, what)};
    return {text, defaultPort};
  }
  return {text.substr(0, colon), portNumber(text.substr(colon + 1), what)};
}

// The TOML configuration (see README): which daughtercards, field voltage,
// 7I77 or 7I77D, jumpers, unit numbers.
void loadConfig(const std::string& path, hm2::HostMot2Card::Options& card) {
  toml::table t;
  try {
    t = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw lbpkit::Error(fmt::format("{}: {} (line {})", path, e.description(), e.source().begin.line));
  }
  if (auto name = t["card"]["name"].value<std::string>(); name && *name != "7I92")
    throw lbpkit::Error(fmt::format("{}: card.name \"{}\": only the 7I92 is modelled", path, *name));
  const auto* boards = t["daughtercard"].as_array();
  if (!boards) return;
  if (boards->size() > 2) throw lbpkit::Error(fmt::format("{}: a 7I92 has two connectors, not {}", path, boards->size()));
  for (std::size_t i = 0; i < boards->size(); ++i) {
    const auto* b = boards->get(i)->as_table();
    if (!b) throw lbpkit::Error(fmt::format("{}: daughtercard {} is not a table", path, i));
    const auto where = fmt::format("{}: daughtercard {}", path, i);
    const auto type = (*b)["type"].value_or(std::string("7I77"));
    if (type == "none") {
      if (i == 0) throw lbpkit::Error(where + ": the first connector must carry a 7I77");
      continue;
    }
    if (type != "7I77" && type != "7I77D") throw lbpkit::Error(fmt::format("{}: type \"{}\": 7I77, 7I77D or none", where, type));
    hm2::HostMot2Card::DaughterOptions d;
    if (i == 1 && !card.first.fieldIo.nvFile.empty()) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile.string() + ".2";
      d.analog.nvFile = card.first.analog.nvFile.string() + ".2";
    }
    d.fieldIo.outputs = type == "7I77D" ? remote::OutputType::Sinking : remote::OutputType::Sourcing;
    d.fieldIo.fieldVoltage = (*b)["field_voltage"].value_or(24.0);
    const auto w1 = (*b)["w1"].value_or(std::string("field"));
    if (w1 != "field" && w1 != "separate") throw lbpkit::Error(where + ": w1 is \"field\" or \"separate\"");
    d.fieldIo.vinFromField = w1 == "field";
    d.fieldIo.vin = (*b)["vin"].value_or(24.0);
    d.fieldIo.setupMode = (*b)["w12_setup"].value_or(false);
    d.analog.setupMode = (*b)["w4_setup"].value_or(false);
    // Each board has its own serial number (the low 24 bits of both units).
    const std::int64_t serial = 0x000AEE + static_cast<std::int64_t>(i);
    d.fieldIo.unitNumber = static_cast<std::uint32_t>((*b)["field_io_unit"].value_or(0x12000000 + serial));
    d.analog.unitNumber = static_cast<std::uint32_t>((*b)["analog_unit"].value_or(0x11000000 + serial));
    if ((d.fieldIo.unitNumber >> 24) != 0x12 || (d.analog.unitNumber >> 24) != 0x11)
      throw lbpkit::Error(where + ": unit numbers of a 7I77 start with 0x12 (field I/O) and 0x11 (analog)");
    if (i == 0) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile;
      d.analog.nvFile = card.first.analog.nvFile;
      card.first = d;
    } else {
      card.second = d;
    }
  }
}

// The default EEPROM file: one per bind address, so that sims side by side
// never share one (two writers would lose each other's writes).
std::filesystem::path defaultStatePath(const std::string& host, int port) {
  std::string name = fmt::format("7i77-{}-{}.eeprom", host, port);
  for (auto& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
  const auto dir = app::defaultStateDir();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);  // lbpkit's own directory: created on first use
  const auto file = dir / name;
  // Earlier versions kept every sim's EEPROM in sim-7i77.eeprom: the sim on
  // the default address takes it over, so its saved parameters survive.
  const auto legacy = dir / "sim-7i77.eeprom";
  if (host == "127.0.0.1" && port == net::lbp16::kPort && !std::filesystem::exists(std::filesystem::symlink_status(file, ec)) &&
      std::filesystem::is_regular_file(std::filesystem::symlink_status(legacy, ec))) {
    std::filesystem::rename(legacy, file, ec);
    const auto legacyAnalog = legacy.string() + ".analog";
    if (!ec && std::filesystem::is_regular_file(std::filesystem::symlink_status(legacyAnalog, ec)))
      std::filesystem::rename(legacyAnalog, file.string() + ".analog", ec);
  }
  return file;
}

int runSim(const SimCommandOptions& o) {
  net::SimOptions s;
  const auto [bindHost, bindPort] = hostPort(o.bind, net::lbp16::kPort, "--bind");
  s.bindAddress = bindHost;
  s.port = static_cast<std::uint16_t>(bindPort);
  if (o.noApi) {
    s.apiPort = -1;
  } else {
    const auto [apiHost, apiPort] = hostPort(o.api, 27182, "--api");
    s.apiAddress = apiHost;
    s.apiPort = apiPort;
  }
  s.speed = o.speed;
  s.paused = o.paused;
  s.realtime = !o.noRealtime;
  s.demo = o.demo;
  if (!(o.speed > 0)) throw lbpkit::Error("--speed must be above 0");
  static const std::map<std::string, net::LogLevel> kLevels = {
      {"error", net::LogLevel::Error}, {"warn", net::LogLevel::Warn}, {"info", net::LogLevel::Info}, {"debug", net::LogLevel::Debug}};
  if (!kLevels.count(o.logLevel)) throw lbpkit::Error("--log-level: error, warn, info or debug");
  s.logLevel = kLevels.at(o.logLevel);
  // A --state FILE is taken as given: a missing directory is the user's
  // typo to hear about, not something to create (the store says so).
  const std::filesystem::path state = o.state.empty() ? defaultStatePath(bindHost, bindPort) : std::filesystem::path(o.state);
  s.card.first.fieldIo.nvFile = state;
  s.card.first.analog.nvFile = state.string() + ".analog";
  if (!o.config.empty()) {
    loadConfig(o.config, s.card);
    s.configDescription = o.config;
  } else {
    s.configDescription = "built-in default: a 7I92 with one 7I77, 24 V field power";
  }
  // What the EEPROM files say (models cannot log): every refused write is
  // logged, and so is a file that cannot be used.
  const auto owner = fmt::format("lbpkit sim on {}:{}{}", bindHost, bindPort, bindPort == 0 ? " (any free port)" : "");
  const bool warn = s.logLevel >= net::LogLevel::Warn;
  std::vector<std::filesystem::path> files;
  auto watch = [&](auto& processor, std::string what) {
    files.push_back(processor.nvFile);
    processor.nvOwner = owner;
    processor.nvReport = [what, warn](const remote::NvEvent& e) {
      using Kind = remote::NvEvent::Kind;
      const bool error = e.kind == Kind::Refused || e.kind == Kind::WriteFailed;
      if (!error && !warn) return;
      // fputs, not fmt::print: a log that cannot be written must not throw
      // out of the card thread.
      std::fputs(fmt::format("lbpkit sim: {}: {}: {}\n", error ? "error" : "warning", what, e.message).c_str(), stderr);
      std::fflush(stderr);
    };
  };
  watch(s.card.first.fieldIo, "connector 0 field I/O EEPROM");
  watch(s.card.first.analog, "connector 0 analog EEPROM");
  if (s.card.second) {
    watch(s.card.second->fieldIo, "connector 1 field I/O EEPROM");
    watch(s.card.second->analog, "connector 1 analog EEPROM");
  }
  // A file the sim will not use (not an EEPROM image, a symlink, held by
  // another sim, ...) stops it before it starts: the same checks the
  // processors make, made first so nothing is half started.
  for (const auto& file : files) {
    remote::NvStore probe(remote::memory::kEepromSize, file);
    probe.load();
    if (!probe.refusal().empty()) throw lbpkit::Error(probe.refusal());
  }
  net::SimDaemon daemon(s);
  app::installSignalHandlers();
  fmt::print("{}", daemon.banner());
  fmt::print("  point LinuxCNC at it: loadrt hm2_eth board_ip={} config=\"num_encoders=6 sserial_port_0=00xxxx\"\n",
             s.bindAddress);
  std::fflush(stdout);
  daemon.run(app::gStop);
  fmt::print("lbpkit sim: stopped; server time per datagram: {}\n", daemon.latencySummary());
  fmt::print("lbpkit sim: the 7I77's EEPROM state is in {}\n", state.string());
  return 0;
}

}  // namespace

void addSimCommand(CLI::App& app) {
  auto o = std::make_shared<SimCommandOptions>();
  auto* cmd = app.add_subcommand("sim", "Run a virtual 7I92 with a 7I77 on the network (LBP16, UDP port 27181)");
  cmd->add_option("--bind", o->bind, "ADDR[:PORT] to serve LBP16 on (127.0.0.1:27181 unless you say otherwise)")
      ->capture_default_str();
  cmd->add_option("--config", o->config, "TOML file: daughtercards, field voltage, 7I77 or 7I77D, jumpers, unit numbers");
  cmd->add_option("--state", o->state, "EEPROM file of the 7I77 (non-volatile parameters)");
  cmd->add_option("--api", o->api, "[ADDR:]PORT of the HTTP control API (0: any free port)")->capture_default_str();
  cmd->add_flag("--no-api", o->noApi, "No control API");
  cmd->add_option("--log-level", o->logLevel, "error, warn, info or debug")->capture_default_str();
  cmd->add_option("--speed", o->speed, "Simulated seconds per wall-clock second")->capture_default_str();
  cmd->add_flag("--demo", o->demo, "Demo world: field outputs 0..15 wired back to inputs 0..15, encoder 0 turning");
  cmd->add_flag("--no-realtime", o->noRealtime, "Do not ask for real-time (SCHED_FIFO) scheduling of the card thread");
  cmd->add_flag("--paused", o->paused, "Start with simulated time stopped (the API can run or step it)");
  cmd->callback([o] { app::gRun = [o] { return runSim(*o); }; });
}
