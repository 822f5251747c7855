// SPDX-License-Identifier: MIT
// The web view in a real browser: headless Chromium from Debian,
// driven through Debian's chromedriver, loads the page from `lbpkit sim`,
// acts on the board as a user would (each action is an ordinary control-API
// call the page makes), and the host library, cycling the sim at about
// 1 kHz, reads the result. Each test saves a screenshot under the build
// folder (LBPKIT_SCREENSHOT_DIR). Skipped, saying why, when Chromium or
// chromedriver is missing (scripts/deps --test installs them).
#include <gtest/gtest.h>

#include "web_support.hpp"

namespace {

using namespace std::chrono_literals;

using namespace webtest;

// The page has drawn the board from its first frames.
constexpr const char* kBoardDrawn = "return !!document.getElementById('in-0-0') && (window.lbpkit.frames || 0) > 3;";

// Each test: its own sim (on loopback address n, with `extra` arguments), a
// host cycling it (when asked), and the page open in the browser with its
// board drawn.
class WebView : public testing::Test {
 protected:
  void start(int n, std::vector<std::string> extra = {}, bool withHost = true) {
    sim = std::make_unique<Sim>(loopback(n), std::move(extra));
    ASSERT_TRUE(sim->up());
    if (withHost) host = std::make_unique<Host>(*sim);
    b = std::make_unique<Browser>();
    b->open(sim->url());
    ASSERT_TRUE(b->waitFor(kBoardDrawn, 30000ms));  // Chromium's start, on a loaded machine
  }
  // Gone in this order: the browser, the host, then the sim.
  std::unique_ptr<Sim> sim;
  std::unique_ptr<Host> host;
  std::unique_ptr<Browser> b;
};

TEST_F(WebView, ThePageIsServedOfflineAndPushedAtLeast20FramesASecond) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(1, {}, false));
  // Chart.js came from lbpkit itself, not from the network.
  EXPECT_EQ(b->run("return typeof Chart;"), "function");
  EXPECT_EQ(b->run("return Chart.version;"), "3.9.1");
  // The rate the page measures, over its last two seconds.
  ASSERT_TRUE(b->waitFor("return (window.lbpkit.rate || 0) > 0;", 5000ms));
  std::this_thread::sleep_for(2500ms);
  const double rate = b->run("return window.lbpkit.rate;").get<double>();
  std::printf("web view: %.1f frames per second reach the page\n", rate);
  EXPECT_GE(rate, 20.0);
  // What the manual names is on the board.
  for (const char* id : {"led-CR1-0", "led-CR3-0", "led-CR6-0", "led-CR7-0", "led-CR15-0", "led-CR16-0", "tb2-5-0",
                         "in-31-0", "out-15-0", "aout-5-0", "enc-count-5-0", "ch-5-cs", "jumpers-0"})
    EXPECT_TRUE(b->run(std::string("return !!document.getElementById('") + id + "');").get<bool>()) << id;
  b->screenshot("web-board");
}

// With --api-token, a browser opens the web view as /?token=TOKEN: the
// token goes back as an HttpOnly, SameSite=Strict cookie, the address loses
// it, and the page, its scripts and its event stream work; without it the
// API still answers 401.
TEST_F(WebView, WithATokenTheBrowserComesInOnceThroughTheAddress) {
  SKIP_WITHOUT_BROWSER();
  sim = std::make_unique<Sim>(loopback(7), std::vector<std::string>{"--api-token", "s3cret-token"});
  ASSERT_TRUE(sim->up());
  b = std::make_unique<Browser>();
  b->open(sim->url("/"));
  EXPECT_TRUE(b->waitFor("return document.body.innerText.includes('needs');", 10000ms)) << "401 without the token";
  b->open(sim->url("/?token=wrong"));
  EXPECT_TRUE(b->waitFor("return document.body.innerText.includes('needs');", 10000ms)) << "401 with a wrong one";
  b->open(sim->url("/?token=s3cret-token"));
  ASSERT_TRUE(b->waitFor(kBoardDrawn, 30000ms)) << "the page, its scripts and its event stream with the cookie";
  EXPECT_EQ(b->run("return location.search;"), "") << "the token is no longer in the address";
  EXPECT_EQ(b->run("return document.cookie;"), "") << "no script can read the token";
  b->screenshot("web-with-token");
  // Outside the browser: the cookie or the bearer header, nothing else.
  httplib::Client c(sim->apiAddress(), sim->apiPort());
  EXPECT_EQ(c.Get("/api/state")->status, 401);
  EXPECT_EQ(c.Get("/api/state", {{"Cookie", "other=1; lbpkit_token=s3cret-token"}})->status, 200);
  EXPECT_EQ(c.Get("/api/state", {{"Cookie", "lbpkit_token=s3cret-tokeX"}})->status, 401);
  EXPECT_EQ(c.Get("/api/state", {{"Authorization", "Bearer s3cret-token"}})->status, 200);
  const auto r = c.Get("/?token=s3cret-token");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 303);
  EXPECT_EQ(r->get_header_value("Set-Cookie"), "lbpkit_token=s3cret-token; HttpOnly; SameSite=Strict; Path=/");
  // A page of another origin is refused even with the cookie.
  EXPECT_EQ(c.Post("/api/input", {{"Cookie", "lbpkit_token=s3cret-token"}, {"Origin", "http://evil.example"}},
                   R"({"input":1,"on":true})", "application/json")
                ->status,
            403);
}

