// SPDX-License-Identifier: MIT
// lbpkit sim: a virtual 7I92 with 7I77s on the network (LBP16 over UDP),
// with an HTTP control API to watch the board and change its world.
#include <fmt/core.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <cmath>
#include <initializer_list>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common.hpp"
#include "config/card_toml.hpp"
#include "config/fault_script.hpp"
#include "config/machine_toml.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "daemon/sim_daemon.hpp"
#include "hostmot2/cards/catalogue.hpp"
#include "linuxcnc/board_address.hpp"
#include "lbp16/flash_file.hpp"
#include "remote/nv_store.hpp"
#include "remote/remote_device.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;
namespace server = lbpkit::server;
namespace config = lbpkit::config;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

struct SimCommandOptions {
  // --bind, repeatable: a card on each (one process, one card thread).
  std::vector<std::string> bind{"127.0.0.1"};
  std::string config;
  std::string script;  // --script FILE: [[fault]] entries of their own
  std::string state;
  std::string api = "127.0.0.1:27182";
  bool noApi = false;
  std::string apiToken;
  std::string logLevel = "info";
  double speed = 1.0;
  std::string clock = "wall";  // --clock wall|host[=PERIOD]
  bool paused = false;
  bool noRealtime = false;
  std::string cpu = "any";  // --cpu N|last|any: the card thread on CPU N alone
  int cpuLatencyUs = -1;     // --cpu-latency US
  bool demo = false;
  std::string machine;
  std::string record;
  std::string trace;  // --trace FILE.pcap: every datagram in and reply out
  std::vector<std::string> remotes;  // --remote CH=pty, repeatable
  std::string card;  // --card NAME: which Mesa card (hostmot2/cards/catalogue.hpp)
  int readyFd = -1;  // --ready-fd N: the greeting for programs (readyGreeting)
};

// --remote CH=pty: the SSLBP channel CH brought out to a pseudo-terminal.
// Which channels can be is the daemon's to say.
unsigned externalRemoteChannel(const std::string& text) {
  const auto eq = text.find('=');
  const std::string ch = text.substr(0, eq);
  if (eq == std::string::npos || text.substr(eq + 1) != "pty" || ch.empty() || ch.size() > 1 ||
      ch.find_first_not_of("0123456789") != std::string::npos)
    throw lbpkit::Error(fmt::format("--remote \"{}\": give CHANNEL=pty, e.g. 2=pty (the channel, 0..7, brought out "
                                    "to a pseudo-terminal for a remote of your own)",
                                    text));
  return static_cast<unsigned>(std::stoul(ch));
}

// The config string for hm2_eth's loadrt that uses this card as it is
// plugged: the encoders of each 7I77 (six a connector) and a 7I76's, the firmware's
// StepGens and PWMGens, and smart-serial mode 0 on each channel a remote
// answers on (the 7I77s' field I/O and analog processors, a 7I76's), 'x'
// on the others (LinuxCNC hostmot2(9): config modparam).
std::string hm2EthConfig(const hm2::HostMot2Card::Options& o) {
  const auto& card = o.card != nullptr ? *o.card : hm2::cards::defaultCard();
  const auto* fw = o.pinout ? hm2::cards::firmware(card, *o.pinout) : &card.firmwares.front();
  if (fw == nullptr) fw = &card.firmwares.front();
  auto count = [&](hm2::cards::Part part) {
    unsigned n = 0;
    for (const auto& m : fw->modules)
      if (m.part == part) n += m.count;
    return n;
  };
  std::string channels(count(hm2::cards::Part::SSerial), 'x');
  const std::size_t plugged = o.second && fw->sevenI77s.size() > 1 ? 2 : 1;
  for (std::size_t i = 0; i < plugged; ++i)
    for (unsigned c = fw->sevenI77s[i].firstChannel; c < fw->sevenI77s[i].firstChannel + 2U && c < channels.size(); ++c)
      channels[c] = '0';
  // A 7I76's spindle encoder is the counter after the 7I77's six.
  const auto sevenI76 = hm2::cards::sevenI76Channel(*fw);
  if (sevenI76 && *sevenI76 < channels.size()) channels[*sevenI76] = '0';
  std::string config = fmt::format("num_encoders={}", 6 * plugged + (sevenI76 ? 1 : 0));
  if (const auto n = count(hm2::cards::Part::StepGen)) config += fmt::format(" num_stepgens={}", n);
  if (const auto n = count(hm2::cards::Part::PwmGen)) config += fmt::format(" num_pwmgens={}", n);
  return config + " sserial_port_0=" + channels;
}

