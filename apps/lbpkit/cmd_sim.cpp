// lbpkit sim: a virtual 7I92 with 7I77s on the network (LBP16 over UDP),
// with an HTTP control API to watch the board and change its world.
#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <initializer_list>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include <toml++/toml.h>

#include "common.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/wire/seven_i77.hpp"
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
  std::string apiToken;
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

// The TOML configuration (README: `--config`; examples/sim.toml): which
// daughtercards, field voltage, 7I77 or 7I77D, jumpers, unit numbers. Every
// mistake is an error naming the file, line and key: a misspelt key that
// was silently ignored would leave the user testing a board they did not
// describe.
class ConfigReader {
 public:
  explicit ConfigReader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const toml::node* node, const std::string& key, const std::string& what) const {
    if (node != nullptr && node->source().begin)
      throw lbpkit::Error(fmt::format("{}:{}:{}: {}: {}", path_, node->source().begin.line,
                                      node->source().begin.column, key, what));
    throw lbpkit::Error(fmt::format("{}: {}: {}", path_, key, what));
  }

  // Refuses keys the table may not have, suggesting the nearest known one.
  void onlyKeys(const toml::table& t, const std::string& prefix, std::initializer_list<std::string_view> known) const {
    for (const auto& [k, v] : t) {
      const std::string_view key = k.str();
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::string_view best;
      std::size_t bestDistance = 3;  // suggest only near misses
      for (auto candidate : known) {
        const auto d = distance(key, candidate);
        if (d < bestDistance) bestDistance = d, best = candidate;
      }
      std::string known_list;
      for (auto candidate : known) known_list += (known_list.empty() ? "" : ", ") + std::string(candidate);
      fail(&v, prefix + std::string(key),
           best.empty() ? fmt::format("unknown key (known here: {})", known_list)
                        : fmt::format("unknown key; did you mean {}?", best));
    }
  }

  double number(const toml::table& t, const std::string& prefix, std::string_view key, double fallback, double min,
                double max, std::string_view unit) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const auto name = prefix + std::string(key);
    double v = 0;
    if (auto f = n->value_exact<double>()) v = *f;
    else if (auto i = n->value_exact<std::int64_t>()) v = static_cast<double>(*i);
    else fail(n, name, fmt::format("expected a number ({}), not {}", unit, typeName(*n)));
    if (!std::isfinite(v) || v < min || v > max)
      fail(n, name, fmt::format("{} is out of range: {} to {} {}", v, min, max, unit));
    return v;
  }

  std::int64_t integer(const toml::table& t, const std::string& prefix, std::string_view key, std::int64_t fallback,
                       std::int64_t min, std::int64_t max) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const auto name = prefix + std::string(key);
    const auto i = n->value_exact<std::int64_t>();
    if (!i) fail(n, name, fmt::format("expected an integer, not {}", typeName(*n)));
    if (*i < min || *i > max) fail(n, name, fmt::format("0x{:X} is out of range: 0x{:X} to 0x{:X}", *i, min, max));
    return *i;
  }

  bool boolean(const toml::table& t, const std::string& prefix, std::string_view key, bool fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const auto b = n->value_exact<bool>();
    if (!b) fail(n, prefix + std::string(key), fmt::format("expected true or false, not {}", typeName(*n)));
    return *b;
  }

  std::string text(const toml::table& t, const std::string& prefix, std::string_view key, std::string fallback,
                   std::initializer_list<std::string_view> allowed) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const auto s = n->value_exact<std::string>();
    const auto name = prefix + std::string(key);
    std::string list;
    for (auto a : allowed) list += (list.empty() ? "\"" : ", \"") + std::string(a) + "\"";
    if (!s) fail(n, name, fmt::format("expected a string ({}), not {}", list, typeName(*n)));
    if (std::find(allowed.begin(), allowed.end(), *s) == allowed.end())
      fail(n, name, fmt::format("\"{}\" is not one of {}", *s, list));
    return *s;
  }

  const std::string& path() const { return path_; }

 private:
  static std::string typeName(const toml::node& n) {
    switch (n.type()) {
      case toml::node_type::string: return "a string";
      case toml::node_type::integer: return "an integer";
      case toml::node_type::floating_point: return "a number";
      case toml::node_type::boolean: return "a boolean";
      case toml::node_type::table: return "a table";
      case toml::node_type::array: return "an array";
      default: return "a date or time";
    }
  }
  // Edit distance, for "did you mean".
  static std::size_t distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0U : 1U)});
        diagonal = up;
      }
    }
    return row[b.size()];
  }

  std::string path_;
};

