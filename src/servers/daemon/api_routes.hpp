// The HTTP control API of `lbpkit sim`: its routes and the validation of
// what they are sent.
//
// The API runs on the HTTP server's own threads, but the card belongs to the
// card thread: every route hands its whole work (validation that looks at
// the card included) to the card thread as a job and answers with what the
// job returns. httplib stays behind this header.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "daemon/sim_clock.hpp"
#include "hostmot2/card.hpp"

namespace net {

// Where and how the API serves. (Room for its limits: timeouts, connection
// cap, body size, allowed Host/Origin, token.)
struct ApiOptions {
  std::string address = "127.0.0.1";  // never anything else unless the user asks
  int port = 27182;                   // 0: any free port
};

// What the routes act on: touched only inside jobs, on the card thread.
struct ApiTarget {
  hm2::HostMot2Card& card;
  SimClock& clock;
  // The answer to every successful call: the whole state as JSON.
  std::function<std::string()> stateJson;
};

// Runs a job on the card thread and returns its result (throws when the card
// thread does not get to it in time).
using CardThreadRunner = std::function<std::string(std::function<std::string()>)>;

class ControlApi {
 public:
  // Binds (throws std::runtime_error saying why it cannot) and serves on a
  // thread of its own until destroyed.
  ControlApi(const ApiOptions& options, ApiTarget target, CardThreadRunner run);
  ~ControlApi();
  ControlApi(const ControlApi&) = delete;
  ControlApi& operator=(const ControlApi&) = delete;

  [[nodiscard]] int port() const { return port_; }

 private:
  struct Server;
  std::unique_ptr<Server> server_;
  int port_ = -1;
};

}  // namespace net
