#include "daemon/api_routes.hpp"

#include <httplib.h>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>
#include <type_traits>

#include "daemon/state_json.hpp"

namespace net {

using nlohmann::json;

struct ControlApi::Server {
  httplib::Server http;
  std::thread thread;
  std::atomic<bool> listenReturned{false};
};

namespace {

// --- Request validation: every complaint is an std::invalid_argument whose
// text the client gets back with HTTP 400.

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

// A whole number from 0 to limit - 1.
unsigned index(const json& j, const char* key, unsigned limit) {
  const auto n = need<unsigned>(j, key);
  if (n >= limit) throw std::invalid_argument(fmt::format("\"{}\" must be below {}", key, limit));
  return n;
}

// "connector" (0 when absent), checked against the 7I77s the card carries.
unsigned connector(const json& j, const hm2::HostMot2Card& card) {
  const auto d = j.contains("connector") ? need<unsigned>(j, "connector") : 0U;
  if (d >= card.daughtercards()) throw std::invalid_argument(fmt::format("no 7I77 on connector {}", d));
  return d;
}

using Route = std::function<std::string(const json&)>;

void addRoutes(httplib::Server& http, const ApiTarget& t, const CardThreadRunner& run) {
  auto handle = [run](Route route) {
    return [run, route](const httplib::Request& req, httplib::Response& res) {
      try {
        // The job owns what it needs: if it outlives this request (a timeout),
        // nothing it touches has gone away.
        res.set_content(run([route, j = body(req)] { return route(j); }), "application/json");
      } catch (const std::exception& e) {
        res.status = 400;
        res.set_content(json{{"error", e.what()}}.dump(), "application/json");
      }
    };
  };
  // Each route holds a copy of the target (references and the state
  // function), so a job stays valid whichever request it came from.
  http.Get("/api/state", handle([t](const json&) { return t.stateJson(); }));
  http.Post("/api/input", handle([t](const json& j) {
              auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
              const auto n = index(j, "input", remote::FieldIoProcessor::kInputs);
              const double v =
                  j.contains("volts") ? need<double>(j, "volts") : (need<bool>(j, "on") ? io.fieldVoltage() : 0.0);
              io.setInputVoltage(n, v);
              return t.stateJson();
            }));
  http.Post("/api/field", handle([t](const json& j) {
              auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
              if (j.contains("volts")) io.setFieldVoltage(need<double>(j, "volts"), t.clock.now());
              if (j.contains("vin")) io.setVin(need<double>(j, "vin"), t.clock.now());
              return t.stateJson();
            }));
  http.Post("/api/encoder", handle([t](const json& j) {
              const auto d = connector(j, t.card);
              constexpr unsigned kPer = SimState::kEncodersPerDaughtercard;
              const auto n = index(j, "encoder", kPer) + kPer * d;
              auto& enc = t.card.encoders();
              if (j.contains("counts_per_rev")) enc.setIndexPeriod(n, need<std::uint32_t>(j, "counts_per_rev"));
              if (j.contains("velocity")) enc.setVelocity(n, need<double>(j, "velocity"), t.clock.now());
              return t.stateJson();
            }));
  http.Post("/api/cable", handle([t](const json& j) {
              const auto ch = index(j, "channel", t.card.smartSerial().channels());
              t.card.smartSerial().link(ch).setConnected(need<bool>(j, "connected"));
              return t.stateJson();
            }));
  http.Post("/api/output", handle([t](const json& j) {
              auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
              const auto n = index(j, "output", remote::FieldIoProcessor::kOutputs);
              double ohms = std::numeric_limits<double>::infinity();  // {}: an open terminal
              if (j.value("short", false))
                ohms = 0;
              else if (j.contains("ohms"))
                ohms = need<double>(j, "ohms");
              io.setOutputLoad(n, ohms);
              return t.stateJson();
            }));
  http.Post("/api/overtemp", handle([t](const json& j) {
              auto& io = t.card.daughtercard(connector(j, t.card)).fieldIo;
              io.setDriverOverTemperature(index(j, "chip", remote::FieldIoProcessor::kChips), need<bool>(j, "hot"));
              return t.stateJson();
            }));
  http.Post("/api/time", handle([t](const json& j) {
              const double speed = j.value("speed", t.clock.speed());
              if (!(speed > 0) || speed > 1000) throw std::invalid_argument("\"speed\" must be above 0 and at most 1000");
              double step = 0;
              if (j.contains("step_ms")) {
                step = need<double>(j, "step_ms");
                if (!(step >= 0) || step > 60000) throw std::invalid_argument("\"step_ms\" must be 0 to 60000");
              }
              t.clock.set(speed, j.value("paused", t.clock.paused()));
              if (step > 0) t.clock.advanceBy(lbp::SimTime{static_cast<std::int64_t>(step * 1e6)});
              return t.stateJson();
            }));
}

}  // namespace

ControlApi::ControlApi(const ApiOptions& options, ApiTarget target, CardThreadRunner run)
    : server_(std::make_unique<Server>()) {
  auto& http = server_->http;
  addRoutes(http, target, run);
  if (options.port == 0)
    port_ = http.bind_to_any_port(options.address);
  else
    port_ = http.bind_to_port(options.address, options.port) ? options.port : -1;
  if (port_ < 0)
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{} (port in use? --api 0 picks a free one)",
                                         options.address, options.port));
  server_->thread = std::thread([this] {
    server_->http.listen_after_bind();
    server_->listenReturned = true;
  });
}

ControlApi::~ControlApi() {
  // httplib's stop() does nothing until the listening thread has started
  // running, and the thread would then accept forever: a daemon destroyed
  // right after it was made (a start that fails later) must wait for that.
  while (!server_->http.is_running() && !server_->listenReturned)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  server_->http.stop();
  if (server_->thread.joinable()) server_->thread.join();
}

}  // namespace net