TEST_F(WebView, ClickingAnInputIsReadByTheHost) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(2));
  ASSERT_TRUE(test_support::waitFor([&] { return host->cycles > 50; }));
  EXPECT_EQ(host->inputs.load() & (1U << 5), 0U);
  b->click("#in-5-0");  // INPUT5, TB8 pin 6
  EXPECT_TRUE(test_support::waitFor([&] { return (host->inputs.load() >> 5) & 1U; })) << "the host never read INPUT5 on";
  EXPECT_TRUE(b->waitFor("return document.getElementById('in-5-0').dataset.on === 'true';"));
  b->screenshot("web-input-on");
  b->click("#in-5-0");
  EXPECT_TRUE(test_support::waitFor([&] { return ((host->inputs.load() >> 5) & 1U) == 0; })) << "INPUT5 never went off";
}

TEST_F(WebView, AShortedOutputLightsTheFaultLedAndSetsTheFaultBits) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(3));
  host->outputs = 1U << 2;  // OUTPUT2 on
  ASSERT_TRUE(b->waitFor("return document.getElementById('out-2-0').dataset.on === 'true';"));
  ASSERT_TRUE(b->waitFor("return document.getElementById('led-CR16-0').dataset.lit === 'false';"))
      << "CR16 should be off once the host runs";
  EXPECT_EQ(host->fieldIoFaults.load(), 0);
  b->click("#load-2-0 option[value=short]");
  EXPECT_TRUE(b->waitFor("return document.getElementById('out-2-0').dataset.tripped === 'true';"));
  EXPECT_TRUE(b->waitFor("return document.getElementById('led-CR16-0').dataset.lit === 'true';"))
      << "CR16 (field I/O fault) did not light";
  EXPECT_TRUE(b->waitFor("return document.getElementById('fio-faults-0').textContent !== 'none';"));
  EXPECT_TRUE(test_support::waitFor([&] { return (host->fieldIoFaults.load() & 0x08U) != 0; }))
      << "the host never read OverCurrentFault (0x08) in the field I/O remote's fault byte";
  // The page names the fault the card has (the host's bit 0x08 above).
  EXPECT_TRUE(b->waitFor("return document.getElementById('fio-faults-0').textContent.includes('OverCurrentFault');"));
  const auto faults = sim->get()["daughtercards"][0]["field_io"]["faults"];
  std::printf("shorted OUTPUT2: the card shows faults %s, the host reads fault byte 0x%02X\n", faults.dump().c_str(),
              host->fieldIoFaults.load());
  b->screenshot("web-output-shorted");
}

TEST_F(WebView, UnpluggingAChannelShowsItsCsState) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(4));
  ASSERT_TRUE(b->waitFor("return document.getElementById('ch-0-state').textContent === 'running';"));
  const auto before = b->run("return document.getElementById('ch-0-cs').textContent;").get<std::string>();
  b->click("#ch-0-cable");
  EXPECT_TRUE(b->waitFor("return document.getElementById('ch-0-cable').dataset.connected === 'false';"));
  // The page shows the CS the card shows (GET /api/state), and it changed.
  EXPECT_TRUE(test_support::waitFor([&] {
    const auto cs = sim->get()["sserial"]["channels"][0]["cs"].get<std::string>();
    return b->run("return document.getElementById('ch-0-cs').textContent;").get<std::string>().rfind(cs, 0) == 0 &&
           b->run("return document.getElementById('ch-0-cs').textContent;").get<std::string>() != before;
  })) << "before: " << before;
  std::printf("channel 0 unplugged: CS %s -> %s\n", before.c_str(),
              b->run("return document.getElementById('ch-0-cs').textContent;").get<std::string>().c_str());
  b->screenshot("web-channel-unplugged");
}

TEST_F(WebView, WithTheMillAnAxisMovesOnThePlotWhileAHostDrivesIt) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(5, {"--machine", "mill"}));
  ASSERT_TRUE(b->waitFor("return !!window.lbpkit.charts.x;"));
  host->volts0 = 2.0;  // X at 50 mm/s
  // The plot's "x actual" line climbs by more than 20 mm within its window.
  const char* climbed =
      "const d = window.lbpkit.charts.x.data.datasets[1].data;"
      "return d.length > 20 && d[d.length - 1].y - d[0].y > 20;";
  EXPECT_TRUE(b->waitFor(climbed, 10000ms))
      << "host cycles " << host->cycles << " (failed " << host->failedCycles << "); X: " << sim->get("/api/machine")["axes"][0].dump()
      << "; analog: " << sim->get()["daughtercards"][0]["analog"].dump();
  const auto span = b->run(
      "const d = window.lbpkit.charts.x.data.datasets[1].data;"
      "return d.length ? [d.length, d[0].y, d[d.length - 1].y] : [0];");
  std::printf("X on the plot: %s (points, first and last position)\n", span.dump().c_str());
  EXPECT_TRUE(b->waitFor("return document.getElementById('amp-x').textContent.startsWith('enabled');"));
  b->run("document.getElementById('machine').scrollIntoView();");
  b->screenshot("web-mill-x-moving");
  host->volts0 = 0.0;
}

