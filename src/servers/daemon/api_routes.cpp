// SPDX-License-Identifier: MIT
#include "daemon/api_routes.hpp"
#include "daemon/api_http.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "daemon/link_api.hpp"
#include "daemon/network_api.hpp"
#include "daemon/request_fields.hpp"
#include "daemon/state_json.hpp"
#include "daemon/web_view.hpp"
#include "hostmot2/terminals.hpp"
#include "lbpkit/wire/names.hpp"

namespace lbpkit::server {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;
using fields::flag;
using fields::index;
using fields::listed;
using fields::number;
using fields::text;
using fields::whole;

// --- Request validation: every complaint is an std::invalid_argument whose
// text the client gets back with HTTP 400. Each names the key and what it
// may be: the range is what the hardware (7I77 manual: SPECIFICATIONS) or
// the model can represent, never the JSON library's own words.

json body(const httplib::Request& req) {
  if (req.body.empty()) return json::object();
  auto j = json::parse(req.body, nullptr, false);
  if (j.is_discarded()) throw std::invalid_argument("the request body is not valid JSON (numbers must fit a double)");
  if (!j.is_object()) throw std::invalid_argument("the request body is not a JSON object");
  return j;
}

// The 7I76 on the 7I77+7I76 firmwares is on the card's second connector
// (IO17..33: PIN_7I77_7I76_34.vhd), where no 7I77 is.
constexpr unsigned kSevenI76Connector = SimState::SevenI76::kConnector;

// "connector" (0 when absent), checked against the 7I77s the card carries.
unsigned connector(const json& j, model::hm2::HostMot2Card& card) {
  const auto d = j.contains("connector") ? index(j, "connector", 2) : 0U;
  if (d >= card.daughtercards())
    throw std::invalid_argument(d == kSevenI76Connector && card.sevenI76() != nullptr
                                    ? fmt::format("connector {} carries the 7I76: only its inputs (/api/input), field "
                                                  "voltage (/api/field) and output loads (/api/output) can be set",
                                                  d)
                                    : fmt::format("no 7I77 on connector {}", d));
  return d;
}

// The 7I76 when "connector" names its connector, else nullptr (a 7I77's).
model::remote::SevenI76FieldIo* sevenI76At(const json& j, model::hm2::HostMot2Card& card) {
  if (card.sevenI76() == nullptr || !j.contains("connector")) return nullptr;
  return index(j, "connector", 2) == kSevenI76Connector && card.daughtercards() <= kSevenI76Connector
             ? card.sevenI76()
             : nullptr;
}

// Field power and VIN are rated up to 32 V (7I77 manual: SPECIFICATIONS; the
// sim raises HighVoltage above it) and the analog readings go to 36.3 V:
// 0..36 V covers a supply that sags to nothing or overshoots.
constexpr double kMaxVolts = 36.0;
const std::string kVoltsRange = "from 0 to 36 (volts)";
// An output's load: a real resistance. 0 is "short": true, open is null or {}.
constexpr double kMaxOhms = 1e9;
// The muxed encoder path: far past its ~2 MHz exact limit, counts are lost
// as on the hardware; beyond 10 MHz there is nothing more to see.
constexpr double kMaxCountsPerSecond = 1e7;
constexpr std::uint64_t kMaxCountsPerRev = std::uint64_t{1} << 31;
constexpr double kMaxSpeed = 10000;
constexpr double kMaxStepMs = 60000;

using Route = std::function<Answer(const json&)>;

// --- The machine: GET /api/machine, POST /api/machine actions,
// GET /api/machine/trace.

// A route about a machine the sim does not have.
struct NoMachine : std::runtime_error {
  NoMachine() : std::runtime_error("no machine is loaded (start the sim with --machine mill, lathe, gantry or FILE)") {}
};

std::string axisNames(const model::machine::Machine& m) {
  std::vector<std::string> names;
  for (const auto& a : m.description().axes) names.push_back(a.name);
  return listed(names);
}

// Why an "encoder" action on the spindle cannot be done.
std::string noSpindleEncoder(const model::machine::Machine& m) {
  return m.spindle() != nullptr ? "\"axis\": this machine's spindle has no encoder"
                                : "\"axis\": this machine has no spindle";
}

// The outside world's reach: a push as far as any machine travels, as fast
// as any axis could be shoved.
constexpr double kMaxPush = 1e6;
constexpr double kMaxPushSpeed = 1e5;
constexpr double kDefaultPushSpeed = 20.0;

void machineAction(model::machine::Machine& m, const json& j) {
  const std::string action = text(j, "action");
  auto axis = [&]() {
    const std::string name = text(j, "axis");
    if (const auto i = m.axisIndex(name)) return *i;
    throw std::invalid_argument(
        fmt::format("\"axis\": this machine has no axis \"{}\" (it has {})", name, axisNames(m)));
  };
  // Everything is checked before anything changes.
  if (action == "push") {
    fields::onlyKnown(j, {"action", "axis", "distance", "speed"});
    const auto a = axis();
    const double distance = number(j, "distance", -kMaxPush, kMaxPush,
                                   fmt::format("from {:g} to {:g} (machine units)", -kMaxPush, kMaxPush));
    const double speed = j.contains("speed") ? number(j, "speed", std::numeric_limits<double>::min(), kMaxPushSpeed,
                                                      fmt::format("above 0 and at most {:g} (machine units per second)",
                                                                  kMaxPushSpeed))
                                             : kDefaultPushSpeed;
    m.push(a, distance, speed);
  } else if (action == "jam") {
    fields::onlyKnown(j, {"action", "axis", "jammed"});
    const auto a = axis();
    m.setJammed(a, flag(j, "jammed"));
  } else if (action == "encoder") {
    fields::onlyKnown(j, {"action", "axis", "drive", "channel", "broken", "reversed"});
    const std::string name = text(j, "axis");
    const auto a = m.axisIndex(name);
    if (!a && name != "spindle")
      throw std::invalid_argument(fmt::format("\"axis\": this machine has no axis \"{}\" (it has {}, and \"spindle\" "
                                              "for the spindle's encoder)",
                                              name, axisNames(m)));
    // A stepper axis has no encoder: it goes where its steps say.
    if (a && m.stepper(*a) != nullptr)
      throw std::invalid_argument(fmt::format("\"axis\": {} is a stepper axis: it has no encoder", name));
    const unsigned drives = a ? static_cast<unsigned>(m.drives(*a)) : 1U;
    const unsigned drive = j.contains("drive") ? index(j, "drive", drives) : 0U;
    // One fault a request: a channel broken or mended, or A and B swapped.
    const bool reversing = j.contains("reversed");
    if (reversing && (j.contains("channel") || j.contains("broken")))
      throw std::invalid_argument(
          "\"reversed\" goes alone: give either \"channel\" and \"broken\" (a broken wire) or \"reversed\" (A and B "
          "swapped), not both");
    if (!reversing && !j.contains("channel") && !j.contains("broken"))
      throw std::invalid_argument(
          "missing \"channel\" and \"broken\" (a broken wire) or \"reversed\" (A and B swapped)");
    if (reversing) {
      const bool reversed = flag(j, "reversed");
      if (a)
        m.setEncoderReversed(*a, drive, reversed);
      else if (!m.setSpindleEncoderReversed(reversed))
        throw std::invalid_argument(noSpindleEncoder(m));
      return;
    }
    const std::string channelName = text(j, "channel");
    model::machine::EncoderChannel channel{};
    if (channelName == "A")
      channel = model::machine::EncoderChannel::A;
    else if (channelName == "B")
      channel = model::machine::EncoderChannel::B;
    else if (channelName == "index")
      channel = model::machine::EncoderChannel::Index;
    else
      throw std::invalid_argument("\"channel\" must be \"A\", \"B\" or \"index\"");
    const bool broken = flag(j, "broken");
    if (a)
      m.setEncoderBroken(*a, drive, channel, broken);
    else if (!m.setSpindleEncoderBroken(channel, broken))
      throw std::invalid_argument(noSpindleEncoder(m));
  } else if (action == "amplifier") {
    fields::onlyKnown(j, {"action", "axis", "drive", "enable_ignored"});
    const auto a = axis();
    // A stepper axis has no amplifier on the 7I77: its StepGen drives it.
    if (m.stepper(a) != nullptr)
      throw std::invalid_argument(
          fmt::format("\"axis\": {} is a stepper axis: it has no amplifier", m.description().axes[a].name));
    const unsigned drive = j.contains("drive") ? index(j, "drive", static_cast<unsigned>(m.drives(a))) : 0U;
    m.setEnableIgnored(a, drive, flag(j, "enable_ignored"));
  } else if (action == "estop") {
    fields::onlyKnown(j, {"action", "pressed"});
    const bool pressed = flag(j, "pressed");
    if (m.setSwitches(model::machine::SwitchKind::Estop, pressed) == 0)
      throw std::invalid_argument("\"action\": this machine has no E-stop switch");
  } else if (action == "probe") {
    fields::onlyKnown(j, {"action", "touching"});
    const bool touching = flag(j, "touching");
    if (m.setSwitches(model::machine::SwitchKind::Probe, touching) == 0)
      throw std::invalid_argument("\"action\": this machine has no probe");
  } else if (action == "switch") {
    fields::onlyKnown(j, {"action", "name", "tripped"});
    const std::string name = text(j, "name");
    const bool tripped = flag(j, "tripped");
    if (!m.setSwitch(name, tripped)) {
      std::vector<std::string> names;
      for (const auto& sw : m.description().switches) names.push_back(sw.name);
      throw std::invalid_argument(
          fmt::format("\"name\": this machine has no switch \"{}\" (it has {})", name, listed(names)));
    }
  } else {
    throw std::invalid_argument("\"action\" must be one of push, jam, encoder, amplifier, estop, probe, switch");
  }
}

// GET /api/machine/trace?since=SECONDS: the rows after `since` (all the
// ring holds without it), written straight to text: up to 60 s of rows.
std::string traceJson(const TraceRing& trace, const httplib::Request& req) {
  double since = -std::numeric_limits<double>::infinity();
  if (req.has_param("since")) {
    const std::string v = req.get_param_value("since");
    std::size_t used = 0;
    bool ok = !v.empty();
    try {
      since = ok ? std::stod(v, &used) : 0.0;
    } catch (const std::exception&) {
      ok = false;
    }
    if (!ok || used != v.size() || !std::isfinite(since))
      throw std::invalid_argument(fmt::format("\"since\" must be a number of seconds (simulated time), not \"{}\"", v));
  }
  std::string out = "{\"columns\":" + json(trace.columns()).dump() + ",\"rows\":[";
  std::vector<double> row(trace.width());
  const std::uint64_t end = trace.pushed();
  bool first = true;
  for (std::uint64_t n = trace.firstAfter(since); n < end; ++n) {
    if (!trace.read(n, row)) continue;  // overwritten meanwhile: older than what follows
    out += first ? "[" : ",[";
    first = false;
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i > 0) out += ',';
      out += std::isfinite(row[i]) ? fmt::format("{:.12g}", row[i]) : std::string("null");
    }
    out += ']';
  }
  out += "]}";
  return out;
}

