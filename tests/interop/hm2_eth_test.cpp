// SPDX-License-Identifier: MIT
// LinuxCNC's hm2_eth (Debian's linuxcnc-uspace, installed by scripts/test)
// against `lbpkit sim`, in a network namespace of the test's own: it loads,
// makes the 7I77's pins, runs its smart-serial channels and muxed encoders
// at 1 kHz, and the measurements of what it counts on the wall clock.
#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support/interop.hpp"

namespace interop {
namespace {

using namespace std::chrono_literals;

TEST_F(LinuxCnc, Hm2EthRunsTheVirtual7i77) {
  startSim();
  // The MAC the card reports is its veth's: hm2_eth pins an ARP entry to it.
  std::ifstream macFile("/sys/class/net/" + cardLink_ + "/address");
  std::string mac;
  macFile >> mac;
  EXPECT_EQ(sim_->get()["card"]["mac"], mac);

  // The 7I77's watchdog at 200 ms (support/interop.hpp), short enough for
  // its bite to be seen below.
  patient7i77Watchdogs({0, 1}, "200");
  EXPECT_EQ(sim_->get()["daughtercards"][0]["field_io"]["watchdog_ms"], 200);
  const auto r = load("00xxxxxx");
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out + halcmd("show param").out;
  for (int i = 0; i < 32; ++i) EXPECT_NE(pins.find(fmt("hm2_7i92.0.7i77.0.0.input-%02d", i)), std::string::npos) << i;
  for (int i = 0; i < 16; ++i) EXPECT_NE(pins.find(fmt("hm2_7i92.0.7i77.0.0.output-%02d", i)), std::string::npos) << i;
  for (int i = 0; i < 6; ++i) {
    EXPECT_NE(pins.find(fmt("hm2_7i92.0.7i77.0.1.analogout%d", i)), std::string::npos) << i;
    EXPECT_NE(pins.find(fmt("hm2_7i92.0.encoder.%02d.count", i)), std::string::npos) << i;
  }
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.1.analogena"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.1.spinena"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.watchdog.has_bit"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.nvwatchdogtimeout"), std::string::npos);

  // HAL -> terminals.
  halcmd("setp hm2_7i92.0.7i77.0.0.output-03 1");
  halcmd("setp hm2_7i92.0.7i77.0.0.output-12 1");
  halcmd("setp hm2_7i92.0.7i77.0.1.analogout2 4.5");
  halcmd("setp hm2_7i92.0.7i77.0.1.analogout5 -7.25");
  halcmd("setp hm2_7i92.0.7i77.0.1.analogena 1");
  EXPECT_TRUE(waitFor(
      [&] {
        auto s = sim_->get()["daughtercards"][0];
        return s["field_io"]["outputs"][3]["on"] == true && s["field_io"]["outputs"][12]["on"] == true &&
               std::abs(s["analog"]["outputs"][2]["volts"].get<double>() - 4.5) < 0.005 &&
               std::abs(s["analog"]["outputs"][5]["volts"].get<double>() + 7.25) < 0.005 &&
               s["analog"]["outputs"][0]["enable"] == true && s["analog"]["outputs"][5]["enable"] == false;
      },
      500ms))
      << sim_->get().dump();
  // Terminals -> HAL within a few periods.
  sim_->post("/api/input", {{"input", 7}, {"on", true}});
  EXPECT_TRUE(waitFor([&] { return getp("hm2_7i92.0.7i77.0.0.input-07") == "TRUE"; }, 500ms));
  sim_->post("/api/encoder", {{"encoder", 2}, {"velocity", 20000}});
  EXPECT_TRUE(waitFor([&] { return std::atoi(getp("hm2_7i92.0.encoder.02.count").c_str()) > 1000; }, 1000ms));
  EXPECT_EQ(getp("hm2_7i92.0.io_error"), "FALSE");