void loadConfig(const std::string& path, hm2::HostMot2Card::Options& card) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw lbpkit::Error(fmt::format("{}: no such file", path));
  if (!std::filesystem::is_regular_file(status))
    throw lbpkit::Error(fmt::format("{}: is not a regular file (a TOML configuration file is expected)", path));
  toml::table t;
  try {
    t = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw lbpkit::Error(fmt::format("{}:{}:{}: {}", path, e.source().begin.line, e.source().begin.column,
                                    e.description()));
  }
  const ConfigReader r(path);
  r.onlyKeys(t, "", {"card", "daughtercard"});
  if (const toml::node* c = t.get("card")) {
    const auto* cardTable = c->as_table();
    if (cardTable == nullptr) r.fail(c, "card", "expected a table ([card])");
    r.onlyKeys(*cardTable, "card.", {"name"});
    r.text(*cardTable, "card.", "name", "7I92", {"7I92"});  // the only card modelled
  }
  const toml::node* boardsNode = t.get("daughtercard");
  if (boardsNode == nullptr) return;
  const auto* boards = boardsNode->as_array();
  if (boards == nullptr) r.fail(boardsNode, "daughtercard", "expected an array of tables ([[daughtercard]])");
  if (boards->size() > 2) r.fail(boardsNode, "daughtercard", fmt::format("a 7I92 has two connectors, not {}", boards->size()));
  for (std::size_t i = 0; i < boards->size(); ++i) {
    const auto* b = boards->get(i)->as_table();
    const auto prefix = fmt::format("daughtercard[{}].", i);
    if (b == nullptr) r.fail(boards->get(i), prefix.substr(0, prefix.size() - 1), "expected a table");
    r.onlyKeys(*b, prefix,
               {"type", "field_voltage", "w1", "vin", "w12_setup", "w4_setup", "field_io_unit", "analog_unit"});
    const auto type = r.text(*b, prefix, "type", "7I77", {"7I77", "7I77D", "none"});
    if (type == "none") {
      if (i == 0) r.fail(b->get("type"), prefix + "type", "the first connector must carry a 7I77");
      continue;
    }
    hm2::HostMot2Card::DaughterOptions d;
    if (i == 1 && !card.first.fieldIo.nvFile.empty()) {
      d.fieldIo.nvFile = card.first.fieldIo.nvFile.string() + ".2";
      d.analog.nvFile = card.first.analog.nvFile.string() + ".2";
    }
    d.fieldIo.outputs = type == "7I77D" ? remote::OutputType::Sinking : remote::OutputType::Sourcing;
    // Rated 5..28 V field power and 10..32 V VIN (manual: SPECIFICATIONS);
    // lower values model a failing supply, above 36 V nothing survives.
    d.fieldIo.fieldVoltage = r.number(*b, prefix, "field_voltage", 24.0, 0.0, 36.0, "V");
    d.fieldIo.vinFromField = r.text(*b, prefix, "w1", "field", {"field", "separate"}) == "field";
    d.fieldIo.vin = r.number(*b, prefix, "vin", 24.0, 0.0, 36.0, "V");
    d.fieldIo.setupMode = r.boolean(*b, prefix, "w12_setup", false);
    d.analog.setupMode = r.boolean(*b, prefix, "w4_setup", false);
    // Each board has its own serial number (the low 24 bits of both units);
    // the top byte says which processor it is.
    namespace unit = lbpkit::wire::i7i77::unit_type;
    const std::int64_t serial = 0x000AEE + static_cast<std::int64_t>(i);
    const auto unitRange = [](std::uint8_t top) {
      return std::pair<std::int64_t, std::int64_t>{std::int64_t{top} << unit::kShift,
                                                   (std::int64_t{top} << unit::kShift) | 0xFFFFFF};
    };
    const auto [ioMin, ioMax] = unitRange(unit::kFieldIo);
    const auto [anMin, anMax] = unitRange(unit::kAnalog);
    d.fieldIo.unitNumber = static_cast<std::uint32_t>(r.integer(*b, prefix, "field_io_unit", ioMin + serial, ioMin, ioMax));
    d.analog.unitNumber = static_cast<std::uint32_t>(r.integer(*b, prefix, "analog_unit", anMin + serial, anMin, anMax));
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
  if (host == "127.0.0.1" && port == net::lbp16::kPort) {
    for (const char* suffix : {"", ".analog", ".2", ".analog.2"}) {  // both processors of both connectors
      const auto legacy = (dir / "sim-7i77.eeprom").string() + suffix;
      const auto now = file.string() + suffix;
      if (!std::filesystem::exists(std::filesystem::symlink_status(now, ec)) &&
          std::filesystem::is_regular_file(std::filesystem::symlink_status(legacy, ec)))
        std::filesystem::rename(legacy, now, ec);
    }
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
    s.apiToken = o.apiToken;
    if (std::any_of(o.apiToken.begin(), o.apiToken.end(), [](unsigned char c) { return c <= ' ' || c >= 0x7F; }))
      throw lbpkit::Error("--api-token: printable ASCII without spaces (it travels in an HTTP header)");
  }
  // Beyond loopback, anyone who can reach this machine can use what it
  // serves: said, not refused (a lab network may be what the user wants).
  auto loopback = [](const std::string& a) { return a.rfind("127.", 0) == 0 || a == "localhost"; };
  if (!loopback(bindHost))
    fmt::print(stderr, "lbpkit sim: warning: LBP16 on {} answers anyone who can reach this machine: they can read and "
                       "write the virtual card's registers, EEPROM and flash (as a real card on that network)\n",
               bindHost);
  if (!o.noApi && !loopback(s.apiAddress))
    fmt::print(stderr, "lbpkit sim: warning: the control API on {} lets anyone who can reach this machine change the "
                       "simulated machine (unplug cables, short outputs, set field power){}\n",
               s.apiAddress,
               o.apiToken.empty() ? "; give it a token (--api-token or LBPKIT_API_TOKEN) or keep it on 127.0.0.1"
                                  : ", if they have its token");
  s.speed = o.speed;
  s.paused = o.paused;
  s.realtime = !o.noRealtime;
  s.demo = o.demo;
  // Simulated time is 64-bit nanoseconds: at 10000x it lasts 10 days.
  if (!(o.speed > 0) || !std::isfinite(o.speed) || o.speed > 10000)
    throw lbpkit::Error("--speed must be above 0 and at most 10000 (simulated seconds per wall-clock second)");
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
  // 0.0.0.0 is where the sim listens, not an address a host can reach.
  fmt::print("  point LinuxCNC at it: loadrt hm2_eth board_ip={} config=\"num_encoders=6 sserial_port_0=00xxxx\"\n",
             s.bindAddress == "0.0.0.0" ? "ADDRESS (this machine's address on the host's network)" : s.bindAddress);
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
  cmd->add_option("--api-token", o->apiToken,
                  "Require \"Authorization: Bearer TOKEN\" on every control API request (or LBPKIT_API_TOKEN)")
      ->envname("LBPKIT_API_TOKEN");
  cmd->add_option("--speed", o->speed, "Simulated seconds per wall-clock second (above 0, at most 10000)")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  cmd->add_flag("--demo", o->demo, "Demo world: field outputs 0..15 wired back to inputs 0..15, encoder 0 turning");
  cmd->add_flag("--no-realtime", o->noRealtime, "Do not ask for real-time (SCHED_FIFO) scheduling of the card thread");
  cmd->add_flag("--paused", o->paused, "Start with simulated time stopped (the API can run or step it)");
  cmd->callback([o] { app::gRun = [o] { return runSim(*o); }; });
}
