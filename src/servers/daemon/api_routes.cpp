#include "daemon/api_routes.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>
#include <httplib.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <vector>

#include "daemon/link_api.hpp"
#include "daemon/network_api.hpp"
#include "daemon/request_fields.hpp"
#include "daemon/state_json.hpp"
#include "daemon/web_view.hpp"

namespace net {

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
unsigned connector(const json& j, hm2::HostMot2Card& card) {
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
remote::SevenI76FieldIo* sevenI76At(const json& j, hm2::HostMot2Card& card) {
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

// --- The machine (issue 10): GET /api/machine, POST /api/machine actions,
// GET /api/machine/trace.

// A route about a machine the sim does not have.
struct NoMachine : std::runtime_error {
  NoMachine() : std::runtime_error("no machine is loaded (start the sim with --machine mill, lathe, gantry or FILE)") {}
};

std::string axisNames(const machine::Machine& m) {
  std::vector<std::string> names;
  for (const auto& a : m.description().axes) names.push_back(a.name);
  return listed(names);
}

// The outside world's reach: a push as far as any machine travels, as fast
// as any axis could be shoved.
constexpr double kMaxPush = 1e6;
constexpr double kMaxPushSpeed = 1e5;
constexpr double kDefaultPushSpeed = 20.0;

void machineAction(machine::Machine& m, const json& j) {
  const std::string action = text(j, "action");
  auto axis = [&]() {
    const std::string name = text(j, "axis");
    if (const auto i = m.axisIndex(name)) return *i;
    throw std::invalid_argument(
        fmt::format("\"axis\": this machine has no axis \"{}\" (it has {})", name, axisNames(m)));
  };
  // Everything is checked before anything changes.
  if (action == "push") {
    const auto a = axis();
    const double distance = number(j, "distance", -kMaxPush, kMaxPush,
                                   fmt::format("from {:g} to {:g} (machine units)", -kMaxPush, kMaxPush));
    const double speed = j.contains("speed") ? number(j, "speed", std::numeric_limits<double>::min(), kMaxPushSpeed,
                                                      fmt::format("above 0 and at most {:g} (machine units per second)",
                                                                  kMaxPushSpeed))
                                             : kDefaultPushSpeed;
    m.push(a, distance, speed);
  } else if (action == "jam") {
    const auto a = axis();
    m.setJammed(a, flag(j, "jammed"));
  } else if (action == "encoder") {
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
    const std::string channelName = text(j, "channel");
    machine::EncoderChannel channel{};
    if (channelName == "A")
      channel = machine::EncoderChannel::A;
    else if (channelName == "B")
      channel = machine::EncoderChannel::B;
    else if (channelName == "index")
      channel = machine::EncoderChannel::Index;
    else
      throw std::invalid_argument("\"channel\" must be \"A\", \"B\" or \"index\"");
    const bool broken = flag(j, "broken");
    if (a)
      m.setEncoderBroken(*a, drive, channel, broken);
    else if (!m.setSpindleEncoderBroken(channel, broken))
      throw std::invalid_argument(m.spindle() ? "\"axis\": this machine's spindle has no encoder"
                                              : "\"axis\": this machine has no spindle");
  } else if (action == "estop") {
    const bool pressed = flag(j, "pressed");
    if (m.setSwitches(machine::SwitchKind::Estop, pressed) == 0)
      throw std::invalid_argument("\"action\": this machine has no E-stop switch");
  } else if (action == "probe") {
    const bool touching = flag(j, "touching");
    if (m.setSwitches(machine::SwitchKind::Probe, touching) == 0)
      throw std::invalid_argument("\"action\": this machine has no probe");
  } else if (action == "switch") {
    const std::string name = text(j, "name");
    const bool tripped = flag(j, "tripped");
    if (!m.setSwitch(name, tripped)) {
      std::vector<std::string> names;
      for (const auto& sw : m.description().switches) names.push_back(sw.name);
      throw std::invalid_argument(
          fmt::format("\"name\": this machine has no switch \"{}\" (it has {})", name, listed(names)));
    }
  } else {
    throw std::invalid_argument("\"action\" must be one of push, jam, encoder, estop, probe, switch");
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

void linkAction(const ApiTarget& t, const json& j) { applyLink(t.card.smartSerial(), j, t.card.now()); }

void networkAction(const ApiTarget& t, const json& j) {
  if (t.udp == nullptr) throw std::invalid_argument("this sim has no network to disturb");
  applyNetwork(t.udp->faults(), j, NetworkFaults::Clock::now());
}

void machineRouteAction(const ApiTarget& t, const json& j) {
  if (t.machine == nullptr) throw NoMachine();
  machineAction(*t.machine, j);
}

void inputAction(const ApiTarget& t, const json& j) {
  if (auto* i76 = sevenI76At(j, t.card)) {
    const auto n = index(j, "input", remote::SevenI76FieldIo::kInputs);
    i76->setInputVoltage(n, j.contains("volts") ? number(j, "volts", 0, kMaxVolts, kVoltsRange)
                                                : (flag(j, "on") ? i76->fieldVoltage() : 0.0));
    return;
  }
  auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
  const auto n = index(j, "input", remote::FieldIoProcessor::kInputs);
  const double v = j.contains("volts") ? number(j, "volts", 0, kMaxVolts, kVoltsRange)
                                       : (flag(j, "on") ? io.fieldVoltage() : 0.0);
  io.setInputVoltage(n, v);
}

void fieldAction(const ApiTarget& t, const json& j) {
  if (auto* i76 = sevenI76At(j, t.card)) {
    // Its processor runs from field power (seven_i76.hpp): it has no VIN.
    if (j.contains("vin")) throw std::invalid_argument("\"vin\": the 7I76 has no VIN (it runs from field power)");
    i76->setFieldVoltage(number(j, "volts", 0, kMaxVolts, kVoltsRange), t.card.now());
    return;
  }
  auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
  // Both checked before either changes anything.
  const bool volts = j.contains("volts"), vin = j.contains("vin");
  const double v = volts ? number(j, "volts", 0, kMaxVolts, kVoltsRange) : 0;
  const double w = vin ? number(j, "vin", 0, kMaxVolts, kVoltsRange) : 0;
  if (volts) io.setFieldVoltage(v, t.card.now());
  if (vin) io.setVin(w, t.card.now());
}

void encoderAction(const ApiTarget& t, const json& j) {
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
  auto& enc = t.card.encoders();
  if (cpr) enc.setIndexPeriod(n, static_cast<std::uint32_t>(c));
  if (vel) enc.setVelocity(n, v, t.card.now());
}

void cableAction(const ApiTarget& t, const json& j) {
  const auto ch = index(j, "channel", t.card.smartSerial().channels());
  t.card.smartSerial().link(ch).setConnected(flag(j, "connected"));
}

void outputAction(const ApiTarget& t, const json& j) {
  auto* i76 = sevenI76At(j, t.card);
  auto* io = i76 != nullptr ? nullptr : &t.card.daughtercard(connector(j, t.card)).fieldIo;
  const auto n = index(j, "output", i76 != nullptr ? remote::SevenI76FieldIo::kOutputs : remote::FieldIoProcessor::kOutputs);
  double ohms = std::numeric_limits<double>::infinity();  // {} or null: an open terminal
  if (flag(j, "short", false))
    ohms = 0;
  else if (j.contains("ohms") && !j.at("ohms").is_null())
    ohms = number(j, "ohms", std::numeric_limits<double>::min(), kMaxOhms,
                  fmt::format("above 0 and at most {:g}, or null for an open output (\"short\": true "
                              "for a short)",
                              kMaxOhms));
  if (i76 != nullptr)
    i76->setOutputLoad(n, ohms);
  else
    io->setOutputLoad(n, ohms);
}

void overtempAction(const ApiTarget& t, const json& j) {
  auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
  io.setDriverOverTemperature(index(j, "chip", remote::FieldIoProcessor::kChips), flag(j, "hot"));
}

void timeAction(const ApiTarget& t, const json& j) {
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
  if (step > 0) t.clock.advanceBy(lbp::SimTime{static_cast<std::int64_t>(step * 1e6)});
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

void addMachineRoutes(httplib::Server& http, const ApiTarget& t, const CardThreadRunner& run) {
  // Whether there is a machine never changes: said at once, without the card thread.
  auto answer = [](httplib::Response& res, int status, const std::string& content) {
    res.status = status;
    res.set_content(content, "application/json");
  };
  auto guarded = [answer](auto&& work) {
    return [answer, work](const httplib::Request& req, httplib::Response& res) {
      try {
        answer(res, 200, work(req));
      } catch (const NoMachine& e) {
        answer(res, 404, json{{"error", e.what()}}.dump());
      } catch (const std::invalid_argument& e) {
        answer(res, 400, json{{"error", e.what()}}.dump());
      } catch (const std::exception& e) {
        answer(res, 503, json{{"error", e.what()}}.dump());  // the card thread is busy, or the sim is stopping
      }
    };
  };
  http.Get("/api/machine", guarded([t, run](const httplib::Request&) {
             if (t.machine == nullptr) throw NoMachine();
             return run([t] { return t.machineState(); });
           }));
  http.Post("/api/machine", guarded([t, run](const httplib::Request& req) {
              if (t.machine == nullptr) throw NoMachine();
              return run([t, j = body(req)] {
                machineRouteAction(t, j);
                return t.machineState();
              });
            }));
  http.Get("/api/machine/trace", guarded([t](const httplib::Request& req) {
             if (t.trace == nullptr) throw NoMachine();
             return traceJson(*t.trace, req);
           }));
}

void addRoutes(httplib::Server& http, const ApiTarget& t, const CardThreadRunner& run) {
  auto handle = [run](Route route) {
    return [run, route](const httplib::Request& req, httplib::Response& res) {
      try {
        // The job owns what it needs: if it outlives this request (a timeout),
        // nothing it touches has gone away.
        res.set_content(run([route, j = body(req)] { return route(j); }), "application/json");
      } catch (const std::invalid_argument& e) {
        res.status = 400;
        res.set_content(json{{"error", e.what()}}.dump(), "application/json");
      } catch (const std::exception& e) {
        res.status = 503;  // the card thread is busy, or the sim is stopping
        res.set_content(json{{"error", e.what()}}.dump(), "application/json");
      }
    };
  };
  // Each route holds a copy of the target (references and the state
  // function), so a job stays valid whichever request it came from. Changes
  // happen at the card's own time (it may lag the clock while it catches up).
  http.Get("/api/state", handle([t](const json&) { return t.state(); }));
  addMachineRoutes(http, t, run);
  // The network (issue 13): what is set and what it did.
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
    const auto s = takeLinkSnapshots(t.card.smartSerial(), t.card.now());
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

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Whether HOST[:PORT] names this API: its own address, the address the
// client reached it on, or localhost when that is a loopback address. A
// page whose DNS name was rebound to 127.0.0.1 still sends its own name.
bool isOwnHost(const std::string& hostPort, const std::string& configured, const std::string& local, int port) {
  const auto colon = hostPort.rfind(':');
  const std::string host = lower(hostPort.substr(0, colon));
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

httplib::Server::HandlerResponse refuse(httplib::Response& res, int status, const std::string& why) {
  res.status = status;
  res.set_content(json{{"error", why}}.dump(), "application/json");
  return httplib::Server::HandlerResponse::Handled;
}

void addChecks(httplib::Server& http, const ApiOptions& o, int port) {
  http.set_pre_routing_handler([o, port](const httplib::Request& req, httplib::Response& res) {
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
      if (auth.rfind("Bearer ", 0) != 0 || !sameSecret(auth.substr(7), o.token)) {
        res.set_header("WWW-Authenticate", "Bearer");
        return refuse(res, 401, "this API needs \"Authorization: Bearer TOKEN\" with its token (--api-token or "
                                "LBPKIT_API_TOKEN)");
      }
    }
    if (req.method == "POST") {
      auto type = req.get_header_value("Content-Type");
      type = lower(type.substr(0, type.find(';')));
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

// --- Connections

// httplib parses a request, routes it and writes the answer; process_request
// is protected, so this is how it is reached.
class HttpEngine : public httplib::Server {
 public:
  bool answer(httplib::Stream& s, bool closeAfter, bool& closed) { return process_request(s, closeAfter, closed, nullptr); }
};

struct Connection {
  int fd = -1;
  std::string in;  // bytes received and not yet answered
  Clock::time_point since;  // accepted, or last answer sent
  Clock::time_point started;  // first byte of the request now arriving
  Clock::time_point drainUntil;
  std::size_t requestBytes = 0;  // of `in`: the whole request handed to a worker
  unsigned served = 0;
  bool draining = false;  // answered and half closed: reading what still comes, then closing
  bool continued = false;  // sent "100 Continue" for this request
  bool adopted = false;  // its socket goes to the web view's event stream (web_view.hpp)
  std::string peer, local;
  int peerPort = 0, localPort = 0;
  ~Connection() {
    if (fd >= 0) ::close(fd);
  }
};

using ConnectionPtr = std::unique_ptr<Connection>;

// The connection a worker is answering: GET /api/events marks it adopted.
thread_local Connection* answeringNow = nullptr;

std::string addressOf(const sockaddr_in& sa, int& port) {
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &sa.sin_addr, text, sizeof text);
  port = ntohs(sa.sin_port);
  return text;
}

// One whole request, read by the poller, as httplib reads it; the answer
// goes straight to the socket, within the write timeout from its first byte
// (the route may have waited for the card thread before).
class RequestStream final : public httplib::Stream {
 public:
  RequestStream(const Connection& c, std::chrono::milliseconds writeTimeout)
      : c_(c), request_(std::string_view(c.in).substr(0, c.requestBytes)), writeTimeout_(writeTimeout) {}
  bool is_readable() const override { return at_ < request_.size(); }
  bool is_writable() const override { return wait(POLLOUT); }
  ssize_t read(char* ptr, size_t size) override {
    const auto n = std::min(size, request_.size() - at_);
    std::memcpy(ptr, request_.data() + at_, n);
    at_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (c_.adopted) return static_cast<ssize_t>(size);  // the event stream writes its own answer
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::send(c_.fd, ptr + done, size - done, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        if (!wait(POLLOUT)) return -1;
      } else {
        return -1;
      }
    }
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.peer;
    port = c_.peerPort;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.local;
    port = c_.localPort;
  }
  socket_t socket() const override { return c_.fd; }

 private:
  bool wait(short events) const {
    if (deadline_ == Clock::time_point{}) deadline_ = Clock::now() + writeTimeout_;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{c_.fd, events, 0};
    return ::poll(&p, 1, static_cast<int>(left)) > 0 && (p.revents & events) && !(p.revents & (POLLERR | POLLHUP));
  }

  const Connection& c_;
  std::string_view request_;
  std::size_t at_ = 0;
  std::chrono::milliseconds writeTimeout_;
  mutable Clock::time_point deadline_{};  // set when writing first has to wait
};

// What the poller makes of the bytes a connection has sent so far.
enum class Verdict { Wait, Whole, Refused };

}  // namespace

struct ControlApi::Server {
  ApiOptions options;
  HttpEngine http;
  int listenFd = -1;
  int wakeFd = -1;
  std::atomic<bool> stopping{false};
  std::thread poller;
  std::vector<std::thread> workers;
  // Whole requests for the workers, connections back from them, and the
  // sockets they are answering on (shut down to stop them at once).
  std::mutex mutex;
  std::condition_variable ready;
  std::deque<ConnectionPtr> requests;
  std::vector<ConnectionPtr> returned;
  std::set<int> answering;
  std::atomic<unsigned> away{0};  // connections the poller has handed on
  std::unique_ptr<WebView> web;  // the page and its event stream (issue 14); gone before the rest

  ~Server() {
    if (listenFd >= 0) ::close(listenFd);
    if (wakeFd >= 0) ::close(wakeFd);
  }
  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wakeFd, &one, sizeof one);
  }
  void poll();
  void work();
  Verdict examine(Connection& c);
  void refuseAndClose(Connection& c, int status, const char* reason, const std::string& why);
};

void ControlApi::Server::refuseAndClose(Connection& c, int status, const char* reason, const std::string& why) {
  const auto content = json{{"error", why}}.dump();
  const auto text = fmt::format("HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n"
                                "Connection: close\r\n\r\n{}",
                                status, reason, content.size(), content);
  // Small, on a socket with nothing else queued: it fits its buffer. Then
  // half close and read what the client still sends for a while, so the
  // answer reaches it instead of a reset.
  [[maybe_unused]] const auto n = ::send(c.fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(c.fd, SHUT_WR);
  c.draining = true;
  c.drainUntil = Clock::now() + std::chrono::seconds(1);
  c.in.clear();
}

Verdict ControlApi::Server::examine(Connection& c) {
  const auto end = c.in.find("\r\n\r\n");
  if (end == std::string::npos) {
    if (c.in.size() <= options.maxHeader) return Verdict::Wait;
    refuseAndClose(c, 431, "Request Header Fields Too Large",
                   fmt::format("the request line and headers are over {} bytes", options.maxHeader));
    return Verdict::Refused;
  }
  const std::size_t head = end + 4;
  if (head > options.maxHeader) {
    refuseAndClose(c, 431, "Request Header Fields Too Large",
                   fmt::format("the request line and headers are over {} bytes", options.maxHeader));
    return Verdict::Refused;
  }
  // The few headers that say how long the request is.
  std::size_t length = 0;
  bool expectContinue = false;
  std::size_t expectAt = std::string::npos;
  for (std::size_t at = c.in.find("\r\n") + 2; at < end;) {
    const auto eol = c.in.find("\r\n", at);
    const auto line = std::string_view(c.in).substr(at, eol - at);
    const auto colon = line.find(':');
    if (colon != std::string_view::npos) {
      const auto name = lower(std::string(line.substr(0, colon)));
      auto value = line.substr(colon + 1);
      while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
      while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
      if (name == "transfer-encoding") {
        refuseAndClose(c, 411, "Length Required",
                       fmt::format("send bodies with a Content-Length (at most {} bytes), not {}", options.maxBody,
                                   std::string(value)));
        return Verdict::Refused;
      }
      if (name == "content-length") {
        if (value.empty() || value.size() > 12 || value.find_first_not_of("0123456789") != std::string_view::npos) {
          refuseAndClose(c, 400, "Bad Request", "Content-Length is not a number");
          return Verdict::Refused;
        }
        length = std::stoull(std::string(value));
        if (length > options.maxBody) {
          refuseAndClose(c, 413, "Payload Too Large",
                         fmt::format("the body is too large: {} bytes, at most {}", length, options.maxBody));
          return Verdict::Refused;
        }
      }
      if (name == "expect" && lower(std::string(value)) == "100-continue") {
        expectContinue = true;
        expectAt = at;
      }
    }
    at = eol + 2;
  }
  if (c.in.size() >= head + length) {
    c.requestBytes = head + length;
    return Verdict::Whole;
  }
  if (expectContinue && !c.continued) {
    // The client waits for this before it sends the body. Said here, where
    // the body is waited for; the header is renamed (same length) so httplib
    // does not say it a second time.
    static constexpr char kContinue[] = "HTTP/1.1 100 Continue\r\n\r\n";
    [[maybe_unused]] const auto n = ::send(c.fd, kContinue, sizeof kContinue - 1, MSG_NOSIGNAL | MSG_DONTWAIT);
    c.in[expectAt] = 'X';
    c.continued = true;
  }
  return Verdict::Wait;
}

// The one thread that waits on clients: it accepts, reads requests until
// they are whole, enforces the timeouts and the connection cap, and hands
// whole requests to the workers. A slow or idle client costs a socket here,
// never a worker.
void ControlApi::Server::poll() {
  std::vector<ConnectionPtr> conns;
  std::vector<pollfd> fds;
  Clock::time_point acceptPausedUntil{};
  auto hand = [&](ConnectionPtr c) {
    ++away;
    {
      std::lock_guard<std::mutex> lock(mutex);
      requests.push_back(std::move(c));
    }
    ready.notify_one();
  };
  while (!stopping) {
    const auto now = Clock::now();
    {
      std::vector<ConnectionPtr> back;
      {
        std::lock_guard<std::mutex> lock(mutex);
        back.swap(returned);
      }
      for (auto& c : back) {
        --away;
        c->since = c->started = now;
        c->continued = false;
        // Pipelined bytes of the next request may already be here.
        if (!c->in.empty() && examine(*c) == Verdict::Whole)
          hand(std::move(c));
        else
          conns.push_back(std::move(c));
      }
    }
    // Deadlines: idle, a request too slow to arrive, draining done.
    auto next = now + std::chrono::seconds(1);
    for (auto& c : conns) {
      Clock::time_point due;
      if (c->draining)
        due = c->drainUntil;
      else if (!c->in.empty())
        due = c->started + options.requestTimeout;
      else
        due = c->since + options.idleTimeout;
      if (due <= now) {
        if (!c->draining && !c->in.empty()) {
          refuseAndClose(*c, 408, "Request Timeout",
                         fmt::format("the request did not arrive whole within {} ms", options.requestTimeout.count()));
          due = c->drainUntil;
        } else {
          c.reset();
          continue;
        }
      }
      next = std::min(next, due);
    }
    std::erase(conns, nullptr);

    fds.clear();
    fds.push_back({wakeFd, POLLIN, 0});
    const bool accepting = now >= acceptPausedUntil;
    fds.push_back({accepting ? listenFd : -1, POLLIN, 0});
    for (auto& c : conns) fds.push_back({c->fd, POLLIN, 0});
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count() + 1;
    if (::poll(fds.data(), fds.size(), static_cast<int>(std::clamp<long long>(wait, 0, 1000))) < 0) continue;
    if (stopping) break;
    if (fds[0].revents & POLLIN) {
      std::uint64_t count = 0;
      [[maybe_unused]] const auto n = ::read(wakeFd, &count, sizeof count);
    }
    // Reads first: a request that is whole goes before new connections can
    // push its connection out.
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      auto& c = conns[i - 2];
      char buf[16384];
      const ssize_t n = ::recv(c->fd, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        c.reset();
        continue;
      }
      if (n < 0 || c->draining) continue;
      if (c->in.empty()) c->started = Clock::now();
      c->in.append(buf, static_cast<std::size_t>(n));
      if (examine(*c) == Verdict::Whole) hand(std::move(c));
    }
    std::erase(conns, nullptr);
    if (accepting && (fds[1].revents & POLLIN)) {
      for (;;) {
        sockaddr_in peer{};
        socklen_t len = sizeof peer;
        const int fd = ::accept4(listenFd, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
          // Out of descriptors: the connection stays queued; try again soon
          // instead of spinning on it.
          if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM)
            acceptPausedUntil = Clock::now() + std::chrono::milliseconds(100);
          break;
        }
        auto c = std::make_unique<Connection>();
        c->fd = fd;
        c->since = Clock::now();
        c->peer = addressOf(peer, c->peerPort);
        sockaddr_in local{};
        len = sizeof local;
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &len);
        c->local = addressOf(local, c->localPort);
        const int on = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
        // The cap: make room by closing the connection that has waited
        // longest on its client; when every one is being answered, this one
        // goes.
        if (conns.size() + away >= options.maxConnections) {
          if (conns.empty()) continue;  // c closes as it goes
          std::iter_swap(std::min_element(conns.begin(), conns.end(),
                                          [](const auto& a, const auto& b) { return a->since < b->since; }),
                         conns.end() - 1);
          conns.pop_back();
        }
        conns.push_back(std::move(c));
      }
    }
  }
  conns.clear();
}

// A worker: answers whole requests, then gives the connection back to the
// poller to wait for its next one.
void ControlApi::Server::work() {
  for (;;) {
    ConnectionPtr c;
    {
      std::unique_lock<std::mutex> lock(mutex);
      ready.wait(lock, [this] { return stopping || !requests.empty(); });
      if (stopping) return;
      c = std::move(requests.front());
      requests.pop_front();
      answering.insert(c->fd);
    }
    const bool last = ++c->served >= options.maxRequestsPerConnection;
    bool closed = false;
    bool ok = false;
    {
      RequestStream s(*c, options.writeTimeout);
      answeringNow = c.get();
      ok = http.answer(s, last, closed);
      answeringNow = nullptr;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      answering.erase(c->fd);
      if (c->adopted) {
        --away;
        web->adopt(std::exchange(c->fd, -1));
      } else if (ok && !closed && !last && !stopping) {
        c->in.erase(0, c->requestBytes);
        c->requestBytes = 0;
        returned.push_back(std::move(c));
      } else {
        --away;
      }
    }
    wake();
  }
}

ControlApi::ControlApi(const ApiOptions& options, ApiTarget target, CardThreadRunner run)
    : server_(std::make_unique<Server>()) {
  auto& s = *server_;
  s.options = options;
  // The listening socket is ours, bound without SO_REUSEPORT (httplib sets
  // it): a second sim on the same port must fail, not share it and get
  // half the requests. SO_REUSEADDR only lets a restarted sim have its port
  // back while old connections linger.
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(options.port));
  if (::inet_pton(AF_INET, options.address.c_str(), &sa.sin_addr) != 1)
    throw std::runtime_error(fmt::format("control API: \"{}\" is not an IPv4 address", options.address));
  s.listenFd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  s.wakeFd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (s.listenFd < 0 || s.wakeFd < 0)
    throw std::runtime_error(fmt::format("control API: cannot create a socket: {}", std::strerror(errno)));
  const int on = 1;
  ::setsockopt(s.listenFd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (::bind(s.listenFd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    if (errno == EADDRINUSE)
      throw std::runtime_error(fmt::format("control API port {}:{} is in use (another lbpkit sim?); --api 0 picks a "
                                           "free one",
                                           options.address, options.port));
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{}: {}", options.address, options.port,
                                         std::strerror(errno)));
  }
  if (::listen(s.listenFd, 128) != 0)
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{}: {}", options.address, options.port,
                                         std::strerror(errno)));
  socklen_t len = sizeof sa;
  ::getsockname(s.listenFd, reinterpret_cast<sockaddr*>(&sa), &len);
  port_ = ntohs(sa.sin_port);

  auto& http = s.http;
  http.set_payload_max_length(options.maxBody);
  http.set_keep_alive_max_count(options.maxRequestsPerConnection);  // what its Keep-Alive header says
  http.set_keep_alive_timeout(std::max<time_t>(1, static_cast<time_t>(options.idleTimeout.count() / 1000)));
  addChecks(http, options, port_);
  addRoutes(http, target, run);
  s.web = std::make_unique<WebView>(target, run);
  s.web->addRoutes(http, [] {
    if (answeringNow != nullptr) answeringNow->adopted = true;
  });
  s.poller = std::thread([this] { server_->poll(); });
  for (unsigned i = 0; i < std::max(1U, options.workers); ++i) s.workers.emplace_back([this] { server_->work(); });
}

ControlApi::~ControlApi() {
  auto& s = *server_;
  {
    // Under the lock, so no worker takes a request after the sockets being
    // answered are shut down: a worker writing to a client that does not
    // read, or reading nothing, returns at once.
    std::lock_guard<std::mutex> lock(s.mutex);
    s.stopping = true;
    for (const int fd : s.answering) ::shutdown(fd, SHUT_RDWR);
  }
  s.ready.notify_all();
  s.wake();
  if (s.poller.joinable()) s.poller.join();
  for (auto& w : s.workers)
    if (w.joinable()) w.join();
}

}  // namespace net
