// SPDX-License-Identifier: MIT
// What the web view's tests share: `lbpkit sim` on a loopback address of the
// test's own, a host (the lbpkit library) cycling it at about 1 kHz on a
// thread of its own, a plain-socket client of the control API, and a
// WebDriver client for Debian's chromedriver and headless Chromium.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#include <httplib.h>

#include <atomic>
#include <cmath>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "support/wait.hpp"
#include "support/stepgen_registers.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"

namespace webtest {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// 127.94.P.n: P from the process id (ctest runs tests side by side).
inline std::string loopback(int n) { return "127.94." + std::to_string(::getpid() % 250) + "." + std::to_string(n); }

// `lbpkit sim` on `address` (LBP16 and API on free ports), its own state.
using Sim = test_support::SimChild;

// A host on the library: discovers the 7I77's two remotes and cycles them
// at about 1 kHz on its own thread until destroyed. What it last read and
// what it should write are shared through atomics.
class Host {
 public:
  explicit Host(const Sim& sim) : transport_(sim.address(), static_cast<std::uint16_t>(sim.udpPort())) {
    transport_.setCycleTimeout(std::chrono::milliseconds(500));  // what is tested is the data, not the reply time
    const auto info = lbpkit::readCardInfo(transport_);
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x03;
    ss_ = std::make_unique<lbpkit::SmartSerial>(transport_, info, o);
    ss_->discover(0x03);
    ss_->startNormal();
    input_ = ss_->find(0, "input");
    output_ = ss_->find(0, "output");
    analog0_ = ss_->find(1, "analogout0");
    analogEnable_ = ss_->find(1, "analogena");
    thread_ = std::thread([this] { run(); });
  }
  ~Host() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  std::atomic<std::uint32_t> outputs{0};  // field outputs to turn on
  std::atomic<double> volts0{0.0};        // analog output 0 (X on the mill), enabled when not 0
  std::atomic<std::uint64_t> inputs{0};   // the field inputs it last read
  std::atomic<std::uint8_t> fieldIoFaults{0};  // the field I/O remote's fault byte (its CS)
  std::atomic<std::uint64_t> cycles{0};
  std::atomic<std::uint64_t> failedCycles{0};

 private:
  void run() {
    while (!stop_) {
      ss_->setRaw(output_, outputs.load());
      const double v = volts0.load();
      ss_->set(analog0_, v);
      ss_->setRaw(analogEnable_, v != 0.0 ? 1 : 0);
      const auto st = ss_->cycle();
      if (st.ok) inputs = ss_->raw(input_);
      // A channel that keeps failing, or whose remote's watchdog bit (a
      // thread starved on a busy machine, while Chromium starts), is started
      // again: START clears the fault (7I77 manual: FIELD I/O WATCHDOG AND
      // FAULTS, "normally handled by SSLBP").
      for (unsigned slot = 0; slot < ss_->slots(); ++slot)
        if (((static_cast<unsigned>(st.needsRecovery()) >> slot) & 1U) != 0 || (ss_->remoteFaults(slot) & 0x01U) != 0) {
          try {
            ss_->recover(slot);
          } catch (const std::exception&) {
          }
        }
      if (!st.ok) ++failedCycles;
      fieldIoFaults = ss_->remoteFaults(0);
      ++cycles;
      transport_.sleep(std::chrono::milliseconds(1));
    }
  }