// --clock wall|host[=PERIOD]: PERIOD as LinuxCNC's SERVO_PERIOD gives it
// (nanoseconds) or with a unit (1ms, 500us, 1000000ns); without it, the
// period is learned from the host's first cycles.
std::optional<server::HostClock> clockOption(const std::string& text) {
  if (text == "wall") return std::nullopt;
  server::HostClock host;
  if (text == "host") return host;
  const std::string bad = fmt::format(
      "--clock \"{}\": give wall (the default), host, or host=PERIOD with PERIOD the host's servo period from 100us "
      "to 10ms (1ms, 500us, or nanoseconds as SERVO_PERIOD: 1000000)",
      text);
  if (text.rfind("host=", 0) != 0) throw lbpkit::Error(bad);
  const std::string period = text.substr(5);
  const auto digits = period.find_first_not_of("0123456789");
  const auto length = digits == std::string::npos ? period.size() : digits;  // of the number
  if (length == 0 || length > 9) throw lbpkit::Error(bad);
  const std::string unit = digits == std::string::npos ? "ns" : period.substr(digits);
  const std::int64_t n = std::stoll(period.substr(0, digits));
  std::int64_t ns = 0;
  if (unit == "ns") ns = n;
  else if (unit == "us") ns = n * 1000;
  else if (unit == "ms") ns = n * 1'000'000;
  else throw lbpkit::Error(bad);
  if (ns < 100'000 || ns > 10'000'000) throw lbpkit::Error(bad);
  host.period = lbp::SimTime{ns};
  return host;
}

// --machine NAME|FILE: a built-in machine (mill, lathe, gantry) or a TOML
// machine file (config::loadMachine says what is wrong with one), and where
// it came from, for the banner.
std::pair<machine::MachineDescription, std::string> loadMachineOption(const std::string& nameOrPath) {
  const bool builtIn = nameOrPath == "mill" || nameOrPath == "lathe" || nameOrPath == "gantry";
  return {config::loadMachine(nameOrPath), builtIn ? "built-in " + nameOrPath : nameOrPath};
}

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

// The default EEPROM file: one per bind address, so that sims side by side
// never share one (two writers would lose each other's writes).
// With several cards, `dir` is --state's folder.
std::filesystem::path defaultStatePath(const std::string& host, int port,
                                       const std::filesystem::path& dir = app::defaultStateDir()) {
  std::string name = fmt::format("7i77-{}-{}.eeprom", host, port);
  for (auto& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);  // lbpkit's own directory: created on first use
  const auto file = dir / name;
  // Earlier versions kept every sim's EEPROM in sim-7i77.eeprom: the sim on
  // the default address takes it over, so its saved parameters survive.
  if (host == "127.0.0.1" && port == server::lbp16::kPort) {
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

// One card's options: the card on `bind`, its API as --api says (with
// several cards, on the card's own address: `card` of `cards`), its EEPROM
// and flash files its own.
struct CardRun {
  server::SimOptions options;
  std::filesystem::path state;
};

CardRun cardOptions(const SimCommandOptions& o, const std::string& bind, std::size_t card, std::size_t cards,
                    const std::filesystem::path& state) {
  server::SimOptions s;
  const auto [bindHost, bindPort] = hostPort(bind, server::lbp16::kPort, "--bind");
  s.bindAddress = bindHost;
  s.port = static_cast<std::uint16_t>(bindPort);
  if (o.noApi) {
    s.apiPort = -1;
  } else {
    auto [apiHost, apiPort] = hostPort(o.api, 27182, "--api");
    if (cards > 1) {
      // Each card's API on the card's own address: the port hm2_eth users
      // know, one address a card. On one address, the ports after it.
      if (apiHost != "127.0.0.1")
        throw lbpkit::Error(fmt::format("--api \"{}\": with several cards each card's API is on its own address; give "
                                        "--api PORT",
                                        o.api));
      apiHost = bindHost;
      if (apiPort != 0) {
        std::size_t sameHost = 0;
        for (std::size_t i = 0; i < card; ++i)
          if (hostPort(o.bind[i], server::lbp16::kPort, "--bind").first == bindHost) ++sameHost;
        apiPort += static_cast<int>(sameHost);
      }
    }
    s.apiAddress = apiHost;
    s.apiPort = apiPort;
    s.apiToken = o.apiToken;
    if (std::any_of(o.apiToken.begin(), o.apiToken.end(), [](unsigned char c) { return c <= ' ' || c >= 0x7F; }))
      throw lbpkit::Error("--api-token: printable ASCII without spaces (it travels in an HTTP header)");
  }
  // Beyond loopback, anyone who can reach this machine can use what it
  // serves: said, not refused (a lab network may be what the user wants).
  auto loopback = [](const std::string& a) { return a.rfind("127.", 0) == 0; };
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
  s.hostClock = clockOption(o.clock);
  if (s.hostClock && o.speed != 1.0)
    throw lbpkit::Error("--speed and --clock host exclude each other: on the host clock a servo period passes per host "
                        "cycle");
  s.realtime = !o.noRealtime;
  s.cpu = app::cpuOption(o.cpu);
  if (o.cpuLatencyUs >= 0) s.cpuLatency = std::chrono::microseconds(o.cpuLatencyUs);
  s.demo = o.demo;
  if (!o.machine.empty()) {
    if (o.demo) throw lbpkit::Error("--machine and --demo exclude each other: both wire the 7I77's terminals");
    auto [description, source] = loadMachineOption(o.machine);
    s.machine = std::move(description);
    s.machineSource = std::move(source);
  }
  if (!o.record.empty() && o.machine.empty()) throw lbpkit::Error("--record needs --machine: it records the machine's axes");
  s.recordFile = o.record;
  s.packetTraceFile = o.trace;
  for (const auto& r : o.remotes) s.externalRemotes.push_back(externalRemoteChannel(r));
  // Simulated time is 64-bit nanoseconds: at 10000x it lasts 10 days.
  if (!(o.speed > 0) || !std::isfinite(o.speed) || o.speed > 10000)
    throw lbpkit::Error("--speed must be above 0 and at most 10000 (simulated seconds per wall-clock second)");
  static const std::map<std::string, server::LogLevel> kLevels = {{"error", server::LogLevel::Error},
                                                                  {"warn", server::LogLevel::Warn},
                                                                  {"info", server::LogLevel::Info},
                                                                  {"debug", server::LogLevel::Debug}};
  if (!kLevels.count(o.logLevel)) throw lbpkit::Error("--log-level: error, warn, info or debug");
  s.logLevel = kLevels.at(o.logLevel);
  s.card.first.fieldIo.nvFile = state;
  s.card.first.analog.nvFile = state.string() + ".analog";
  if (!o.card.empty()) {  // before the TOML, whose pinout must be one this card has
    s.card.card = hm2::cards::find(o.card);
    if (s.card.card == nullptr)
      throw lbpkit::Error(fmt::format("--card \"{}\": the cards lbpkit models are {}", o.card, hm2::cards::names()));
  }
  // The [[fault]] entries of --config and of --script, in time order (the
  // sim checks each against the card at start).
  auto addFaults = [&s](const std::string& file, bool scriptOnly) {
    for (auto& f : config::loadFaultScript(file, scriptOnly))
      s.faultScript.push_back({f.at, f.fault, nlohmann::json::parse(f.body),
                               f.lasts ? std::optional<lbp::SimTime>(*f.lasts) : std::nullopt, f.where});
  };
  if (!o.config.empty()) {
    config::loadConfig(o.config, s.card);
    s.configDescription = o.config;
    addFaults(o.config, false);
  }
  if (!o.script.empty()) {
    addFaults(o.script, true);
    std::stable_sort(s.faultScript.begin(), s.faultScript.end(),
                     [](const auto& a, const auto& b) { return a.at < b.at; });
  }
  if (o.config.empty()) {
    s.configDescription = s.card.card == nullptr
                              ? "built-in default: a 7I92 (Mesa's two-7I77 firmware) with one 7I77, 24 V field power"
                              : fmt::format("built-in default: a {} ({} firmware, {}) with one 7I77, 24 V field power",
                                            s.card.card->name, s.card.card->firmwares.front().name,
                                            s.card.card->firmwares.front().source);
  }
  // What the EEPROM files say (models cannot log): every refused write is
  // logged, and so is a file that cannot be used.
  const auto owner = fmt::format("lbpkit sim on {}:{}{}", bindHost, bindPort, bindPort == 0 ? " (any free port)" : "");
  const bool warn = s.logLevel >= server::LogLevel::Warn;
  std::vector<std::filesystem::path> files;
  // A processor whose program flash holds no valid program is named by its
  // smart-serial channel, where a host misses it (3 per connector).
  auto watch = [&](auto& processor, std::string what, unsigned channel) {
    files.push_back(processor.nvFile);
    processor.nvOwner = owner;
    processor.nvReport = [what, channel, warn](const remote::NvEvent& e) {
      using Kind = remote::NvEvent::Kind;
      const bool error = e.kind == Kind::Refused || e.kind == Kind::WriteFailed;
      if (!error && !warn) return;
      const auto from = e.kind == Kind::NoProgram ? fmt::format("channel {}", channel) : what;
      // fputs, not fmt::print: a log that cannot be written must not throw
      // out of the card thread.
      std::fputs(fmt::format("lbpkit sim: {}: {}: {}\n", error ? "error" : "warning", from, e.message).c_str(), stderr);
      std::fflush(stderr);
    };
  };
  watch(s.card.first.fieldIo, "connector 0 field I/O EEPROM", 0);
  watch(s.card.first.analog, "connector 0 analog EEPROM", 1);
  if (s.card.second) {
    watch(s.card.second->fieldIo, "connector 1 field I/O EEPROM", 3);
    watch(s.card.second->analog, "connector 1 analog EEPROM", 4);
  }
  // A file the sim will not use (not an EEPROM image, a symlink, held by
  // another sim, ...) stops it before it starts: the same checks the
  // processors make, made first so nothing is half started.
  for (const auto& file : files) {
    remote::NvStore probe(remote::memory::kEepromSize, file);
    probe.load();
    if (!probe.refusal().empty()) throw lbpkit::Error(probe.refusal());
    // Its program flash beside it (remote/program_flash.hpp).
    remote::NvStore program(remote::ProgramFlash::kSize, file.string() + ".program");
    program.load();
    if (!program.refusal().empty()) throw lbpkit::Error(program.refusal());
  }
  // The 7I92's configuration flash (what mesaflash --write programs), next
  // to the EEPROM: FILE.flash. Checked the same way.
  s.flashFile = state.string() + ".flash";
  {
    std::vector<std::uint8_t> probe(2 * 1024 * 1024);
    const auto loaded = server::loadFlashFile(s.flashFile, probe);
    if (loaded.status == server::FlashFileLoad::Status::Refused) throw lbpkit::Error(loaded.message);
    if (loaded.status == server::FlashFileLoad::Status::Corrupt && warn)
      fmt::print(stderr, "lbpkit sim: warning: {}\n", loaded.message);
  }
  return {std::move(s), state};
}

// Each --bind as an address and port, checked before anything is opened:
// the address a dotted quad (linuxcnc/board_address.hpp: parseIpv4), and no
// two cards on one address and port (the second could never listen there;
// with port 0, their state files would be one). 0.0.0.0 listens on a port
// of every address, so it clashes with any other on that port.
std::vector<std::pair<std::string, int>> checkedBinds(const std::vector<std::string>& binds) {
  std::vector<std::pair<std::string, int>> out;
  for (std::size_t i = 0; i < binds.size(); ++i) {
    // The address first: "::1" is an address lbpkit does not serve, not a
    // port.
    const auto address = binds[i].substr(0, binds[i].find(':'));
    if (!lbpkit::linuxcnc::parseIpv4(address))
      throw lbpkit::Error(fmt::format("--bind \"{}\": \"{}\" is not an IPv4 address (four numbers 0-255 joined by "
                                      "dots; ADDR[:PORT], e.g. 127.0.0.1 or 127.0.0.1:27181)",
                                      binds[i], address));
    auto [host, port] = hostPort(binds[i], server::lbp16::kPort, "--bind");
    for (std::size_t j = 0; j < out.size(); ++j) {
      const auto& [otherHost, otherPort] = out[j];
      if (port != otherPort) continue;
      if (host == otherHost)
        throw lbpkit::Error(fmt::format("--bind {} and --bind {} (options {} and {} of --bind) are one address and "
                                        "port: give each card its own",
                                        binds[j], binds[i], j + 1, i + 1));
      if (port != 0 && (host == "0.0.0.0" || otherHost == "0.0.0.0"))
        throw lbpkit::Error(fmt::format("--bind {} and --bind {} (options {} and {} of --bind) clash: 0.0.0.0 takes "
                                        "port {} on every address of this machine",
                                        binds[j], binds[i], j + 1, i + 1, port));
    }
    out.emplace_back(std::move(host), port);
  }
  return out;
}

// Each card's EEPROM file: --state FILE with one card, one file a card in
// the --state folder with several, else one a card in lbpkit's own folder.
// A --state folder, or a --state file's folder, that does not exist is the
// user's typo to hear about, not something to create.
std::vector<std::filesystem::path> statePaths(const SimCommandOptions& o,
                                              const std::vector<std::pair<std::string, int>>& binds) {
  namespace fs = std::filesystem;
  std::vector<fs::path> out;
  if (!o.state.empty()) {
    const fs::path given = o.state;
    const fs::path folder = binds.size() > 1 ? given : given.parent_path();
    std::error_code ec;
    if (!folder.empty() && !fs::is_directory(folder, ec))
      throw lbpkit::Error(
          fs::exists(fs::symlink_status(folder, ec))
              ? fmt::format("--state {}: {} is not a directory{}", o.state, folder.string(),
                            binds.size() > 1 ? " (with several --bind, --state is the folder for each card's files)"
                                             : "")
              : fmt::format("--state {}: the directory {} does not exist; lbpkit sim creates no folder for --state: "
                            "create it first",
                            o.state, folder.string()));
  }
  for (const auto& [host, port] : binds)
    out.push_back(o.state.empty()        ? defaultStatePath(host, port)
                  : binds.size() > 1 ? defaultStatePath(host, port, o.state)
                                     : fs::path(o.state));
  return out;
}

// The files beside each state file that belong to it: FILE itself and
// FILE.<anything> (FILE.analog, FILE.program, FILE.flash, FILE.2, ...).
std::vector<std::filesystem::path> filesBeside(const std::vector<std::filesystem::path>& states) {
  namespace fs = std::filesystem;
  std::vector<fs::path> out;
  for (const auto& state : states) {
    const auto name = state.filename().string();
    const auto folder = state.parent_path().empty() ? fs::path(".") : state.parent_path();
    std::error_code ec;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      const auto entry = it->path().filename().string();
      if (entry == name || entry.rfind(name + ".", 0) == 0) out.push_back(it->path());
    }
  }
  return out;
}

// --ready-fd N: what a program that started the sim needs to use it, as
// one JSON line once every card, its control API and web view serve (as
// QEMU's QMP greets its client), so that no program reads the banner, which
// is for people and may change its words:
//   {"lbpkit":"sim","cards":[{"card":"7I92","lbp16":{"address":"127.0.0.1","port":27181},
//     "api":{"address":"127.0.0.1","port":27182,"url":"http://127.0.0.1:27182"},
//     "web":"http://127.0.0.1:27182/","clock":"wall","state":"...","flash":"...",
//     "external_remotes":[{"channel":2,"pty":"/dev/pts/3"}]}]}
// "api" and "web" are null without a control API (--no-api); "clock" is
// "wall" or "host"; the token (--api-token) is never written.
nlohmann::json readyGreeting(const std::vector<CardRun>& runs,
                             const std::vector<std::unique_ptr<server::SimDaemon>>& daemons) {
  auto cards = nlohmann::json::array();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const auto& s = runs[i].options;
    const auto& d = *daemons[i];
    const std::string url = fmt::format("http://{}:{}", s.apiAddress, d.apiPort());
    const auto api = d.apiPort() >= 0 ? nlohmann::json{{"address", s.apiAddress}, {"port", d.apiPort()}, {"url", url}}
                                      : nlohmann::json(nullptr);
    auto remotes = nlohmann::json::array();
    for (const auto& [channel, pty] : d.externalRemotes()) remotes.push_back({{"channel", channel}, {"pty", pty}});
    cards.push_back({{"card", (s.card.card != nullptr ? *s.card.card : hm2::cards::defaultCard()).name},
                     {"lbp16", {{"address", s.bindAddress}, {"port", d.port()}}},
                     {"api", api},
                     {"web", api.is_null() ? api : nlohmann::json(url + "/")},
                     {"clock", s.hostClock ? "host" : "wall"},
                     {"state", runs[i].state.string()},
                     {"flash", s.flashFile.string()},
                     {"external_remotes", remotes}});
  }
  return {{"lbpkit", "sim"}, {"cards", cards}};
}

// Writes the greeting to `fd` and closes it; a descriptor that is not open
// is the caller's mistake, said at once.
void greet(int fd, const nlohmann::json& greeting) {
  const std::string line = greeting.dump() + "\n";
  std::size_t done = 0;
  while (done < line.size()) {
    const auto n = ::write(fd, line.data() + done, line.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw lbpkit::Error(fmt::format("--ready-fd {}: cannot write the greeting: {}", fd, std::strerror(errno)));
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
}

void removeFilesWritten(const std::vector<std::filesystem::path>& states,
                        const std::vector<std::filesystem::path>& before) {
  for (const auto& file : filesBeside(states))
    if (std::find(before.begin(), before.end(), file) == before.end()) {
      std::error_code ec;
      std::filesystem::remove(file, ec);
    }
}

int runSim(const SimCommandOptions& o) {
  if (o.bind.empty()) throw lbpkit::Error("--bind: give ADDR[:PORT]");
  if (o.readyFd >= 0 && ::fcntl(o.readyFd, F_GETFD) < 0)
    throw lbpkit::Error(fmt::format("--ready-fd {}: no such open descriptor (the program starting the sim passes "
                                    "one it made, such as a pipe's write end)",
                                    o.readyFd));
  if (o.bind.size() > 1) {
    // What names one file, or one pseudo-terminal, cannot serve several cards.
    for (const auto& [given, what] : {std::pair{!o.record.empty(), "--record"}, {!o.trace.empty(), "--trace"},
                                      {!o.remotes.empty(), "--remote"}})
      if (given)
        throw lbpkit::Error(fmt::format("{} names one card's file or terminal: give it with one --bind (here {} "
                                        "cards)",
                                        what, o.bind.size()));
  }
  const auto binds = checkedBinds(o.bind);
  const auto states = statePaths(o, binds);
  // What the start writes beside each state file (the EEPROMs of both
  // connectors, their program flash, the configuration flash) and did not
  // find there, removed again when the start fails: a refused option or a
  // bind that fails leaves the folder as it was.
  const auto before = filesBeside(states);
  std::vector<CardRun> runs;
  std::vector<std::unique_ptr<server::SimDaemon>> daemons;
  try {
    std::vector<CardRun> starting;
    for (std::size_t i = 0; i < o.bind.size(); ++i)
      starting.push_back(cardOptions(o, o.bind[i], i, o.bind.size(), states[i]));
    std::vector<std::unique_ptr<server::SimDaemon>> started;
    for (auto& r : starting) started.push_back(std::make_unique<server::SimDaemon>(r.options));
    runs = std::move(starting);
    daemons = std::move(started);
  } catch (...) {
    // The cards started so far are gone (and have closed their files).
    removeFilesWritten(states, before);
    throw;
  }
  app::installSignalHandlers();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const auto& s = runs[i].options;
    fmt::print("{}", daemons[i]->banner());
    // 0.0.0.0 is where the sim listens, not an address a host can reach.
    fmt::print("  point LinuxCNC at it: loadrt hm2_eth board_ip={} config=\"{}\"\n",
               s.bindAddress == "0.0.0.0" ? "ADDRESS (this machine's address on the host's network)" : s.bindAddress,
               hm2EthConfig(s.card));
  }
  if (runs.size() > 1) fmt::print("lbpkit sim: {} cards, served by one thread\n", runs.size());
  std::fflush(stdout);
  if (o.readyFd >= 0) greet(o.readyFd, readyGreeting(runs, daemons));
  std::vector<server::SimDaemon*> cards;
  for (auto& d : daemons) cards.push_back(d.get());
  server::SimDaemon::runAll(cards, app::gStop, app::stopFd());
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const auto& s = runs[i].options;
    const auto& daemon = *daemons[i];
    const std::string which = runs.size() > 1 ? fmt::format(" ({})", o.bind[i]) : "";
    fmt::print("lbpkit sim: stopped{}; server time per datagram: {}\n", which, daemon.latencySummary());
    fmt::print("lbpkit sim: the 7I77's EEPROM state is in {}, the {}'s configuration flash in {}\n",
               runs[i].state.string(), (s.card.card != nullptr ? *s.card.card : hm2::cards::defaultCard()).name,
               s.flashFile.string());
  }
  if (!o.record.empty()) fmt::print("lbpkit sim: the servo-cycle trace is in {}\n", o.record);
  if (!o.trace.empty()) fmt::print("lbpkit sim: {}\n", daemons.front()->packetTraceSummary());
  return 0;
}

}  // namespace