  // Stop the thread: within the 7I77's watchdog (200 ms here) the outputs
  // and enables drop, and the HostMot2 watchdog bites when its timeout
  // (patientDeadlines) has passed.
  halcmd("stop");
  const auto stopped = std::chrono::steady_clock::now();
  EXPECT_TRUE(waitFor(
      [&] {
        auto s = sim_->get()["daughtercards"][0];
        return s["field_io"]["outputs"][3]["on"] == false && s["analog"]["outputs"][0]["enable"] == false &&
               s["analog"]["outputs"][2]["volts"].get<double>() == 0.0;
      },
      1000ms));
  const auto dropped = std::chrono::steady_clock::now() - stopped;
  EXPECT_LT(dropped, 600ms) << "the watchdog's 200 ms and halcmd's own start-up";
  EXPECT_EQ(sim_->get()["daughtercards"][0]["field_io"]["faults"][0], "WatchdogFault");
  EXPECT_TRUE(waitFor([&] { return sim_->get()["watchdog"]["bitten"] == true; }, 1000ms));
  halcmd("start");
  EXPECT_TRUE(waitFor([&] { return getp("hm2_7i92.0.watchdog.has_bit") == "TRUE"; }, 1000ms));
}

// hostmot2's smart-serial set-up (LinuxCNC: hostmot2/sserial.c,
// hm2_sserial_parse_md and hm2_sserial_stopstart) writes STOP ALL (0x800)
// and gives it 51 ms of the wall clock, then START (0xF00) and 8000 ms.
// Debian 12's snapshot went on when either ran out; from 2.9.4 (LinuxCNC
// commit cbdb967b0d, #1747) the load fails. The card answers both in time
// on the host clock (a command that is not a DoIt meets the wall clock:
// docs/clocks.md) and on the wall clock, and no release says a set-up
// command timed out.
TEST_F(LinuxCnc, SmartSerialSetUpIsAnsweredInTimeOnBothClocks) {
  for (const bool hostClock : {true, false}) {
    SCOPED_TRACE(hostClock ? "host clock" : "wall clock");
    sim_ = cardSim({}, hostClock);
    ASSERT_TRUE(sim_->up());
    const auto messages = fifo_ + ".messages";
    const auto r = load("00xxxxxx", true, messages);
    std::ifstream in(messages);
    const std::string said{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::filesystem::remove(messages);
    ASSERT_EQ(r.exit, 0) << r.out << said;
    EXPECT_EQ(said.find("Timeout"), std::string::npos) << said;
    EXPECT_EQ(said.find("ailed to"), std::string::npos) << said;  // "Failed to restart device"
    EXPECT_TRUE(waitFor([&] { return getp("hm2_7i92.0.sserial.port-0.port_state") == "3"; }, 2000ms))
        << "port_state " << getp("hm2_7i92.0.sserial.port-0.port_state");
    EXPECT_NE(halcmd("show pin hm2_7i92.0.7i77.0.0.input-00").out.find("input-00"), std::string::npos);
    hal("halrun -U");
    sim_.reset();
  }
}

// sserial_port_0=xxxxxxxx: every channel of the port off. hostmot2 loads,
// makes no smart-serial port and no 7I77 pins, and runs the card's other
// modules. Debian 12's snapshot returned from the smart-serial set-up as soon
// as it saw every channel off; from 2.9.4 (commit cbdb967b0d) it probes
// the instance all the same (reset, version, baud rate, START in setup
// mode) and then finds no remote: the sim answers that probe as a card
// with nothing enabled.
TEST_F(LinuxCnc, SmartSerialSetUpWithEveryChannelOffLoadsTheRestOfTheCard) {
  startSim();
  const auto messages = fifo_ + ".messages";
  const auto r = load("xxxxxxxx", true, messages);
  std::ifstream in(messages);
  const std::string said{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::filesystem::remove(messages);
  ASSERT_EQ(r.exit, 0) << r.out << said;
  std::printf("LinuxCNC %d.%d.%d with sserial_port_0=xxxxxxxx said:\n%s\n", test_support::linuxCncRelease().major,
              test_support::linuxCncRelease().minor, test_support::linuxCncRelease().patch, said.c_str());
  const auto pins = halcmd("show pin").out;
  EXPECT_EQ(pins.find("7i77"), std::string::npos) << pins;
  EXPECT_EQ(pins.find("sserial.port-0"), std::string::npos) << pins;
  EXPECT_NE(pins.find("hm2_7i92.0.encoder.00.count"), std::string::npos) << pins;
  sim_->post("/api/encoder", {{"encoder", 0}, {"velocity", 20000}});
  EXPECT_TRUE(waitFor([&] { return std::atoi(getp("hm2_7i92.0.encoder.00.count").c_str()) > 1000; }, 1000ms));
  EXPECT_EQ(getp("hm2_7i92.0.io_error"), "FALSE");
  EXPECT_EQ(said.find("Timeout"), std::string::npos) << said;
}

TEST_F(LinuxCnc, FieldIoModesProduceTheirPins) {
  startSim();
  const auto r = load("30xxxxxx");  // field I/O mode 3
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out;
  for (int i = 0; i < 4; ++i) EXPECT_NE(pins.find(fmt("hm2_7i92.0.7i77.0.0.analogin%d", i)), std::string::npos) << pins;
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.fieldvoltage"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.enc0.count"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.enc1.count"), std::string::npos);
  // The field voltage reaches HAL in volts.
  EXPECT_TRUE(waitFor(
      [&] {
        const double v = std::atof(getp("hm2_7i92.0.7i77.0.0.fieldvoltage").c_str());
        return std::abs(v - 24.0) < 0.2;
      },
      500ms));
}

// The parameters LinuxCNC makes of the GTOC (LinuxCNC: sserial.c, read only
// when the direction is Input): the siblings' set in sserial(9), nv* and
// swrevision ro; the manual's working unitnumber and watchdogtime rw; no
// encmode, hwrevision or mode 1..3 process data as parameters in mode 0.
TEST_F(LinuxCnc, SmartSerialParametersAreTheSiblingsWithTheirReadOnlyChoice) {
  startSim();
  ASSERT_EQ(load("00xxxxxx").exit, 0);
  const auto params = halcmd("show param").out;
  auto line = [&](const std::string& name) {
    const auto full = "hm2_7i92.0.7i77.0." + name;
    std::size_t at = params.find(full + "\n");
    if (at == std::string::npos) return std::string();
    const auto begin = params.rfind('\n', at);
    return params.substr(begin == std::string::npos ? 0 : begin + 1, at + full.size() - (begin + 1));
  };
  for (const char* ro : {"0.nvbaudrate", "0.nvunitnumber", "0.nvwatchdogtimeout", "0.swrevision", "0.nvencmode0",
                         "0.nvencmode1", "1.nvbaudrate", "1.nvunitnumber", "1.nvwatchdogtimeout", "1.swrevision"}) {
    const auto l = line(ro);
    EXPECT_NE(l.find(" RO "), std::string::npos) << ro << ": " << l << "\n" << params;
  }
  for (const char* rw : {"0.unitnumber", "0.watchdogtime", "1.unitnumber", "1.watchdogtime"}) {
    const auto l = line(rw);
    EXPECT_NE(l.find(" RW "), std::string::npos) << rw << ": " << l << "\n" << params;
  }
  for (const char* absent : {"0.encmode0", "0.encmode1", "1.hwrevision", "0.analogin0", "0.fieldvoltage"})
    EXPECT_EQ(line(absent), "") << absent << "\n" << params;
}

// Measurements, not pass/fail tests: what LinuxCNC's hm2_eth counts at 1 kHz
// on the wall clock depends on how this machine schedules LinuxCNC's servo
// thread (not real-time here), so these print figures (scripts/test runs
// them with LBPKIT_MEASURE=1) and assert only what holds however it is
// scheduled. LBPKIT_SOAK_SECONDS sets the soak's length (10 s unless set).
bool measuring() { return std::getenv("LBPKIT_MEASURE") != nullptr; }

TEST_F(LinuxCnc, SixtySecondsAt1kHz) {
  if (!measuring()) GTEST_SKIP() << "a measurement: LBPKIT_MEASURE=1 runs it";
  const char* env = std::getenv("LBPKIT_SOAK_SECONDS");
  const int seconds = env != nullptr ? std::atoi(env) : 10;
  startSim(false);
  if (!measuredLoad()) return;
  const auto before = sim_->get()["lbp16"]["packets"].get<std::uint64_t>();
  std::this_thread::sleep_for(std::chrono::seconds(seconds));
  const auto after = sim_->get()["lbp16"]["packets"].get<std::uint64_t>();
  const auto errors = getp("hm2_7i92.0.packet-error-total");
  auto server = sim_->get()["server"];
  const auto ioError = getp("hm2_7i92.0.io_error");
  // A figure: the goal is none, but this machine's LinuxCNC runs without a
  // real-time kernel.
  std::printf("LinuxCNC hm2_eth, 1 kHz servo thread, %d s: %llu datagrams served, packet-error-total %s, io_error %s; "
              "server time per datagram: median %.1f us, p99 %.1f us, max %.1f us (of it queued in the socket: max %.1f us); "
              "card thread: %s\n",
              seconds, static_cast<unsigned long long>(after - before), errors.c_str(), ioError.c_str(),
              server["median_us"].get<double>(), server["p99_us"].get<double>(), server["max_us"].get<double>(),
              server["queue_max_us"].get<double>(), server["scheduling"].get<std::string>().c_str());
  // About two a cycle while hm2_eth reads; none once io_error has stopped
  // it, which a servo thread held back on this machine can cause before the
  // window opens (the figures above show it): that the sim served unless
  // hm2_eth gave up is all that holds however LinuxCNC is scheduled.
  if (ioError != "TRUE") {
    EXPECT_GT(after - before, 0U) << "hm2_eth reads, but the sim served nothing";
  }
}

// A HAL file loading hm2_eth with 12 muxed encoders and smart-serial
// channels 0..5 (the hostmot2 man page: sserial_port_N, one digit or x per
// channel), the servo thread running; returns its name.
std::string twelveEncodersAndSixChannels(const std::string& file, const std::string& cardIp) {
  std::ofstream(file) << "loadrt hostmot2\n"
                      << "loadrt hm2_eth board_ip=" << cardIp << " config=\"num_encoders=12 sserial_port_0=000000\"\n"
                      << patientDeadlines("hm2_7i92.0") << "loadrt threads name1=servo period1=1000000\n"
                      << "addf hm2_7i92.0.read servo\naddf hm2_7i92.0.write servo\nstart\n";
  return file;
}

// The card's IDROM is Mesa's two-7I77 firmware
// (PIN_7I77x2_34.vhd): a configuration asking for 12 muxed encoders and
// smart-serial channels 3..5 loads. With one 7I77, channels 3..5 answer
// "no remote" (hm2 makes their pins GPIO) and the first 7I77 runs as ever.
TEST_F(LinuxCnc, Hm2EthLoadsTwelveEncodersAndChannels3To5WithOne7I77) {
  startSim();
  const auto r = hal("halcmd -f " + twelveEncodersAndSixChannels(fifo_ + ".hal", cardIp_));
  std::filesystem::remove(fifo_ + ".hal");
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out;
  for (int i = 0; i < 12; ++i) EXPECT_NE(pins.find(fmt("hm2_7i92.0.encoder.%02d.count", i)), std::string::npos) << i;
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.input-00"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.1.analogout5"), std::string::npos);
  EXPECT_EQ(pins.find("hm2_7i92.0.7i77.0.3."), std::string::npos) << "nothing on channel 3";
  sim_->post("/api/input", {{"input", 5}, {"on", true}});
  EXPECT_TRUE(waitFor([&] { return getp("hm2_7i92.0.7i77.0.0.input-05") == "TRUE"; }, 500ms));
  EXPECT_EQ(getp("hm2_7i92.0.io_error"), "FALSE");
}

