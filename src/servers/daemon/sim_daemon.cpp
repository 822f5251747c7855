#include "daemon/sim_daemon.hpp"

#include <httplib.h>
#include <pthread.h>
#include <sched.h>
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <type_traits>

#include "lbp16/udp_server.hpp"

namespace net {

using nlohmann::json;

// --- SimClock ---------------------------------------------------------------------

SimClock::SimClock(double speed, bool paused) : wallBase_(Wall::now()), speed_(speed), paused_(paused) {}

hm2::SimTime SimClock::now() const {
  if (paused_) return simBase_;
  const auto wall = std::chrono::duration<double, std::nano>(Wall::now() - wallBase_).count();
  return simBase_ + hm2::SimTime{static_cast<std::int64_t>(wall * speed_)};
}

void SimClock::set(double speed, bool paused) {
  simBase_ = now();
  wallBase_ = Wall::now();
  speed_ = speed;
  paused_ = paused;
}

void SimClock::advanceBy(hm2::SimTime t) {
  simBase_ = now() + t;
  wallBase_ = Wall::now();
}

// --- The control API ------------------------------------------------------------

struct SimDaemon::Api {
  httplib::Server server;
  std::thread thread;
};

namespace {

json faultList(std::uint8_t faults) {
  json a = json::array();
  for (unsigned b = 0; b < 8; ++b)
    if ((static_cast<unsigned>(faults) >> b) & 1U) a.push_back(std::string(remote::fault::kNames[b]));
  return a;
}

json body(const httplib::Request& req) {
  if (req.body.empty()) return json::object();
  auto j = json::parse(req.body, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw std::invalid_argument("the request body is not a JSON object");
  return j;
}

template <typename T>
T need(const json& j, const char* key) {
  if (!j.contains(key)) throw std::invalid_argument(std::string("missing \"") + key + "\"");
  const auto& v = j.at(key);
  if constexpr (std::is_same_v<T, bool>) {
    if (!v.is_boolean()) throw std::invalid_argument(std::string("\"") + key + "\" must be true or false");
  } else if constexpr (std::is_integral_v<T>) {
    if (!v.is_number_unsigned() || v.get<std::uint64_t>() > std::numeric_limits<T>::max())
      throw std::invalid_argument(std::string("\"") + key + "\" must be a whole number from 0");
  } else {
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      throw std::invalid_argument(std::string("\"") + key + "\" must be a number");
  }
  return v.get<T>();
}

}  // namespace

std::string SimDaemon::stateJson() {
  const auto now = clock_.now();
  card_.advance(now);
  json s;
  s["time_s"] = std::chrono::duration<double>(now).count();
  s["clock"] = {{"speed", clock_.speed()}, {"paused", clock_.paused()}};
  const auto& id = lbp16_->identity();
  s["card"] = {{"name", id.name},
               {"address", options_.bindAddress},
               {"port", udp_->port()},
               {"mac", fmt::format("{:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}", id.mac[0], id.mac[1], id.mac[2],
                                   id.mac[3], id.mac[4], id.mac[5])}};
  const auto& c = lbp16_->counters();
  s["lbp16"] = {{"packets", c.packets},
                {"replies", c.replies},
                {"parse_errors", c.parseErrors},
                {"memory_errors", c.memoryErrors},
                {"write_errors", c.writeErrors}};
  s["server"] = {{"datagrams", latency_.count},
                 {"scheduling", schedule_},
                 {"median_us", latency_.percentileUs(0.5)},
                 {"p99_us", latency_.percentileUs(0.99)},
                 {"max_us", static_cast<double>(latency_.maxNs) / 1000.0}};
  s["watchdog"] = {{"bitten", card_.watchdog().bitten()}, {"timer", card_.watchdog().timer(now)}};
  s["card_leds"] = card_.led().leds();
  auto& ss = card_.smartSerial();
  json chans = json::array();
  for (unsigned ch = 0; ch < ss.channels(); ++ch) {
    const auto cs = ss.csRegister(ch);
    const auto& lc = ss.link(ch).counters();
    chans.push_back({{"channel", ch},
                     {"running", ss.channelRunning(ch)},
                     {"cs", fmt::format("0x{:08X}", cs)},
                     {"remote_faults", faultList(static_cast<std::uint8_t>(cs >> 24))},
                     {"baud", ss.channelBaud(ch)},
                     {"cable_connected", ss.link(ch).connected()},
                     {"link",
                      {{"to_remote", lc.toRemote},
                       {"from_remote", lc.fromRemote},
                       {"corrupted", lc.corrupted},
                       {"dropped", lc.dropped},
                       {"added", lc.added},
                       {"breaks", lc.breaks}}}});
  }
  s["sserial"] = {{"command", fmt::format("0x{:04X}", ss.commandRegister())},
                  {"data", fmt::format("0x{:02X}", ss.dataRegister())},
                  {"doits", ss.counters().doits},
                  {"lost_commands", ss.counters().lostCommands},
                  {"channels", chans}};
  json boards = json::array();
  for (unsigned d = 0; d < card_.daughtercards(); ++d) {
    auto& b = card_.daughtercard(d);
    auto& io = b.fieldIo;
    json inputs = json::array(), outputs = json::array();
    for (unsigned i = 0; i < remote::FieldIoProcessor::kInputs; ++i)
      inputs.push_back({{"volts", io.inputVoltage(i)}, {"on", io.input(i)}});
    for (unsigned i = 0; i < remote::FieldIoProcessor::kOutputs; ++i)
      outputs.push_back({{"on", io.outputOn(i)},
                         {"volts", io.outputVoltage(i)},
                         {"amps", std::isinf(io.outputCurrent(i)) ? -1.0 : io.outputCurrent(i)},
                         {"tripped", io.outputTripped(i)}});
    json analogOut = json::array();
    for (unsigned ch = 0; ch < remote::AnalogProcessor::kChannels; ++ch)
      analogOut.push_back({{"volts", b.analog.outputVoltage(ch)}, {"code", b.analog.dacCode(ch)}, {"enable", b.analog.enable(ch)}});
    json enc = json::array();
    for (unsigned n = 0; n < 6; ++n) {
      const unsigned k = 6 * d + n;
      const auto& sig = card_.encoders().signal(k);
      enc.push_back({{"count", card_.encoders().count(k)},
                     {"position", sig.position},
                     {"velocity", sig.velocity},
                     {"counts_per_rev", sig.countsPerRev}});
    }
    boards.push_back(
        {{"connector", d},
         {"type", io.outputType() == remote::OutputType::Sinking ? "7I77D" : "7I77"},
         {"leds",
          {{"CR1", true}, {"CR3", io.fieldVoltageLed()}, {"CR6", true}, {"CR7", true}, {"CR15", io.activityLed()},
           {"CR16", io.faultLed()}}},
         {"field_io",
          {{"powered", io.powered()},
           {"field_voltage", io.fieldVoltage()},
           {"vin", io.vin()},
           {"mode", io.softwareMode()},
           {"unit_number", fmt::format("0x{:08X}", io.unitNumber())},
           {"watchdog_ms", io.watchdogTimeMs()},
           {"faults", faultList(io.faults())},
           {"baud", io.baud()},
           {"inputs", inputs},
           {"outputs", outputs},
           {"mpg", {io.mpgCount(0), io.mpgCount(1)}}}},
         {"analog",
          {{"powered", b.analog.powered()},
           {"unit_number", fmt::format("0x{:08X}", b.analog.unitNumber())},
           {"faults", faultList(b.analog.faults())},
           {"outputs", analogOut}}},
         {"encoders", enc}});
  }
  s["daughtercards"] = boards;
  return s.dump();
}

// --- The daemon ------------------------------------------------------------------

SimDaemon::SimDaemon(SimOptions options)
    : options_(std::move(options)), card_(options_.card), clock_(options_.speed, options_.paused) {
  udp_ = std::make_unique<UdpServer>(options_.bindAddress, options_.port);
  Lbp16Card::Identity id;
  std::array<std::uint8_t, 6> mac{};
  // hm2_eth pins an ARP entry to the MAC the card reports: it must be the
  // MAC of the interface we answer on.
  if (interfaceMac(options_.bindAddress, mac, interface_)) {
    id.mac = mac;
    macFromInterface_ = true;
  }
  unsigned a[4] = {127, 0, 0, 1};
  std::sscanf(options_.bindAddress.c_str(), "%u.%u.%u.%u", &a[0], &a[1], &a[2], &a[3]);
  for (int i = 0; i < 4; ++i) id.ip[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(a[i]);
  lbp16_ = std::make_unique<Lbp16Card>(card_, id);

  if (options_.apiPort < 0) return;
  api_ = std::make_unique<Api>();
  auto& srv = api_->server;
  auto handle = [this](std::function<std::string(const json&)> f) {
    return [this, f](const httplib::Request& req, httplib::Response& res) {
      try {
        // The job owns what it needs: if it outlives this request (a timeout),
        // nothing it touches has gone away.
        res.set_content(runJob([f, j = body(req)] { return f(j); }), "application/json");
      } catch (const std::exception& e) {
        res.status = 400;
        res.set_content(json{{"error", e.what()}}.dump(), "application/json");
      }
    };
  };
  auto board = [this](const json& j) -> hm2::SevenI77& {
    const auto d = j.contains("connector") ? need<unsigned>(j, "connector") : 0U;
    if (d >= card_.daughtercards()) throw std::invalid_argument(fmt::format("no 7I77 on connector {}", d));
    return card_.daughtercard(d);
  };
  auto index = [](const json& j, const char* key, unsigned limit) {
    const auto n = need<unsigned>(j, key);
    if (n >= limit) throw std::invalid_argument(fmt::format("\"{}\" must be below {}", key, limit));
    return n;
  };
  srv.Get("/api/state", handle([this](const json&) { return stateJson(); }));
  srv.Post("/api/input", handle([=, this](const json& j) {
             auto& io = board(j).fieldIo;
             const auto n = index(j, "input", remote::FieldIoProcessor::kInputs);
             const double v = j.contains("volts") ? need<double>(j, "volts") : (need<bool>(j, "on") ? io.fieldVoltage() : 0.0);
             io.setInputVoltage(n, v);
             return stateJson();
           }));
  srv.Post("/api/field", handle([=, this](const json& j) {
             auto& io = board(j).fieldIo;
             if (j.contains("volts")) io.setFieldVoltage(need<double>(j, "volts"), clock_.now());
             if (j.contains("vin")) io.setVin(need<double>(j, "vin"), clock_.now());
             return stateJson();
           }));
  srv.Post("/api/encoder", handle([=, this](const json& j) {
             (void)board(j);  // checks "connector"
             const auto n = index(j, "encoder", 6) + 6 * (j.contains("connector") ? need<unsigned>(j, "connector") : 0U);
             if (j.contains("counts_per_rev")) card_.encoders().setIndexPeriod(n, need<std::uint32_t>(j, "counts_per_rev"));
             if (j.contains("velocity")) card_.encoders().setVelocity(n, need<double>(j, "velocity"), clock_.now());
             return stateJson();
           }));
  srv.Post("/api/cable", handle([=, this](const json& j) {
             const auto ch = index(j, "channel", card_.smartSerial().channels());
             card_.smartSerial().link(ch).setConnected(need<bool>(j, "connected"));
             return stateJson();
           }));
  srv.Post("/api/output", handle([=, this](const json& j) {
             auto& io = board(j).fieldIo;
             const auto n = index(j, "output", remote::FieldIoProcessor::kOutputs);
             double ohms = std::numeric_limits<double>::infinity();
             if (j.value("short", false)) ohms = 0;
             else if (j.contains("ohms")) ohms = need<double>(j, "ohms");
             io.setOutputLoad(n, ohms);
             return stateJson();
           }));
  srv.Post("/api/overtemp", handle([=, this](const json& j) {
             board(j).fieldIo.setDriverOverTemperature(index(j, "chip", 2), need<bool>(j, "hot"));
             return stateJson();
           }));
  srv.Post("/api/time", handle([this](const json& j) {
             const double speed = j.value("speed", clock_.speed());
             if (!(speed > 0) || speed > 1000) throw std::invalid_argument("\"speed\" must be above 0 and at most 1000");
             double step = 0;
             if (j.contains("step_ms")) {
               step = need<double>(j, "step_ms");
               if (!(step >= 0) || step > 60000) throw std::invalid_argument("\"step_ms\" must be 0 to 60000");
             }
             clock_.set(speed, j.value("paused", clock_.paused()));
             if (step > 0) clock_.advanceBy(hm2::SimTime{static_cast<std::int64_t>(step * 1e6)});
             return stateJson();
           }));
  if (options_.apiPort == 0)
    apiPort_ = srv.bind_to_any_port(options_.apiAddress);
  else
    apiPort_ = srv.bind_to_port(options_.apiAddress, options_.apiPort) ? options_.apiPort : -1;
  if (apiPort_ < 0)
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{} (port in use? --api 0 picks a free one)",
                                         options_.apiAddress, options_.apiPort));
  api_->thread = std::thread([this] { api_->server.listen_after_bind(); });
}

SimDaemon::~SimDaemon() {
  if (api_) {
    api_->server.stop();
    if (api_->thread.joinable()) api_->thread.join();
  }
}

std::uint16_t SimDaemon::port() const { return udp_->port(); }

std::string SimDaemon::banner() const {
  const auto& id = lbp16_->identity();
  std::string s = fmt::format("lbpkit sim: virtual {} (HostMot2, SSLBP {}.{}) on UDP {}:{}\n", id.name,
                              hm2::SmartSerial::kMajorRevision, hm2::SmartSerial::kMinorRevision,
                              options_.bindAddress, udp_->port());
  s += fmt::format("  MAC {:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}{}\n", id.mac[0], id.mac[1], id.mac[2], id.mac[3],
                   id.mac[4], id.mac[5],
                   macFromInterface_ ? fmt::format(" (of {})", interface_) : std::string(" (locally administered)"));
  for (unsigned d = 0; d < card_.daughtercards(); ++d) {
    auto& b = const_cast<hm2::HostMot2Card&>(card_).daughtercard(d);
    s += fmt::format("  connector {}: {} field I/O unit 0x{:08X} on channel {}, analog unit 0x{:08X} on channel {}, "
                     "6 encoders, field {:.1f} V{}\n",
                     d, b.fieldIo.outputType() == remote::OutputType::Sinking ? "7I77D" : "7I77",
                     b.fieldIo.unitNumber(), 3 * d, b.analog.unitNumber(), 3 * d + 1, b.fieldIo.fieldVoltage(),
                     b.fieldIo.nvStore().file().empty() ? "" : ", EEPROM " + b.fieldIo.nvStore().file().string());
  }
  s += fmt::format("  configuration: {}\n", options_.configDescription);
  if (apiPort_ >= 0) s += fmt::format("  control API: http://{}:{}/api/state\n", options_.apiAddress, apiPort_);
  s += fmt::format("  time: {}{}\n", options_.paused ? "paused" : "follows the wall clock",
                   options_.speed != 1.0 ? fmt::format(" x{}", options_.speed) : "");
  return s;
}

std::string SimDaemon::runJob(std::function<std::string()> job) {
  std::packaged_task<std::string()> task(std::move(job));
  auto result = task.get_future();
  {
    std::lock_guard<std::mutex> lock(jobsMutex_);
    jobs_.push_back(std::move(task));
  }
  if (result.wait_for(std::chrono::seconds(5)) != std::future_status::ready)
    throw std::runtime_error("the card thread is busy: the request is queued and will still be applied");
  return result.get();
}

void SimDaemon::drainJobs() {
  // Never wait for the API threads: if they hold the lock, try next time.
  // The jobs run with the lock released, so API threads never wait on them.
  std::deque<std::packaged_task<std::string()>> ready;
  {
    std::unique_lock<std::mutex> lock(jobsMutex_, std::try_to_lock);
    if (!lock.owns_lock() || jobs_.empty()) return;
    ready.swap(jobs_);
  }
  for (auto& task : ready) task();
}

void SimDaemon::log(LogLevel level, const std::string& text) const {
  if (level > options_.logLevel) return;
  static constexpr const char* kNames[] = {"error", "warning", "info", "debug"};
  std::fprintf(stderr, "lbpkit sim: %s: %s\n", kNames[static_cast<int>(level)], text.c_str());
}

void SimDaemon::Latency::add(std::chrono::nanoseconds d) {
  const auto us = static_cast<std::size_t>(d.count() / 1000);
  ++buckets[std::min(us, buckets.size() - 1)];
  ++count;
  maxNs = std::max<std::uint64_t>(maxNs, static_cast<std::uint64_t>(d.count()));
}

double SimDaemon::Latency::percentileUs(double p) const {
  if (count == 0) return 0;
  const auto want = static_cast<std::uint64_t>(p * static_cast<double>(count - 1)) + 1;
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < buckets.size(); ++i) {
    seen += buckets[i];
    if (seen >= want) return static_cast<double>(i) + 0.5;
  }
  return static_cast<double>(buckets.size());
}

