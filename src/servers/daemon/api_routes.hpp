// SPDX-License-Identifier: MIT
// The HTTP control API of `lbpkit sim`: its routes and the validation of
// what they are sent.
//
// The API runs on threads of its own, but the card belongs to the card
// thread: every route hands its whole work (validation that looks at the
// card included) to the card thread as a job and answers with what the job
// returns. The API owns its sockets and threads; httplib only parses
// requests, routes them and writes answers, and stays behind this header.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/sim_clock.hpp"
#include "lbp16/udp_server.hpp"
#include "daemon/trace_ring.hpp"
#include "hostmot2/card.hpp"
#include "machine/machine.hpp"

namespace lbpkit::server {

// Where and how the API serves, who may use it, and its limits. The limits
// keep it answering whatever clients do: slow or idle connections wait in
// one thread that costs them nothing but a socket, and only whole requests
// reach the threads that answer them (docs/reliability.md).
struct ApiOptions {
  std::string address = "127.0.0.1";  // never anything else unless the user asks
  int port = 27182;                   // 0: any free port
  // When set, every request must carry "Authorization: Bearer TOKEN" (401).
  std::string token;
  // Open connections at most; a new one beyond closes the one waiting longest
  // on its client (or itself, when every one is being answered).
  unsigned maxConnections = 64;
  unsigned workers = 4;  // threads answering whole requests
  std::chrono::milliseconds idleTimeout{2000};     // connected, no request begun
  std::chrono::milliseconds requestTimeout{5000};  // first byte to whole request (408)
  std::chrono::milliseconds writeTimeout{2000};    // to hand over an answer
  std::size_t maxHeader = 16 * 1024;               // request line and headers (431)
  std::size_t maxBody = 64 * 1024;                 // a body (413); unknown lengths: 411
  unsigned maxRequestsPerConnection = 100;
};

// What a job hands back from the card thread: a snapshot (taken there,
// in microseconds) that becomes the answer's text when called, on the API's
// own thread. Serialising the whole state takes milliseconds under a
// sanitizer, and a host's next datagram must not wait for it: hm2_eth
// counts a reply later than 80 % of its servo period as a packet error.
using Answer = std::function<std::string()>;

// What the routes act on: touched only inside jobs, on the card thread
// (but for the trace, made to be read by any thread).
struct ApiTarget {
  model::hm2::HostMot2Card& card;  // card.now(): the simulated time everything happens at
  SimClock& clock;
  // The answer to every successful call: the whole state.
  std::function<Answer()> state;
  // The machine behind connector 0 (`lbpkit sim --machine`), or none: then
  // the /api/machine routes answer 404.
  model::machine::Machine* machine = nullptr;
  std::function<Answer()> machineState;  // GET /api/machine's answer
  const TraceRing* trace = nullptr;      // GET /api/machine/trace reads it on the API's threads
  // The network between host and card: /api/network sets its faults.
  UdpServer* udp = nullptr;
};

// Runs a job on the card thread and returns its answer's text, made on the
// calling thread. What the job throws comes back as is
// (std::invalid_argument: a bad request); it throws std::runtime_error when
// the card thread does not get to it in time or the sim is stopping.
using CardThreadRunner = std::function<std::string(std::function<Answer()>)>;

// Carries out POST /api/KIND's request (its action, without the answer) on
// the card thread: what a fault script's entry does at its time. Throws
// std::invalid_argument naming what is wrong (an unknown kind included).
void applyAction(const ApiTarget& t, std::string_view kind, const nlohmann::json& body);
// The kinds there are: input, field, encoder, cable, output, overtemp,
// time, network, machine.
std::vector<std::string> actionKinds();

class ControlApi {
 public:
  // Binds, exclusively (throws std::runtime_error saying why it cannot), and
  // serves on threads of its own until destroyed; destruction takes at most
  // about the time a job may wait for the card thread, whatever clients do.
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

}  // namespace lbpkit::server