// Two 7I77s (`[[daughtercard]]` twice): the second on channels 3 and 4 and
// encoders 6..11, as on the real card.
TEST_F(LinuxCnc, Hm2EthRunsTwo7I77sOnChannels0To5AndTwelveEncoders) {
  const auto config = fifo_ + ".toml";
  std::ofstream(config) << "[card]\npinout = \"7I77x2\"\n[[daughtercard]]\ntype = \"7I77\"\n[[daughtercard]]\ntype = \"7I77\"\n";
  sim_ = cardSim(std::vector<std::string>{"--config", config});
  ASSERT_TRUE(sim_->up());
  patient7i77Watchdogs({0, 1, 3, 4});
  const auto r = hal("halcmd -f " + twelveEncodersAndSixChannels(fifo_ + ".hal", cardIp_));
  std::filesystem::remove(fifo_ + ".hal");
  std::filesystem::remove(config);
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out;
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.3.input-31"), std::string::npos) << pins;
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.3.output-15"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.4.analogout5"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.encoder.11.count"), std::string::npos);
  // The second 7I77's terminals reach HAL, and HAL them.
  sim_->post("/api/input", {{"connector", 1}, {"input", 3}, {"on", true}});
  EXPECT_TRUE(waitFor([&] { return getp("hm2_7i92.0.7i77.0.3.input-03") == "TRUE"; }, 500ms));
  EXPECT_EQ(getp("hm2_7i92.0.7i77.0.0.input-03"), "FALSE");
  sim_->post("/api/encoder", {{"connector", 1}, {"encoder", 5}, {"velocity", 20000}});
  EXPECT_TRUE(waitFor([&] { return std::atoi(getp("hm2_7i92.0.encoder.11.count").c_str()) > 1000; }, 1000ms));
  halcmd("setp hm2_7i92.0.7i77.0.3.output-01 1");
  EXPECT_TRUE(waitFor([&] { return sim_->get()["daughtercards"][1]["field_io"]["outputs"][1]["on"] == true; }, 500ms))
      << sim_->get()["daughtercards"][1].dump();
  EXPECT_EQ(getp("hm2_7i92.0.io_error"), "FALSE");
  // The second connector's EEPROM files (FILE.2, FILE.analog.2) go too.
  hal("halrun -U");
  sim_.reset();
  const auto state = (std::filesystem::temp_directory_path() / ("lbpkit-interop-" + std::to_string(::getpid()))).string();
  std::filesystem::remove(state + ".2");
  std::filesystem::remove(state + ".analog.2");
}

