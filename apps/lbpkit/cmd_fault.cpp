// SPDX-License-Identifier: MIT
// lbpkit fault: a fault (or its end) for a running `lbpkit sim`, from the
// command line. Each is the control API's own request (docs/control-api.md,
// docs/faults.md): `lbpkit fault network drop=0.01 direction=reply` is
// POST /api/network {"drop": 0.01, "direction": "reply"}, and a fault
// script's entry in the sim's TOML uses the same words.
#include <fmt/core.h>
#include <httplib.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common.hpp"
#include "daemon/api_routes.hpp"
#include "lbpkit/error.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace server = lbpkit::server;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

using nlohmann::json;

struct FaultOptions {
  std::string kind;
  std::vector<std::string> fields;
  std::string api;
  std::string apiToken;
};

// KEY=VALUE: the value as JSON when it is JSON (0.01, true, null, "text",
// [1,2]), else as text (direction=reply).
json body(const std::vector<std::string>& fields) {
  json j = json::object();
  for (const auto& f : fields) {
    const auto eq = f.find('=');
    if (eq == std::string::npos || eq == 0)
      throw lbpkit::Error(fmt::format("\"{}\" is not KEY=VALUE (for example drop=0.01)", f));
    const std::string value = f.substr(eq + 1);
    auto v = json::parse(value, nullptr, false);
    j[f.substr(0, eq)] = v.is_discarded() ? json(value) : v;
  }
  return j;
}

int run(const FaultOptions& o) {
  const auto api = app::parseApiAddress(o.api, "127.0.0.1");
  httplib::Client http(api.host, api.port);
  http.set_connection_timeout(std::chrono::seconds(2));
  http.set_read_timeout(std::chrono::seconds(10));
  if (!o.apiToken.empty()) http.set_bearer_token_auth(o.apiToken);
  const std::string path = "/api/" + o.kind;
  if (o.fields.empty() && o.kind != "network" && o.kind != "link" && o.kind != "machine")
    throw lbpkit::Error(fmt::format("say what to set: lbpkit fault {} KEY=VALUE ... (only network, link and machine "
                                    "are shown without fields; the whole board is GET /api/state)",
                                    o.kind));
  // Without fields: what is set now.
  const auto r = o.fields.empty() ? http.Get(path) : http.Post(path, body(o.fields).dump(), "application/json");
  if (!r)
    throw lbpkit::Error(fmt::format("no answer from a sim's control API at http://{}:{} ({})", api.host, api.port,
                                    httplib::to_string(r.error())));
  const auto j = json::parse(r->body, nullptr, false);
  if (r->status != 200) {
    const std::string why = !j.is_discarded() && j.contains("error") && j["error"].is_string()
                                ? j["error"].get<std::string>()
                                : r->body;
    throw lbpkit::Error(fmt::format("{} {}: {} (HTTP {})", o.fields.empty() ? "GET" : "POST", path, why, r->status));
  }
  fmt::print("{}\n", j.is_discarded() ? r->body : j.dump(2));
  return 0;
}

}  // namespace

void addFaultCommand(CLI::App& app) {
  auto o = std::make_shared<FaultOptions>();
  auto* cmd = app.add_subcommand(
      "fault",
      "Set a fault on a running `lbpkit sim` (or show it, without fields): the control API's POST /api/KIND");
  // The kinds are the control API's own POST routes (server::actionKinds()).
  cmd->add_option("kind", o->kind, "input, field, encoder, cable, output, overtemp, time, network, link or machine")
      ->required()
      ->check(CLI::IsMember(server::actionKinds()));
  cmd->add_option("fields", o->fields, "KEY=VALUE ... (for example drop=0.01 direction=reply, or silent_ms=200)");
  cmd->add_option("--api", o->api, "[ADDR:]PORT of the sim's control API (127.0.0.1:27182)");
  cmd->add_option("--api-token", o->apiToken, "The sim's API token, when it was started with one");
  cmd->callback([o] { app::gRun = [o] { return run(*o); }; });
}