// On the 7I92T's 7I77+7I76 firmware, a stepper axis' row shows its
// StepGen's steps, the steps its motor lost and whether it stalled, and the
// 7I76 has a panel of its own: inputs a click sets, outputs and the spindle
// interface as a host on channel 3 drives them.
TEST_F(WebView, AStepperAxisAndThe7I76ShowWhatTheCardAndMachineDo) {
  SKIP_WITHOUT_BROWSER();
  ASSERT_NO_FATAL_FAILURE(start(6, {"--card", "7I92T", "--machine", LBPKIT_TESTS_DIR "/machines/router_stepper.toml"}, false));
  auto text = [&](const std::string& id) {
    return b->run("return document.getElementById('" + id + "').textContent;").get<std::string>();
  };
  // The stepper's row: no encoder buttons (it has none), its StepGen.
  ASSERT_TRUE(b->waitFor("return document.getElementById('steps-z').textContent === '0';"));
  EXPECT_EQ(text("amp-z").rfind("StepGen 0: 0 steps, 0 lost, in step", 0), 0U) << text("amp-z");
  EXPECT_FALSE(b->run("return !!document.getElementById('enc-z-A');").get<bool>());
  EXPECT_TRUE(b->run("return !!document.getElementById('enc-x-A');").get<bool>());
  EXPECT_FALSE(b->run("return !!document.getElementById('steps-x');").get<bool>());
  // The 7I76's panel: every input and output, channel 3.
  for (const char* id : {"i76-in-0", "i76-in-31", "i76-out-15", "i76-spinout", "i76-spinena", "i76-spindir", "i76-vfield"})
    EXPECT_TRUE(b->run(std::string("return !!document.getElementById('") + id + "');").get<bool>()) << id;
  EXPECT_NE(text("i76-card").find("SSerial channel 3"), std::string::npos);

  SevenI76Host host76(*sim);
  // A click on INPUT20 reaches the host through channel 3.
  b->click("#i76-in-20");
  EXPECT_TRUE(test_support::waitFor([&] { return (host76.inputs.load() >> 20) & 1U; })) << "the host never read 7I76 INPUT20 on";
  EXPECT_TRUE(b->waitFor("return document.getElementById('i76-in-20').dataset.on === 'true';"));
  EXPECT_EQ(sim->get()["daughtercards"][1]["field_io"]["inputs"][20]["on"], true);
  // The host's outputs and spindle command show on the panel.
  host76.outputs = 1U << 3;
  host76.spindleVolts = 5.0;
  EXPECT_TRUE(b->waitFor("return document.getElementById('i76-out-3').dataset.on === 'true';"));
  EXPECT_TRUE(b->waitFor("return document.getElementById('i76-spinena').textContent === 'enabled';"));
  EXPECT_TRUE(b->waitFor("return document.getElementById('i76-spinout').textContent === '5.000';"))
      << text("i76-spinout");
  EXPECT_EQ(b->run("return document.getElementById('i76-out-2').dataset.on;").get<std::string>(), "false");
  // Z stepping at 20 000 steps/s (25 mm/s): the row counts its steps, none lost.
  host76.stepRate = 20000.0;
  EXPECT_TRUE(b->waitFor("return Number(document.getElementById('steps-z').textContent) > 5000;", 10000ms))
      << text("amp-z");
  EXPECT_EQ(text("lost-z"), "0");
  EXPECT_EQ(b->run("return document.getElementById('stall-z').dataset.stalled;").get<std::string>(), "false");
  // Past the motor's pull-out rate (40 000 steps/s) it stalls and loses them.
  host76.stepRate = 60000.0;
  EXPECT_TRUE(b->waitFor("return document.getElementById('stall-z').dataset.stalled === 'true';", 10000ms))
      << text("amp-z");
  EXPECT_TRUE(b->waitFor("return Number(document.getElementById('lost-z').textContent) > 1000;", 10000ms))
      << text("amp-z");
  EXPECT_NE(text("stall-z").find("STALLED"), std::string::npos);
  const auto z = sim->get("/api/machine")["axes"][1];
  EXPECT_TRUE(z["stepper"]["stalled"].get<bool>()) << z.dump();
  EXPECT_GT(z["stepper"]["lost_steps"].get<std::int64_t>(), 1000) << z.dump();
  std::printf("stepper Z on the page: %s; API: %s\n", text("amp-z").c_str(), z["stepper"].dump().c_str());
  b->run("document.getElementById('i76-card').scrollIntoView();");
  b->screenshot("web-7i76-stepper");
  host76.stepRate = 0.0;
}

}  // namespace