// --- What a POST does: one action per kind, on the card thread. The HTTP
// routes and a fault script's entries (SimDaemon) both carry them out.

using Action = void (*)(const ApiTarget&, const json&);

void linkAction(const ApiTarget& t, const json& j) { applyLink(t.card.part<model::hm2::Sslbp>(), j, t.card.now()); }

void networkAction(const ApiTarget& t, const json& j) {
  if (t.udp == nullptr) throw std::invalid_argument("this sim has no network to disturb");
  applyNetwork(t.udp->faults(), j, NetworkFaults::Clock::now());
}

void machineRouteAction(const ApiTarget& t, const json& j) {
  if (t.machine == nullptr) throw NoMachine();
  machineAction(*t.machine, j);
}

// The field I/O "connector" names: the 7I76's, or the 7I77's there.
model::hm2::FieldIoAt fieldIoAt(const json& j, model::hm2::HostMot2Card& card) {
  return sevenI76At(j, card) != nullptr ? model::hm2::FieldIoAt::theSevenI76()
                                        : model::hm2::FieldIoAt::sevenI77On(connector(j, card));
}

void inputAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"connector", "input", "volts", "on"});
  const auto at = fieldIoAt(j, t.card);
  const auto n = index(j, "input", at.sevenI76 ? model::remote::SevenI76FieldIo::kInputs : model::remote::FieldIoProcessor::kInputs);
  model::hm2::Terminals terminals(t.card);
  if (j.contains("volts"))
    terminals.setInputVoltage(at, n, number(j, "volts", 0, kMaxVolts, kVoltsRange));
  else
    terminals.setInput(at, n, flag(j, "on"));
}

void fieldAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"connector", "volts", "vin"});
  model::hm2::Terminals terminals(t.card);
  const auto at = fieldIoAt(j, t.card);
  if (at.sevenI76) {
    // Its processor runs from field power (seven_i76.hpp): it has no VIN.
    if (j.contains("vin")) throw std::invalid_argument("\"vin\": the 7I76 has no VIN (it runs from field power)");
    terminals.setFieldVoltage(at, number(j, "volts", 0, kMaxVolts, kVoltsRange));
    return;
  }
  // Both checked before either changes anything.
  const bool volts = j.contains("volts"), vin = j.contains("vin");
  const double v = volts ? number(j, "volts", 0, kMaxVolts, kVoltsRange) : 0;
  const double w = vin ? number(j, "vin", 0, kMaxVolts, kVoltsRange) : 0;
  if (volts) terminals.setFieldVoltage(at, v);
  if (vin) terminals.setVin(at.connector, w);
}

void encoderAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"connector", "encoder", "counts_per_rev", "velocity"});
  const auto d = connector(j, t.card);
  constexpr unsigned kPer = SimState::kEncodersPerDaughtercard;
  const auto n = index(j, "encoder", kPer) + kPer * d;
  const bool cpr = j.contains("counts_per_rev"), vel = j.contains("velocity");
  const auto c = cpr ? whole(j, "counts_per_rev", kMaxCountsPerRev,
                             fmt::format("from 0 to {} (0: no index)", kMaxCountsPerRev))
                     : 0;
  const double v = vel ? number(j, "velocity", -kMaxCountsPerSecond, kMaxCountsPerSecond,
                                fmt::format("from {:g} to {:g} (counts per second)", -kMaxCountsPerSecond,
                                            kMaxCountsPerSecond))
                       : 0;
  model::hm2::Terminals(t.card).setEncoder(n, vel ? std::optional<double>(v) : std::nullopt,
                                    cpr ? std::optional<std::uint32_t>(static_cast<std::uint32_t>(c)) : std::nullopt);
}

void cableAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"channel", "connected"});
  const auto ch = index(j, "channel", t.card.part<model::hm2::Sslbp>().channels());
  model::hm2::Terminals(t.card).setCable(ch, flag(j, "connected"));
}

void outputAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"connector", "output", "ohms", "short"});
  const auto at = fieldIoAt(j, t.card);
  const auto n =
      index(j, "output", at.sevenI76 ? model::remote::SevenI76FieldIo::kOutputs : model::remote::FieldIoProcessor::kOutputs);
  double ohms = std::numeric_limits<double>::infinity();  // {} or null: an open terminal
  if (flag(j, "short", false))
    ohms = 0;
  else if (j.contains("ohms") && !j.at("ohms").is_null())
    ohms = number(j, "ohms", std::numeric_limits<double>::min(), kMaxOhms,
                  fmt::format("above 0 and at most {:g}, or null for an open output (\"short\": true "
                              "for a short)",
                              kMaxOhms));
  model::hm2::Terminals(t.card).setOutputLoad(at, n, ohms);
}

void overtempAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"connector", "chip", "hot"});
  const auto d = connector(j, t.card);
  model::hm2::Terminals(t.card).setDriverOverTemperature(d, index(j, "chip", model::remote::FieldIoProcessor::kChips),
                                                  flag(j, "hot"));
}