std::string SimDaemon::latencySummary() const {
  return fmt::format("median {:.1f} us, 99th percentile {:.1f} us, max {:.1f} us over {} datagrams",
                     latency_.percentileUs(0.5), latency_.percentileUs(0.99), static_cast<double>(latency_.maxNs) / 1000.0,
                     latency_.count);
}

void SimDaemon::run(const std::atomic<bool>& stop) {
  if (options_.realtime) {
    sched_param p{};
    p.sched_priority = 40;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0)
      schedule_ = "SCHED_FIFO priority 40";
    else
      log(LogLevel::Info, "real-time scheduling not permitted: running at normal priority");
  }
  auto& lbp16 = *lbp16_;
  std::uint64_t errorsSeen = 0;
  if (options_.demo) card_.encoders().setVelocity(0, 10000, clock_.now());
  while (!stop.load()) {
    std::chrono::steady_clock::time_point received;
    const bool served = udp_->serveOnce(std::chrono::milliseconds(1),
                                        [&](std::span<const std::uint8_t> req, std::span<std::uint8_t> reply) {
                                          received = std::chrono::steady_clock::now();
                                          return lbp16.handle(req, reply, clock_.now());
                                        });
    if (served) latency_.add(std::chrono::steady_clock::now() - received);
    card_.advance(clock_.now());
    if (options_.demo) {
      auto& io = card_.daughtercard(0).fieldIo;
      for (unsigned i = 0; i < remote::FieldIoProcessor::kOutputs; ++i) {
        const double v = io.outputOn(i) ? io.fieldVoltage() : 0.0;
        if (io.inputVoltage(i) != v) io.setInputVoltage(i, v);
      }
    }
    drainJobs();
    // Bad datagrams: logged, at most once a second, with how many.
    const auto& c = lbp16.counters();
    const std::uint64_t errors = c.parseErrors + c.memoryErrors + c.writeErrors;
    if (errors != errorsSeen && options_.logLevel >= LogLevel::Warn) {
      const auto wall = std::chrono::steady_clock::now();
      if (wall - lastBadLog_ > std::chrono::seconds(1)) {
        log(LogLevel::Warn, fmt::format("{} bad LBP16 requests so far ({} malformed, {} bad addresses, {} refused writes)",
                                        errors, c.parseErrors, c.memoryErrors, c.writeErrors));
        lastBadLog_ = wall;
        errorsSeen = errors;
      }
    }
  }
  drainJobs();
}

}  // namespace net