  lbpkit::Lbp16Transport transport_;
  std::unique_ptr<lbpkit::SmartSerial> ss_;
  lbpkit::ElementRef input_{}, output_{}, analog0_{}, analogEnable_{};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A host for the 7I77+7I76 firmwares' other half: cycles the
// 7I76 on SSerial channel 3 at about 1 kHz (outputs, SpinOut, SpinEna) and
// commands StepGen 0's rate (StepGenRegisters), on its own thread until
// destroyed.
class SevenI76Host {
 public:
  static constexpr unsigned kChannel = 3;
  explicit SevenI76Host(const Sim& sim) : transport_(sim.address(), static_cast<std::uint16_t>(sim.udpPort())) {
    transport_.setCycleTimeout(std::chrono::milliseconds(500));
    const auto info = lbpkit::readCardInfo(transport_);
    stepGen_ = std::make_unique<testing_stepgen::StepGenRegisters>(transport_, info);
    lbpkit::SmartSerial::Options o;
    o.channelMask = 1U << kChannel;
    ss_ = std::make_unique<lbpkit::SmartSerial>(transport_, info, o);
    ss_->discover(1U << kChannel);
    ss_->startNormal();
    input_ = ss_->find(kChannel, "input");
    output_ = ss_->find(kChannel, "output");
    spinOut_ = ss_->find(kChannel, "spinout");
    spinEna_ = ss_->find(kChannel, "spinena");
    thread_ = std::thread([this] { run(); });
  }
  ~SevenI76Host() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  SevenI76Host(const SevenI76Host&) = delete;
  SevenI76Host& operator=(const SevenI76Host&) = delete;

  std::atomic<std::uint32_t> outputs{0};
  std::atomic<double> spindleVolts{0.0};  // SpinOut; SpinEna on when not 0
  std::atomic<double> stepRate{0.0};      // StepGen 0, steps per second
  std::atomic<std::uint64_t> inputs{0};
  std::atomic<std::uint64_t> cycles{0};

 private:
  void run() {
    double rate = 0.0;
    while (!stop_) {
      if (const double want = stepRate.load(); want != rate) {
        rate = want;
        try {
          stepGen_->setRate(want);
        } catch (const std::exception&) {
          rate = std::nan("");  // not sent: again next cycle
        }
      }
      ss_->setRaw(output_, outputs.load());
      const double v = spindleVolts.load();
      ss_->set(spinOut_, v);
      ss_->setRaw(spinEna_, v != 0.0 ? 1 : 0);
      const auto st = ss_->cycle();
      if (st.ok) inputs = ss_->raw(input_);
      if (st.needsRecovery() != 0 || (ss_->remoteFaults(0) & 0x01U) != 0) {
        try {
          ss_->recover(0);
        } catch (const std::exception&) {
        }
      }
      ++cycles;
      transport_.sleep(std::chrono::milliseconds(1));
    }
  }

  lbpkit::Lbp16Transport transport_;
  std::unique_ptr<testing_stepgen::StepGenRegisters> stepGen_;
  std::unique_ptr<lbpkit::SmartSerial> ss_;
  lbpkit::ElementRef input_{}, output_{}, spinOut_{}, spinEna_{};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// --- Headless Chromium through Debian's chromedriver (W3C WebDriver).

inline const char* kChromium = "/usr/bin/chromium";
inline const char* kChromedriver = "/usr/bin/chromedriver";

inline bool browserPresent() { return ::access(kChromium, X_OK) == 0 && ::access(kChromedriver, X_OK) == 0; }

// In a test: skips it, saying why, without the browser.
#define SKIP_WITHOUT_BROWSER()                                                                       \
  if (!webtest::browserPresent())                                                                    \
  GTEST_SKIP() << "no headless browser: " << webtest::kChromium << " and " << webtest::kChromedriver \
               << " are needed (Debian's chromium and chromium-driver: scripts/deps --test installs them)"

inline int freeTcpPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  socklen_t len = sizeof sa;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len);
  ::close(fd);
  return ntohs(sa.sin_port);
}

inline std::string base64Decode(const std::string& in) {
  std::string out;
  unsigned buf = 0;
  int bits = 0;
  for (const char ch : in) {
    int v = -1;
    if (ch >= 'A' && ch <= 'Z') v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z') v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9') v = ch - '0' + 52;
    else if (ch == '+') v = 62;
    else if (ch == '/') v = 63;
    if (v < 0) continue;
    buf = (buf << 6) | static_cast<unsigned>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((buf >> bits) & 0xFF));
    }
  }
  return out;
}

