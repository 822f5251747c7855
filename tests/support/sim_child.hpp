// SPDX-License-Identifier: MIT
// `lbpkit sim` as a child process of a test: the virtual card on an address
// of the test's own, its control API, and its state (EEPROM images, flash)
// in a folder of its own that goes, with the sim, when the test is done.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "support/process.hpp"
#include "support/temp_dir.hpp"

namespace test_support {

struct SimOptions {
  // LBP16 on ADDRESS:PORT; port 0 picks a free one, -1 leaves the sim's
  // default (27181, the port hm2_eth and mesaflash use).
  std::string address = "127.0.0.1";
  int port = 0;
  // The control API's address (on a free port); empty: the card's own.
  std::string apiAddress;
  // --no-realtime: the card thread at normal priority (a test beside
  // others); false for the real clients, which meet the sim a user runs.
  bool noRealtime = true;
  // The EEPROM file; empty: `sim.eeprom` in the sim's own folder. A test that
  // restarts a sim on the same state gives both the same file.
  std::string state;
  std::vector<std::string> extra;  // more of lbpkit sim's options
};

struct HttpReply {
  int status = 0;  // 0: no answer
  nlohmann::json body;
};

// GET http://HOST:PORT/PATH: the JSON of a 200 answer, null otherwise (a
// sim's API that a test did not start itself, such as lbpkit linuxcnc's).
[[nodiscard]] nlohmann::json httpGetJson(const std::string& host, int port, const std::string& path,
                                         std::chrono::seconds limit = std::chrono::seconds(5));

// A sim started as a Daemon with `--ready-fd 3` (Daemon(args, true)): its
// greeting (lbpkit sim --ready-fd, docs/sim.md), null when it gave none.
[[nodiscard]] inline nlohmann::json greeting(Daemon& sim) {
  return nlohmann::json::parse(sim.readyLine(), nullptr, false);
}
// Its first card's LBP16 address as ADDR:PORT, or "".
[[nodiscard]] inline std::string lbp16Address(Daemon& sim) {
  const auto g = greeting(sim);
  if (!g.is_object() || !g.contains("cards") || g["cards"].empty()) return {};
  const auto& l = g["cards"][0]["lbp16"];
  return l["address"].get<std::string>() + ":" + std::to_string(l["port"].get<int>());
}

class SimChild {
 public:
  explicit SimChild(SimOptions options);
  // On `address` (LBP16 and the API on free ports), with `extra` options.
  explicit SimChild(const std::string& address, std::vector<std::string> extra = {})
      : SimChild(SimOptions{address, 0, {}, true, {}, std::move(extra)}) {}
  ~SimChild();
  SimChild(const SimChild&) = delete;
  SimChild& operator=(const SimChild&) = delete;

  // Both the card and its API are listening.
  [[nodiscard]] bool up() const { return udpPort_ > 0 && apiPort_ > 0; }
  [[nodiscard]] const std::string& address() const { return options_.address; }
  [[nodiscard]] const std::string& apiAddress() const { return apiAddress_; }
  [[nodiscard]] int udpPort() const { return udpPort_; }
  [[nodiscard]] int apiPort() const { return apiPort_; }
  [[nodiscard]] const std::string& stateFile() const { return state_; }
  [[nodiscard]] pid_t pid() const { return daemon_ ? daemon_->pid() : -1; }
  [[nodiscard]] std::string url(const std::string& path = "/") const;
  // Its resident memory now, in kB (/proc/PID/status VmRSS); -1 if gone.
  [[nodiscard]] long residentKb() const;

  // GET: the JSON of a 200 answer, null otherwise.
  [[nodiscard]] nlohmann::json get(const std::string& path = "/api/state",
                                   std::chrono::seconds limit = std::chrono::seconds(5)) const;
  // POST a JSON body: the status and the JSON answer.
  HttpReply post(const std::string& path, const nlohmann::json& body,
                 std::chrono::seconds limit = std::chrono::seconds(5)) const;

  // SIGTERM (or `sig`) and wait: its exit status.
  int stop(int sig = SIGTERM);
  // The same, giving up after `limit`: -2 when it did not stop (the
  // destructor kills it).
  int stopWithin(std::chrono::milliseconds limit, int sig = SIGTERM);
  Daemon& daemon() { return *daemon_; }

 private:
  SimOptions options_;
  TempDir folder_{"lbpkit-sim"};
  std::string state_;
  std::string apiAddress_;
  std::unique_ptr<Daemon> daemon_;
  int udpPort_ = 0;
  int apiPort_ = 0;
};

}  // namespace test_support