void timeAction(const ApiTarget& t, const json& j) {
  fields::onlyKnown(j, {"speed", "paused", "step_ms"});
  // On the host clock a period passes per host cycle: no speed to set
  // (pausing and stepping by hand still work).
  if (j.contains("speed") && t.clock.source() == SimClock::Source::Host)
    throw std::invalid_argument(
        "\"speed\": time follows the host's servo cycles (lbpkit sim --clock host); a speed applies to the wall clock "
        "only");
  const double speed =
      j.contains("speed")
          ? number(j, "speed", std::numeric_limits<double>::min(), kMaxSpeed,
                   fmt::format("above 0 and at most {:g} (simulated seconds per second)", kMaxSpeed))
          : t.clock.speed();
  const double step = j.contains("step_ms") ? number(j, "step_ms", 0, kMaxStepMs, "from 0 to 60000") : 0;
  t.clock.set(speed, flag(j, "paused", t.clock.paused()));
  if (step > 0) t.clock.advanceBy(model::lbp::SimTime{static_cast<std::int64_t>(step * 1e6)});
}

constexpr std::pair<std::string_view, Action> kActions[] = {
    {"input", inputAction},
    {"field", fieldAction},
    {"encoder", encoderAction},
    {"cable", cableAction},
    {"output", outputAction},
    {"overtemp", overtempAction},
    {"time", timeAction},
    {"network", networkAction},
    {"link", linkAction},
    {"machine", machineRouteAction},
};

}  // namespace

void applyAction(const ApiTarget& t, std::string_view kind, const json& body) {
  for (const auto& [name, action] : kActions)
    if (name == kind) return action(t, body);
  std::vector<std::string_view> names;
  for (const auto& a : kActions) names.push_back(a.first);
  throw std::invalid_argument(fmt::format("no fault or action \"{}\" (there are {})", kind, listed(names)));
}

std::vector<std::string> actionKinds() {
  std::vector<std::string> names;
  for (const auto& a : kActions) names.emplace_back(a.first);
  return names;
}