// chromedriver and one headless Chromium session, both gone when this goes.
class Browser {
 public:
  Browser() : port_(freeTcpPort()) {
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      // chromedriver's profile and Chromium's singleton folders go here,
      // removed with it, whatever state the browser was left in.
      ::setenv("TMPDIR", tmp_.path().c_str(), 1);
      const std::string portArg = "--port=" + std::to_string(port_);
      ::execl(kChromedriver, kChromedriver, portArg.c_str(), "--log-level=OFF", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    client_ = std::make_unique<httplib::Client>("127.0.0.1", port_);
    client_->set_read_timeout(60, 0);
    if (!test_support::waitFor(
            [this] {
              auto r = client_->Get("/status");
              return r && r->status == 200;
            },
            std::chrono::milliseconds(30000)))  // a loaded 2-core machine starts it slowly
      throw std::runtime_error("chromedriver did not start");
    const json caps = {{"capabilities",
                        {{"alwaysMatch",
                          {{"browserName", "chrome"},
                           {"goog:chromeOptions",
                            {{"binary", kChromium},
                             {"args",
                              {"--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                               "--window-size=1500,1900", "--no-first-run", "--disable-extensions"}}}}}}}}};
    const auto r = call("POST", "/session", caps);
    session_ = r["value"]["sessionId"].get<std::string>();
  }
  ~Browser() {
    if (!session_.empty()) {
      try {
        call("DELETE", "/session/" + session_, json());
      } catch (const std::exception&) {
      }
    }
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

  void open(const std::string& url) { call("POST", path("/url"), {{"url", url}}); }
  // Runs `script` (a function body; arguments as `arguments`) in the page.
  json run(const std::string& script, const json& args = json::array()) {
    return call("POST", path("/execute/sync"), {{"script", script}, {"args", args}})["value"];
  }
  void click(const std::string& css) {
    const auto e = call("POST", path("/element"), {{"using", "css selector"}, {"value", css}})["value"];
    const std::string id = e.begin().value().get<std::string>();
    call("POST", path("/element/" + id + "/click"), json::object());
  }
  // Waits up to `limit` for `script` to return true in the page.
  bool waitFor(const std::string& script, std::chrono::milliseconds limit = std::chrono::milliseconds(5000)) {
    return test_support::waitFor([&] {
      const auto v = run(script);
      return v.is_boolean() && v.get<bool>();
    }, limit);
  }
  // Saves a PNG of the window; returns its path.
  std::string screenshot(const std::string& name) {
    const auto png = base64Decode(call("GET", path("/screenshot"), json())["value"].get<std::string>());
    const std::filesystem::path dir = LBPKIT_SCREENSHOT_DIR;
    std::filesystem::create_directories(dir);
    const auto file = (dir / (name + ".png")).string();
    std::ofstream(file, std::ios::binary) << png;
    return file;
  }

 private:
  std::string path(const std::string& tail) const { return "/session/" + session_ + tail; }
  json call(const std::string& method, const std::string& p, const json& body) {
    httplib::Result r = method == "GET"      ? client_->Get(p)
                        : method == "DELETE" ? client_->Delete(p)
                                             : client_->Post(p, body.dump(), "application/json");
    if (!r) throw std::runtime_error("WebDriver " + method + " " + p + ": no answer");
    auto j = json::parse(r->body, nullptr, false);
    if (r->status != 200)
      throw std::runtime_error("WebDriver " + method + " " + p + ": HTTP " + std::to_string(r->status) + " " +
                               r->body.substr(0, 400));
    return j;
  }

  int port_;
  test_support::TempDir tmp_{"lbpkit-browser"};  // removed after the browser has gone
  pid_t pid_ = -1;
  std::unique_ptr<httplib::Client> client_;
  std::string session_;
};

}  // namespace webtest
