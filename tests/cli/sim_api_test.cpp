// SPDX-License-Identifier: MIT
// `lbpkit sim`'s HTTP control API under attack and misuse: what it changes
// and refuses, its limits, who may use it, the values it takes, and what
// /api/state shows. Each test starts its own sim on a loopback address of
// its own, talks to it over plain sockets (so it can misbehave as a hostile
// client would), and stops it before it ends.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "lbpkit/wire/lbp16.hpp"
#include "support/process.hpp"
#include "support/sim_api.hpp"
#include "support/sim_child.hpp"

namespace {

using namespace std::chrono_literals;
using namespace test_support::sim_api;
using nlohmann::json;
namespace lbp16 = lbpkit::wire::lbp16;

// --- What the API changes, and what it refuses --------------------------

TEST(ControlApi, ChangesTheWorldAndRefusesBadRequests) {
  test_support::SimChild sim(onLbp16Port(20));
  ASSERT_TRUE(sim.up());
  auto s = sim.post("/api/input", {{"input", 4}, {"volts", 20.0}}).body;
  EXPECT_EQ(s["daughtercards"][0]["field_io"]["inputs"][4]["on"], true);
  s = sim.post("/api/output", {{"output", 2}, {"ohms", 80.0}}).body;
  EXPECT_FALSE(s.contains("error"));
  s = sim.post("/api/field", {{"volts", 36.0}}).body;
  const auto faults = s["daughtercards"][0]["field_io"]["faults"];
  EXPECT_NE(std::find(faults.begin(), faults.end(), "HighVoltageFault"), faults.end()) << faults.dump();
  s = sim.post("/api/cable", {{"channel", 1}, {"connected", false}}).body;
  EXPECT_EQ(s["sserial"]["channels"][1]["cable_connected"], false);
  s = sim.post("/api/time", {{"paused", true}}).body;
  const double t0 = s["time_s"].get<double>();
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(sim.get()["time_s"].get<double>(), t0);
  s = sim.post("/api/time", {{"step_ms", 100}}).body;
  EXPECT_NEAR(s["time_s"].get<double>() - t0, 0.1, 1e-6);
  // Bad requests: 400 with a message, and the card keeps running.
  EXPECT_NE(sim.post("/api/input", {{"input", 40}, {"on", true}}).body["error"].get<std::string>().find("below 32"),
            std::string::npos);
  EXPECT_NE(sim.post("/api/input", {{"on", true}}).body["error"].get<std::string>().find("missing \"input\""),
            std::string::npos);
  EXPECT_NE(sim.post("/api/time", {{"speed", 0}}).body["error"].get<std::string>().find("above 0"), std::string::npos);
  EXPECT_NE(sim.post("/api/encoder", {{"encoder", "two"}}).body["error"].get<std::string>().size(), 0U);
  EXPECT_FALSE(sim.get().is_null());
}

// --- The control API's limits -------------------------------------------

// Slow-loris clients (a header byte every 2 s) and a hundred idle connections
// used to hold every one of httplib's threads: the API answered nobody for
// as long as they stayed.
TEST(SimApi, SlowAndIdleClientsDoNotLockOthersOut) {
  Sim sim(loopback(1));
  ASSERT_TRUE(sim.up());
  std::vector<std::unique_ptr<Conn>> loris, idle;
  const std::string head = "GET /api/state HTTP/1.1\r\nHost: " + sim.address() + "\r\n";
  for (int i = 0; i < 8; ++i) {
    loris.push_back(std::make_unique<Conn>(sim.address(), sim.apiPort()));
    loris.back()->send(head.substr(0, 1));
  }
  for (int i = 0; i < 100; ++i) idle.push_back(std::make_unique<Conn>(sim.address(), sim.apiPort()));
  std::atomic<bool> done{false};
  std::thread drip([&] {
    for (std::size_t k = 1; !done; ++k) {
      for (int t = 0; t < 200 && !done; ++t) std::this_thread::sleep_for(10ms);  // 2 s
      for (auto& c : loris) c->send(head.substr(k % head.size(), 1));
    }
  });
  std::this_thread::sleep_for(300ms);  // all of them connected and waiting
  for (int round = 0; round < 3; ++round) {
    const auto r = sim.get("/api/state", 2000ms);
    EXPECT_EQ(r.status, 200) << "round " << round << ": " << r.raw.substr(0, 200);
    EXPECT_LT(r.took.count(), 1000) << "round " << round;
    std::this_thread::sleep_for(700ms);
  }
  done = true;
  drip.join();
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// A body over the limit is refused without being kept (three 100 MB posts
// took the daemon to 2 GB).
TEST(SimApi, OversizedBodiesAreRefusedWith413) {
  Sim sim(loopback(2));
  ASSERT_TRUE(sim.up());
  Request q;
  q.method = "POST";
  q.path = "/api/time";
  q.body = "{\"speed\": 1, \"pad\": \"" + std::string(2 * 1024 * 1024, 'x') + "\"}";
  const auto r = sim.send(q);
  EXPECT_EQ(r.status, 413) << r.raw.substr(0, 300);
  ASSERT_TRUE(r.body.is_object()) << r.raw.substr(0, 300);
  EXPECT_NE(r.body.value("error", "").find("too large"), std::string::npos) << r.body;
  // A body of unknown length is refused too: it could be any size.
  Conn c(sim.address(), sim.apiPort());
  c.send("POST /api/time HTTP/1.1\r\nHost: " + sim.address() + ":" + std::to_string(sim.apiPort()) +
         "\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
  const auto rc = parse(c.readAll(2000ms));
  EXPECT_EQ(rc.status, 411) << rc.raw;
  // And the API still works.
  EXPECT_EQ(sim.get().status, 200);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// httplib set SO_REUSEPORT: a second sim shared the first one's API port and
// requests landed on either.
TEST(SimApi, ASecondSimOnTheSameApiPortIsRefused) {
  Sim first(loopback(3));
  ASSERT_TRUE(first.up());
  const auto api = first.address() + ":" + std::to_string(first.apiPort());
  const auto state = tempPath("second");
  const auto r = test_support::run(
      {"sim", "--bind", loopback(4) + ":0", "--no-realtime", "--state", state, "--api", api}, std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("control API port " + api + " is in use (another lbpkit sim?)"), std::string::npos) << r.err;
  test_support::removeStateFiles(state);
  EXPECT_EQ(first.get().status, 200);
  EXPECT_EQ(first.stopWithin(2000ms), 0);
}

// --- Who may use the API -----------------------------------------------

// A web page in the user's browser could POST (text/plain, no preflight) and
// unplug a channel; a DNS-rebinding page could read and write as if local.
TEST(SimApi, RefusesForeignOriginsHostsAndNonJsonPosts) {
  Sim sim(loopback(8));
  ASSERT_TRUE(sim.up());
  const auto own = sim.address() + ":" + std::to_string(sim.apiPort());
  Request unplug;
  unplug.method = "POST";
  unplug.path = "/api/cable";
  unplug.body = R"({"channel": 0, "connected": false})";
  auto q = unplug;
  q.headers = {"Origin: http://evil.example"};
  q.contentType = "text/plain";
  auto r = sim.send(q);
  EXPECT_EQ(r.status, 403) << r.raw;
  EXPECT_TRUE(r.body.contains("error")) << r.raw;
  q.contentType = "application/json";
  EXPECT_EQ(sim.send(q).status, 403);
  q = unplug;
  q.host = "evil.example:" + std::to_string(sim.apiPort());  // DNS rebinding
  r = sim.send(q);
  EXPECT_EQ(r.status, 403) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("Host"), std::string::npos) << r.raw;
  Request get;
  get.host = "evil.example";
  EXPECT_EQ(sim.send(get).status, 403);
  // A second Host or Origin after the good one: none is taken.
  q = unplug;
  q.headers = {"Host: evil.example"};
  r = sim.send(q);
  EXPECT_EQ(r.status, 400) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("Host is given more than once"), std::string::npos) << r.raw;
  q.headers = {"Origin: http://" + own, "Origin: http://evil.example"};
  EXPECT_EQ(sim.send(q).status, 400);
  q = unplug;
  q.contentType = "text/plain";
  r = sim.send(q);
  EXPECT_EQ(r.status, 415) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("application/json"), std::string::npos) << r.raw;
  q.contentType = "application/x-www-form-urlencoded";  // what curl -d sends
  EXPECT_EQ(sim.send(q).status, 415);
  q.contentType = "";
  EXPECT_EQ(sim.send(q).status, 415);
  // Nothing got through.
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(r.body["sserial"]["channels"][0]["cable_connected"].get<bool>());
  // Its own origin, localhost, and a JSON content type with parameters pass.
  q = unplug;
  q.headers = {"Origin: http://" + own};
  q.contentType = "application/json; charset=utf-8";
  EXPECT_EQ(sim.send(q).status, 200);
  get.host = "localhost:" + std::to_string(sim.apiPort());
  EXPECT_EQ(sim.send(get).status, 200);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimApi, ATokenIsRequiredWhenSet) {
  for (const bool fromEnvironment : {false, true}) {
    if (fromEnvironment) ::setenv("LBPKIT_API_TOKEN", "s3cret-from-env", 1);
    const std::string token = fromEnvironment ? "s3cret-from-env" : "s3cret";
    Sim sim(loopback(9), fromEnvironment ? std::vector<std::string>{} : std::vector<std::string>{"--api-token", token});
    ::unsetenv("LBPKIT_API_TOKEN");
    ASSERT_TRUE(sim.up());
    auto r = sim.get();
    EXPECT_EQ(r.status, 401) << r.raw;
    EXPECT_TRUE(r.body.contains("error")) << r.raw;
    Request q;
    q.headers = {"Authorization: Bearer wrong"};
    EXPECT_EQ(sim.send(q).status, 401);
    q.headers = {"Authorization: Bearer " + token};
    EXPECT_EQ(sim.send(q).status, 200);
    q.method = "POST";
    q.path = "/api/field";
    q.body = R"({"volts": 12})";
    EXPECT_EQ(sim.send(q).status, 200);
    q.headers = {};
    EXPECT_EQ(sim.send(q).status, 401);
    EXPECT_EQ(sim.stopWithin(2000ms), 0);
  }
}

// `--bind 0.0.0.0` and `--api 0.0.0.0` started without a word, and the
// banner advised board_ip=0.0.0.0.
TEST(SimApi, WarnsWhenServingBeyondLoopback) {
  const auto state = tempPath("anywhere");
  const auto r = test_support::run(
      {"sim", "--bind", "0.0.0.0:0", "--api", "0.0.0.0:0", "--no-realtime", "--state", state}, std::chrono::seconds(5));
  EXPECT_NE(r.err.find("warning: the control API on 0.0.0.0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--api-token"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("warning: LBP16 on 0.0.0.0"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("board_ip="), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("board_ip=0.0.0.0"), std::string::npos) << r.out;
  // run() kills the sim at its limit, so it leaves its owner notes too.
  test_support::removeStateFiles(state);
}

// --- Values with no physical meaning ----------------------------------

TEST(SimApi, RefusesValuesWithNoPhysicalMeaning) {
  Sim sim(loopback(10));
  ASSERT_TRUE(sim.up());
  struct Case {
    const char* path;
    json body;
    const char* says;  // the key and its range
  };
  const Case cases[] = {
      {"/api/field", {{"volts", 1e308}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/field", {{"volts", -1}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/field", {{"vin", 40}}, "\"vin\" must be a number from 0 to 36"},
      {"/api/input", {{"input", 3}, {"volts", -1e308}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/input", {{"input", 3}, {"volts", "high"}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/output", {{"output", 3}, {"ohms", -5}}, "\"ohms\" must be a number above 0"},
      {"/api/output", {{"output", 3}, {"ohms", 0}}, "\"ohms\" must be a number above 0"},
      {"/api/encoder", {{"encoder", 1}, {"velocity", 1e308}}, "\"velocity\" must be a number from -1e+07 to 1e+07"},
      {"/api/encoder", {{"encoder", 1}, {"counts_per_rev", 4294967295U}}, "\"counts_per_rev\" must be a whole number from 0 to 2147483648"},
      {"/api/encoder", {{"encoder", 1}, {"counts_per_rev", -1}}, "\"counts_per_rev\" must be a whole number from 0 to 2147483648"},
      {"/api/time", {{"speed", 1e308}}, "\"speed\" must be a number above 0 and at most 10000"},
      {"/api/time", {{"speed", 0}}, "\"speed\" must be a number above 0 and at most 10000"},
      {"/api/time", {{"step_ms", 1e9}}, "\"step_ms\" must be a number from 0 to 60000"},
      {"/api/time", {{"paused", "yes"}}, "\"paused\" must be true or false"},
      // A misspelt key is refused, as everywhere in the API, not ignored.
      {"/api/input", {{"input", 3}, {"vots", 3}}, "unknown key \"vots\""},
      {"/api/field", {{"volt", 24}}, "unknown key \"volt\""},
      {"/api/output", {{"output", 3}, {"ohm", 80}}, "unknown key \"ohm\""},
      {"/api/encoder", {{"encoder", 1}, {"velocty", 5}}, "unknown key \"velocty\""},
      {"/api/cable", {{"channel", 1}, {"conected", false}}, "unknown key \"conected\""},
      {"/api/time", {{"pause", true}}, "unknown key \"pause\""},
  };
  for (const auto& c : cases) {
    const auto r = sim.post(c.path, c.body);
    EXPECT_EQ(r.status, 400) << c.path << " " << c.body;
    EXPECT_NE(r.body.value("error", "").find(c.says), std::string::npos) << c.path << " " << c.body << ": " << r.raw;
  }
  // Open (null) and real loads, and the limits themselves, are fine.
  EXPECT_EQ(sim.post("/api/output", {{"output", 3}, {"ohms", nullptr}}).status, 200);
  EXPECT_EQ(sim.post("/api/output", {{"output", 3}, {"ohms", 80}}).status, 200);
  EXPECT_EQ(sim.post("/api/field", {{"volts", 36}}).status, 200);
  EXPECT_EQ(sim.post("/api/encoder", {{"encoder", 1}, {"velocity", -1e7}, {"counts_per_rev", 2147483648U}}).status, 200);
  const auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(r.body["daughtercards"][0]["encoders"][1]["position"].is_number());
  EXPECT_GE(r.body["time_s"].get<double>(), 0);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimApi, CliRefusesSpeedsWithNoPhysicalMeaning) {
  for (const char* speed : {"1e308", "inf", "nan", "0", "-1", "10001"}) {
    const auto state = tempPath("speed");
    const auto r = test_support::run(
        {"sim", "--bind", loopback(11) + ":0", "--api", "0", "--no-realtime", "--state", state, "--speed", speed},
        std::chrono::seconds(5));
    EXPECT_NE(r.exit, 0) << speed;
    EXPECT_NE(r.err.find("--speed"), std::string::npos) << speed << ": " << r.err;
    EXPECT_NE(r.err.find("10000"), std::string::npos) << speed << ": " << r.err;
    test_support::removeStateFiles(state);
  }
}
// --- What /api/state shows ---------------------------------------------

// mesaflash writes the card's EEPROM IP (with the write enable) to move a
// card to another address: /api/state showed none of it.
TEST(SimApi, TheEepromWrittenThroughLbp16ShowsInState) {
  Sim sim(loopback(12));
  ASSERT_TRUE(sim.up());
  auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  ASSERT_TRUE(r.body["card"].contains("eeprom")) << r.body["card"];
  EXPECT_EQ(r.body["card"]["eeprom"]["ip"], sim.address());
  EXPECT_EQ(r.body["card"]["eeprom"]["name"], "7I92");
  EXPECT_EQ(r.body["card"]["eeprom"]["mac"], r.body["card"]["mac"]);
  Bytes d;
  command(d, {true, true, false, 6, 2, true, 1}, lbp16::comm::kEepromWriteEnable);
  put16(d, lbp16::kEepromWriteEnableKey);
  command(d, {true, true, false, 2, 2, true, 2}, lbp16::eeprom::kIp);
  put16(d, (1 << 8) | 121);    // c.d
  put16(d, (192 << 8) | 168);  // a.b
  command(d, {true, true, false, 2, 2, true, 1}, lbp16::eeprom::kMac);
  put16(d, (0x56 << 8) | 0x78);  // the last two bytes of the MAC: read only (Mesa's LBPPARSE.ASM)
  cookieRead(d);
  ASSERT_EQ(exchange(sim.address(), sim.udpPort(), d).size(), 4U);
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.body["card"]["eeprom"]["ip"], "192.168.1.121") << r.body["card"];
  EXPECT_EQ(r.body["card"]["eeprom"]["mac"], r.body["card"]["mac"]) << "the MAC cannot be written";
  EXPECT_EQ(r.body["lbp16"]["write_errors"], 1);
  // Without the enable nothing changes.
  Bytes w;
  command(w, {true, true, false, 2, 2, true, 1}, lbp16::eeprom::kIp);
  put16(w, 0);
  cookieRead(w);
  ASSERT_EQ(exchange(sim.address(), sim.udpPort(), w).size(), 4U);
  EXPECT_EQ(sim.get().body["card"]["eeprom"]["ip"], "192.168.1.121");
  // The server's figures include the time a datagram queued in the socket.
  const auto server = sim.get().body["server"];
  EXPECT_TRUE(server.contains("queue_p99_us")) << server;
  EXPECT_TRUE(server.contains("queue_max_us")) << server;
  EXPECT_GE(server["max_us"].get<double>(), server["queue_max_us"].get<double>()) << server;
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

}  // namespace