namespace {

// A route's handler: `work(req)` gives the JSON of a 200 answer; what it
// throws is the client's fault (400), a machine that is not there (404) or
// the card thread busy or the sim stopping (503), each with its reason.
template <class Work>
auto answered(Work work) {
  return [work](const httplib::Request& req, httplib::Response& res) {
    auto answer = [&res](int status, const std::string& content) {
      res.status = status;
      res.set_content(content, "application/json");
    };
    try {
      answer(200, work(req));
    } catch (const NoMachine& e) {
      answer(404, json{{"error", e.what()}}.dump());
    } catch (const std::invalid_argument& e) {
      answer(400, json{{"error", e.what()}}.dump());
    } catch (const std::exception& e) {
      answer(503, json{{"error", e.what()}}.dump());
    }
  };
}

void addMachineRoutes(httplib::Server& http, const ApiTarget& t, const CardThreadRunner& run) {
  // Whether there is a machine never changes: said at once, without the card thread.
  http.Get("/api/machine", answered([t, run](const httplib::Request&) {
             if (t.machine == nullptr) throw NoMachine();
             return run([t] { return t.machineState(); });
           }));
  http.Post("/api/machine", answered([t, run](const httplib::Request& req) {
              if (t.machine == nullptr) throw NoMachine();
              return run([t, j = body(req)] {
                machineRouteAction(t, j);
                return t.machineState();
              });
            }));
  http.Get("/api/machine/trace", answered([t](const httplib::Request& req) {
             if (t.trace == nullptr) throw NoMachine();
             return traceJson(*t.trace, req);
           }));
}

void addRoutes(httplib::Server& http, const ApiTarget& t, const CardThreadRunner& run) {
  auto handle = [run](Route route) {
    // The job owns what it needs: if it outlives this request (a timeout),
    // nothing it touches has gone away.
    return answered([run, route](const httplib::Request& req) {
      return run([route, j = body(req)] { return route(j); });
    });
  };
  // Each route holds a copy of the target (references and the state
  // function), so a job stays valid whichever request it came from. Changes
  // happen at the card's own time (it may lag the clock while it catches up).
  http.Get("/api/state", handle([t](const json&) { return t.state(); }));
  addMachineRoutes(http, t, run);
  // The network: what is set and what it did.
  auto network = [t] {
    if (t.udp == nullptr) throw std::invalid_argument("this sim has no network to disturb");
    const auto now = NetworkFaults::Clock::now();
    NetworkSnapshot s{t.udp->faults().settings(), t.udp->faults().counters(), t.udp->faults().silentFor(now),
                      t.udp->held()};
    return Answer{[s] { return toJson(s).dump(); }};
  };
  http.Get("/api/network", handle([network](const json&) { return network(); }));
  http.Post("/api/network", handle([t, network](const json& j) {
              networkAction(t, j);
              return network();
            }));
  // The RS-422 links: GET and POST answer what GET /api/link shows.
  auto link = [t] {
    const auto s = takeLinkSnapshots(t.card.part<model::hm2::Sslbp>(), t.card.now());
    return Answer{[s] { return toJson(s).dump(); }};
  };
  http.Get("/api/link", handle([link](const json&) { return link(); }));
  http.Post("/api/link", handle([t, link](const json& j) {
              linkAction(t, j);
              return link();
            }));
  // Every other POST /api/KIND carries out its action and answers the state.
  for (const auto& [name, action] : kActions) {
    if (name == "network" || name == "machine" || name == "link") continue;
    http.Post("/api/" + std::string(name), handle([t, action = action](const json& j) {
                action(t, j);
                return t.state();
              }));
  }
}

// --- Who may use the API (checked before anything is read or done).

// Whether HOST[:PORT] names this API: its own address, the address the
// client reached it on, or localhost when that is a loopback address. A
// page whose DNS name was rebound to 127.0.0.1 still sends its own name.
bool isOwnHost(const std::string& hostPort, const std::string& configured, const std::string& local, int port) {
  const auto colon = hostPort.rfind(':');
  const std::string host = lbpkit::wire::asciiLower(hostPort.substr(0, colon));
  const std::string p = colon == std::string::npos ? "80" : hostPort.substr(colon + 1);
  if (p != std::to_string(port)) return false;
  if (host == local || (host == configured && configured != "0.0.0.0")) return true;
  return host == "localhost" && local.rfind("127.", 0) == 0;
}

// Compares in time independent of where they differ.
bool sameSecret(std::string_view a, std::string_view b) {
  if (b.empty()) return a.empty();
  unsigned diff = a.size() == b.size() ? 0U : 1U;
  for (std::size_t i = 0; i < a.size(); ++i)
    diff |= static_cast<unsigned>(static_cast<unsigned char>(a[i]) ^ static_cast<unsigned char>(b[i % std::max<std::size_t>(b.size(), 1)]));
  return diff == 0;
}

// The web view's token, once a browser has brought it (/?token=TOKEN).
constexpr const char* kTokenCookie = "lbpkit_token";

// The value of cookie `name` in the request's Cookie header, or empty.
std::string cookie(const httplib::Request& req, std::string_view name) {
  const auto header = req.get_header_value("Cookie");
  std::size_t at = 0;
  while (at < header.size()) {
    const auto end = std::min(header.find(';', at), header.size());
    auto pair = std::string_view(header).substr(at, end - at);
    while (!pair.empty() && pair.front() == ' ') pair.remove_prefix(1);
    if (pair.size() > name.size() && pair.substr(0, name.size()) == name && pair[name.size()] == '=')
      return std::string(pair.substr(name.size() + 1));
    at = end + 1;
  }
  return {};
}

httplib::Server::HandlerResponse refuse(httplib::Response& res, int status, const std::string& why) {
  res.status = status;
  res.set_content(json{{"error", why}}.dump(), "application/json");
  return httplib::Server::HandlerResponse::Handled;
}

void addChecks(httplib::Server& http, const ApiOptions& o, int port) {
  http.set_pre_routing_handler([o, port](const httplib::Request& req, httplib::Response& res) {
    // Two of them would leave which one counts to whoever reads first: none
    // is taken.
    for (const char* once : {"Host", "Origin", "Authorization", "Cookie"})
      if (req.get_header_value_count(once) > 1)
        return refuse(res, 400, fmt::format("{} is given more than once: refused", once));
    const auto host = req.get_header_value("Host");
    if (!isOwnHost(host, o.address, req.local_addr, port))
      return refuse(res, 403,
                    fmt::format("Host \"{}\" is not this API ({}:{}): refused, as a page rebound to this address "
                                "by DNS would send it",
                                host, req.local_addr, port));
    // Browsers send Origin with every cross-origin POST, even the "simple"
    // text/plain ones they send without asking first.
    if (req.has_header("Origin")) {
      const auto origin = req.get_header_value("Origin");
      if (origin.rfind("http://", 0) != 0 || !isOwnHost(origin.substr(7), o.address, req.local_addr, port))
        return refuse(res, 403, fmt::format("requests from web pages of another origin ({}) are refused", origin));
    }
    if (!o.token.empty()) {
      const auto auth = req.get_header_value("Authorization");
      const bool bearer = auth.rfind("Bearer ", 0) == 0 && sameSecret(auth.substr(7), o.token);
      if (!bearer && !sameSecret(cookie(req, kTokenCookie), o.token)) {
        // A browser opening the web view cannot send a header: the token
        // comes once in the address (/?token=TOKEN) and goes back as a
        // cookie that only this API's own pages send (SameSite=Strict) and
        // no script can read (HttpOnly); the address it came in is replaced.
        if (req.method == "GET" && req.path == "/" && req.has_param("token")) {
          if (sameSecret(req.get_param_value("token"), o.token)) {
            res.status = 303;
            res.set_header("Location", "/");
            res.set_header("Set-Cookie", fmt::format("{}={}; HttpOnly; SameSite=Strict; Path=/", kTokenCookie, o.token));
            res.set_header("Cache-Control", "no-store");
            return httplib::Server::HandlerResponse::Handled;
          }
        }
        res.set_header("WWW-Authenticate", "Bearer");
        return refuse(res, 401, "this API needs \"Authorization: Bearer TOKEN\" with its token (--api-token or "
                                "LBPKIT_API_TOKEN); a browser opens the web view as /?token=TOKEN");
      }
    }
    if (req.method == "POST") {
      auto type = req.get_header_value("Content-Type");
      type = lbpkit::wire::asciiLower(type.substr(0, type.find(';')));
      type.erase(std::remove(type.begin(), type.end(), ' '), type.end());
      if (type != "application/json")
        return refuse(res, 415, "POST bodies must be JSON sent as Content-Type: application/json (curl: -H "
                                "'Content-Type: application/json')");
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // What httplib answers by itself (no such route, a request it cannot
  // parse) is JSON too.
  http.set_error_handler(httplib::Server::HandlerWithResponse([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    const std::string why = res.status == 404 ? fmt::format("no such route: {} {}", req.method, req.path)
                                              : fmt::format("HTTP {}", res.status);
    res.set_content(json{{"error", why}}.dump(), "application/json");
    return httplib::Server::HandlerResponse::Handled;
  }));
}

}  // namespace

void addApiRoutes(httplib::Server& http, const ApiOptions& options, int port, const ApiTarget& target,
                  const CardThreadRunner& run) {
  addChecks(http, options, port);
  addRoutes(http, target, run);
}

}  // namespace lbpkit::server
