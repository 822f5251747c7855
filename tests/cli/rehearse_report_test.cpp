// SPDX-License-Identifier: MIT
// The report of `lbpkit rehearse` (apps/lbpkit/rehearse_report): its
// terminal lines for a passed, a failed and a not applicable check, and
// report.html from tests/cli/rehearse_report_fixture.json: the summary
// table, Chart.js inlined, one canvas per plot, and the report's text
// escaped so that a title holding </script> stays text.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "rehearse_report.hpp"

namespace {

using lbpkit::app::rehearse::checkLine;
using lbpkit::app::rehearse::reportHtml;
using nlohmann::json;

json fixture() {
  std::ifstream in(LBPKIT_TESTS_DIR "/cli/rehearse_report_fixture.json");
  return json::parse(in);
}

const json& check(const json& report, const std::string& id) {
  for (const auto& c : report["checks"])
    if (c["id"] == id) return c;
  throw std::runtime_error("no check " + id + " in the fixture");
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

TEST(RehearseReport, APassedCheckLineGivesItsFiguresWithUnits) {
  const json c = {{"id", "runaway.x.reversed-encoder.moving"},
                  {"title", "X: reversed encoder while moving at 500 mm/s"},
                  {"verdict", "pass"},
                  {"reason", ""},
                  {"figures",
                   {{"time_to_disable_s", 0.021},
                    {"distance", 9.8},
                    {"bound", 12.0},
                    {"peak_velocity", 510.0},
                    {"left_to_hard_stop", 310.2},
                    {"hit_hard_stop", false}}}};
  EXPECT_EQ(checkLine(c),
            "pass  X: reversed encoder while moving at 500 mm/s — drives off after 0.021 s, 9.8 mm travelled "
            "(bound 12.0 mm), peak 510.0 mm/s, 310.2 mm left to the hard stop");
  EXPECT_EQ(checkLine(c, "inch"),
            "pass  X: reversed encoder while moving at 500 mm/s — drives off after 0.021 s, 9.8 inch travelled "
            "(bound 12.0 inch), peak 510.0 inch/s, 310.2 inch left to the hard stop");
}

TEST(RehearseReport, AFailedCheckLineSaysFailAndWhy) {
  const json report = fixture();
  EXPECT_EQ(checkLine(check(report, "limits.y.max"), report["linear_units"].get<std::string>()),
            "FAIL  Y: through the + limit switch at MAX_VELOCITY — drives off after 0.013 s, peak 300.0 mm/s, "
            "5.0 mm past the switch, 0.0 mm left to the hard stop, HIT THE HARD STOP; Y reaches its hard stop: "
            "the switch at 395.0 mm leaves 5.0 mm, the drive needs 6.9 mm to stop from 300 mm/s");
}

TEST(RehearseReport, ANotApplicableCheckLineGivesTheReason) {
  EXPECT_EQ(checkLine(check(fixture(), "spindle")), "n/a   Spindle — the configuration has no spindle");
}

TEST(RehearseReport, FiguresItDoesNotKnowPrintAsNameAndValue) {
  const json report = fixture();
  EXPECT_EQ(checkLine(check(report, "host.lost")),
            "pass  Host lost: hm2_eth stops mid-move — analog outputs at 0 V after 0.011 s, field outputs off after "
            "0.011 s, errors: hm2_eth read errors 3, watchdog bites 1, watchdog_timeout_ms = 10");
  // Small times keep their digits rather than print as 0.000 s.
  EXPECT_EQ(checkLine({{"title", "t"}, {"verdict", "pass"}, {"figures", {{"time_to_ena_off_s", 0.0004}}}}),
            "pass  t — ENA off after 0.0004 s");
}

TEST(RehearseReport, ALineNeverThrowsAndStaysOneLine) {
  EXPECT_EQ(checkLine(json()), "?     ?");
  EXPECT_EQ(checkLine({{"title", "a\nb\x1b[2J"}, {"verdict", "fail"}, {"figures", {{"distance", "far"}}}}),
            "FAIL  a b [2J — ? mm travelled");
}

TEST(RehearseReport, TheHtmlHasARowPerCheckAndAPlotPerPlottedCheck) {
  const json report = fixture();
  const std::string page = reportHtml(report);
  EXPECT_EQ(count(page, "<tr class="), report["checks"].size());
  std::size_t plotted = 0;
  for (const auto& c : report["checks"]) {
    plotted += c.contains("plot");
    EXPECT_NE(page.find(c["cites"].get<std::string>()), std::string::npos) << c["id"];
  }
  EXPECT_EQ(plotted, 3U);
  EXPECT_EQ(count(page, "<canvas"), plotted);
  EXPECT_NE(page.find("<td class=\"verdict\">FAIL</td><td><a href=\"#check-2\">Y: through the + limit switch"),
            std::string::npos);
  EXPECT_NE(page.find("<td class=\"verdict\">n/a</td><td>Spindle<br>"), std::string::npos);
  EXPECT_NE(page.find("12.5 mm travelled (bound 15.0 mm)"), std::string::npos);
  EXPECT_NE(page.find("1 failed"), std::string::npos);
}

TEST(RehearseReport, TheHtmlInlinesChartJsAndFetchesNothing) {
  const std::string page = reportHtml(fixture());
  EXPECT_NE(page.find("Chart.js v3.9.1"), std::string::npos) << "Debian's Chart.js, as the web view embeds it";
  EXPECT_GT(page.size(), 150000U);
  for (const char* fetch : {"src=", "href=\"http", "href=\"//", "<link", "@import", "url("})
    EXPECT_EQ(page.find(fetch), std::string::npos) << fetch;
  // The three scripts (Chart.js, the data, the charts) and no other.
  EXPECT_EQ(count(page, "<script"), 3U);
  EXPECT_EQ(count(page, "</script>"), 3U);
}

TEST(RehearseReport, NothingFromTheJsonEndsAnElementOrTheScript) {
  json report = fixture();
  const std::string hostile = "X</script><script>alert(1)</script><!--";
  report["checks"][0]["title"] = hostile;
  report["checks"][0]["plot"]["events"][0]["what"] = hostile;
  report["checks"][0]["plot"]["series"][hostile] = report["checks"][0]["plot"]["series"]["position"];
  report["checks"][1]["cites"] = "<img src=x onerror=alert(2)>";
  report["configuration"] = "/home/u/a&b\"c'.ini";
  const std::string page = reportHtml(report);
  EXPECT_EQ(page.find("alert(1)</script>"), std::string::npos);
  EXPECT_EQ(page.find("<img"), std::string::npos);
  EXPECT_EQ(count(page, "<script"), 3U);
  EXPECT_EQ(count(page, "</script>"), 3U);
  EXPECT_NE(page.find("X&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;&lt;!--"), std::string::npos);
  EXPECT_NE(page.find("/home/u/a&amp;b&quot;c&#39;.ini"), std::string::npos);
  // In the data, the same text as JSON escapes (JSON.parse gives it back whole).
  EXPECT_NE(page.find("X\\u003c/script\\u003e\\u003cscript\\u003ealert(1)\\u003c/script\\u003e\\u003c!--"),
            std::string::npos);
}

TEST(RehearseReport, AReportWithoutPlotsHasNoScript) {
  json report = fixture();
  for (auto& c : report["checks"]) c.erase("plot");
  const std::string page = reportHtml(report);
  EXPECT_EQ(page.find("<script"), std::string::npos);
  EXPECT_EQ(page.find("<canvas"), std::string::npos);
  EXPECT_EQ(count(page, "<tr class="), report["checks"].size());
  EXPECT_NO_THROW(static_cast<void>(reportHtml(json())));
  EXPECT_NO_THROW(static_cast<void>(reportHtml({{"checks", {{{"plot", {{"time_s", "no"}}}}}}})));
}

}  // namespace