// A bad network, as hm2_eth sees it. Its documented rules
// (hm2_eth(9)): a cycle with a read or write error adds
// packet-error-increment to packet-error-level (up to packet-error-limit), a
// good one takes packet-error-decrement off (down to 0), and at the limit
// io_error is set for good. The sim's network loses or delays replies on
// purpose (POST /api/network); the numbers seen are printed.
TEST_F(LinuxCnc, PacketErrorsFollowHm2EthsDocumentedRules) {
  if (!measuring()) GTEST_SKIP() << "a measurement: LBPKIT_MEASURE=1 runs it";
  startSim(false);
  if (!measuredLoad()) return;
  const std::string board = "hm2_7i92.0.";
  const int limit = std::atoi(getp(board + "packet-error-limit").c_str());
  const int increment = std::atoi(getp(board + "packet-error-increment").c_str());
  const int decrement = std::atoi(getp(board + "packet-error-decrement").c_str());
  ASSERT_GT(limit, 0);
  ASSERT_GT(increment, 0);
  ASSERT_GT(decrement, 0);
  std::printf("hm2_eth after loading: io_error %s, packet-error-total %s\n", getp(board + "io_error").c_str(),
              getp(board + "packet-error-total").c_str());
  auto total = [&] { return std::atoll(getp(board + "packet-error-total").c_str()); };
  auto network = [&](const json& body) { return sim_->post("/api/network", body); };

  // While losses are rehearsed, a higher limit: LinuxCNC's servo thread runs
  // without real-time priority here, and a late cycle of its own must not
  // end the run before the rules are seen.
  halcmd("setp " + board + "packet-error-limit 100");
  halcmd("setp " + board + "io_error 0");  // from here on, the rules (hm2_eth: the user resets it)

  // 1 % of the replies lost, for 3 s: each loss is one error cycle, isolated
  // losses never reach the limit.
  const auto before = total();
  auto set = network({{"direction", "reply"}, {"drop", 0.01}, {"seed", 7}});
  ASSERT_TRUE(set.contains("set")) << set.dump();
  int highest = 0;
  for (int i = 0; i < 30; ++i) {
    std::this_thread::sleep_for(100ms);
    highest = std::max(highest, std::atoi(getp(board + "packet-error-level").c_str()));
  }
  auto seen = network({{"clear", true}});
  const auto dropped = seen["did"]["reply"]["dropped"].get<long long>();
  const auto passed = seen["did"]["reply"]["passed"].get<long long>();
  const auto errors = total() - before;
  std::printf("hm2_eth with 1 %% of replies dropped for 3 s: %lld replies, %lld dropped, packet-error-total +%lld, "
              "highest packet-error-level seen %d (limit %d, increment %d, decrement %d), io_error %s\n",
              dropped + passed, dropped, errors, highest, limit, increment, decrement,
              getp(board + "io_error").c_str());
  EXPECT_GE(errors, dropped) << "every lost reply is a read error";

  // Good cycles take the level back down by the decrement, to 0 (LinuxCNC's
  // own late cycles add to it meanwhile: how long it took is the figure).
  const auto calm = std::chrono::steady_clock::now();
  const bool back = waitFor([&] { return getp(board + "packet-error-level") == "0"; }, 5000ms);
  std::printf("hm2_eth: packet-error-level back to 0 %s\n",
              back ? fmt("after %.0f ms", std::chrono::duration<double, std::milli>(
                                                  std::chrono::steady_clock::now() - calm).count()).c_str()
                   : "not within 5 s");

  // Every reply 3 ms late (the read timeout is 80 % of the 1 ms period):
  // every cycle is an error, the level climbs to the limit and io_error is
  // set, and stays set when the network is good again.
  halcmd("setp " + board + "packet-error-limit " + std::to_string(limit));
  halcmd("setp " + board + "io_error 0");
  network({{"direction", "reply"}, {"delay_us", 3000}});
  EXPECT_TRUE(waitFor([&] { return getp(board + "io_error") == "TRUE"; }, 2000ms));
  const auto late = network({{"clear", true}});
  // From 0, limit / increment late replies reach the limit (fewer if a
  // cycle of LinuxCNC's own was late too); then hm2_eth stops reading.
  const auto delayed = late["did"]["reply"]["delayed"].get<long long>();
  std::printf("hm2_eth with every reply 3 ms late: io_error %s, packet-error-level %s, packet-error-exceeded %s, "
              "%lld replies delayed\n",
              getp(board + "io_error").c_str(), getp(board + "packet-error-level").c_str(),
              getp(board + "packet-error-exceeded").c_str(), delayed);
  EXPECT_EQ(std::atoi(getp(board + "packet-error-level").c_str()), limit);
  EXPECT_EQ(getp(board + "packet-error-exceeded"), "TRUE");
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(getp(board + "io_error"), "TRUE") << "the condition must be reset by hand";
  std::printf("hm2_eth: %lld replies delayed to reach the limit (at most %d from 0)\n", delayed,
              (limit + increment - 1) / increment);
}