void addSimCommand(CLI::App& app) {
  auto o = std::make_shared<SimCommandOptions>();
  auto* cmd = app.add_subcommand("sim", "Run a virtual 7I92 with a 7I77 on the network (LBP16, UDP port 27181)");
  cmd->add_option("--bind", o->bind,
                  "ADDR[:PORT] to serve LBP16 on, ADDR an IPv4 address (127.0.0.1:27181 unless you say otherwise); "
                  "repeated, a card on each address and port, all served by one thread")
      ->capture_default_str();
  cmd->add_option("--card", o->card, "Which Mesa card: " + hm2::cards::names() + " (default 7I92; docs/cards.md)");
  cmd->add_option("--config", o->config,
                  "TOML file: firmware pinout, daughtercards, field voltage, 7I77 or 7I77D, jumpers, unit numbers");
  cmd->add_option("--script", o->script,
                  "TOML file of [[fault]] entries, a fault script of its own (after --config's entries; "
                  "examples/scenarios/, docs/faults.md)");
  cmd->add_option("--state", o->state,
                  "EEPROM file of the 7I77 (non-volatile parameters); with several --bind, a folder: each card's "
                  "files in it, named by its address. The folder must exist");
  cmd->add_option("--api", o->api, "[ADDR:]PORT of the HTTP control API (0: any free port)")->capture_default_str();
  cmd->add_flag("--no-api", o->noApi, "No control API");
  cmd->add_option("--log-level", o->logLevel, "error, warn, info or debug")->capture_default_str();
  cmd->add_option("--api-token", o->apiToken,
                  "Require \"Authorization: Bearer TOKEN\" on every control API request (or LBPKIT_API_TOKEN)")
      ->envname("LBPKIT_API_TOKEN");
  cmd->add_option("--speed", o->speed, "Simulated seconds per wall-clock second (above 0, at most 10000)")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--clock", o->clock,
                  "What simulated time follows: wall (the wall clock), or host[=PERIOD] (one servo period per host "
                  "cycle, e.g. host=1ms; docs/clocks.md)")
      ->capture_default_str();
  cmd->add_flag("--demo", o->demo, "Demo world: field outputs 0..15 wired back to inputs 0..15, encoder 0 turning");
  cmd->add_option("--machine", o->machine,
                  "A machine behind the 7I77 on connector 0: mill, lathe, gantry (built-in) or a TOML machine file")
      ->excludes("--demo");
  cmd->add_option("--record", o->record,
                  "CSV file: each axis' command, position and following error at every servo cycle (needs --machine)");
  cmd->add_option("--trace", o->trace,
                  "pcap file: every LBP16 datagram the card takes and every reply it sends, timed (lbpkit decode, "
                  "Wireshark)");
  cmd->add_flag("--no-realtime", o->noRealtime, "Do not ask for real-time (SCHED_FIFO) scheduling of the card thread");
  cmd->add_option("--cpu", o->cpu,
                  "N|last|any: run the card thread on this CPU alone (last: the last this process may use); start "
                  "the host on the same CPU (taskset -c N) and every reply is there before the host looks for it, "
                  "however busy the PC is")
      ->capture_default_str();
  cmd->add_option("--ready-fd", o->readyFd,
                  "N: once every card, its control API and web view serve, write one JSON line to descriptor N "
                  "(their addresses, clock, state and flash files) and close it: for a program that starts the "
                  "sim (the banner is for people)")
      ->check(CLI::Range(0, 1 << 20));
  cmd->add_option("--cpu-latency", o->cpuLatencyUs,
                  "US: while the sim runs, no CPU sleeps deeper than it can wake from in US (PM QoS, root); 0 keeps "
                  "idle CPUs polling, so no thread waits for a CPU to wake (costs the idle CPUs' time; docs/sim.md)")
      ->check(CLI::Range(0, 100000));
  cmd->add_flag("--paused", o->paused, "Start with simulated time stopped (the API can run or step it)");
  cmd->add_option("--remote", o->remotes,
                  "CH=pty: SSLBP channel CH (e.g. 2, TB6) on a pseudo-terminal for a remote of your own; repeatable");
  cmd->callback([o] { app::gRun = [o] { return runSim(*o); }; });
}
