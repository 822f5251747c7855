// SPDX-License-Identifier: MIT
// The machine section of `lbpkit monitor`: what `lbpkit sim --machine`
// reports at GET /api/machine (axes, drives, switches, spindle, E-stop
// chain, probe, outputs), fetched off the servo cycle and formatted for the
// screen.
#pragma once

#include <condition_variable>
#include <chrono>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <thread>

namespace httplib {
class Client;
}

namespace lbpkit::app {

// The screen text for one GET /api/machine answer. Whatever the answer
// holds (fields missing or of the wrong type show as "?"), this never
// throws: the API may be an older or newer lbpkit.
[[nodiscard]] std::string machineSection(const nlohmann::json& machine);

// Asks a sim's control API for its machine on a thread of its own, at most
// `period` apart, so the monitor's servo cycle never waits for HTTP. The
// first answer is fetched in the constructor (call it before the cycle
// starts). section() is the latest answer's text: "" while there is no
// API, no machine (404) or no answer, so a board without a sim behind it
// shows nothing extra.
class MachineWatcher {
 public:
  MachineWatcher(std::string host, int port, std::string token, std::chrono::milliseconds period);
  ~MachineWatcher();
  MachineWatcher(const MachineWatcher&) = delete;
  MachineWatcher& operator=(const MachineWatcher&) = delete;

  [[nodiscard]] std::string section() const;
  [[nodiscard]] std::string describe() const;  // "http://HOST:PORT/api/machine"

  // How long one request may take: connecting, and waiting for the answer.
  static constexpr std::chrono::milliseconds kConnectTimeout{50};
  static constexpr std::chrono::milliseconds kReadTimeout{100};

 private:
  void fetch(httplib::Client& client);
  void run();

  std::string host_;
  int port_;
  std::string token_;
  std::chrono::milliseconds period_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::string section_;
  std::thread thread_;
};

}  // namespace lbpkit::app