// While LinuxCNC runs at 1 kHz, another socket floods the card
// with garbage and with replayed reads, ten times LinuxCNC's own rate: the
// card answers LinuxCNC in time all along (no io_error) and its memory stays
// flat.
TEST_F(LinuxCnc, AGarbageAndReplayFloodLeavesLinuxCncRunning) {
  if (!measuring()) GTEST_SKIP() << "a measurement: LBPKIT_MEASURE=1 runs it";
  startSim(false);
  if (!measuredLoad()) return;
  const std::string board = "hm2_7i92.0.";
  // The flood's sender and the sim take CPU from LinuxCNC's servo thread,
  // which runs without real-time priority on this machine: a few late
  // cycles of its own must not end the run (they are counted and printed).
  // A card the flood kept from answering would still set io_error, within
  // 50 cycles at this limit.
  halcmd("setp " + board + "packet-error-limit 100");
  std::this_thread::sleep_for(300ms);
  const long before = sim_->residentKb();
  const auto errorsBefore = std::atoll(getp(board + "packet-error-total").c_str());
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(27181);
  ::inet_pton(AF_INET, cardIp_.c_str(), &sa.sin_addr);
  // A read of the IDROM and of the 7I77's process data, as hm2_eth sends
  // them, replayed; and noise of every length.
  const std::uint8_t replay[][4] = {{0x01, 0x4A, 0x00, 0x01}, {0x08, 0x4A, 0x00, 0x5D}, {0x04, 0x4A, 0x00, 0x5C}};
  std::uint32_t x = 11;
  std::vector<std::uint8_t> junk(1500);
  long sent = 0;
  const auto end = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < end) {
    for (int k = 0; k < 10; ++k, ++sent) {
      if (k % 2 == 0) {
        const auto& r = replay[static_cast<std::size_t>(sent) % 3];
        ::sendto(fd, r, sizeof r, 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
      } else {
        for (auto& b : junk) b = static_cast<std::uint8_t>((x = x * 1103515245U + 12345U) >> 16);
        ::sendto(fd, junk.data(), 1 + x % junk.size(), 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
      }
    }
    std::this_thread::sleep_for(1ms);
  }
  ::close(fd);
  std::this_thread::sleep_for(200ms);
  const long after = sim_->residentKb();
  const auto s = sim_->get();
  const auto errors = std::atoll(getp(board + "packet-error-total").c_str()) - errorsBefore;
  std::printf("flood of %ld datagrams in 5 s beside LinuxCNC at 1 kHz: io_error %s, packet-error-total +%lld, "
              "sim resident memory %ld kB -> %ld kB, %d malformed\n",
              sent, getp(board + "io_error").c_str(), errors, before, after,
              s["lbp16"]["parse_errors"].get<int>());
  EXPECT_GT(s["lbp16"]["parse_errors"].get<int>(), 0);
  ASSERT_GT(before, 0);
  EXPECT_LT(after - before, 2048) << "the sim's memory grew under the flood";
}

}  // namespace
}  // namespace interop
