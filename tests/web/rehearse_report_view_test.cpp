// SPDX-License-Identifier: MIT
// The report.html of `lbpkit rehearse` (apps/lbpkit/rehearse_report), made
// from tests/cli/rehearse_report_fixture.json, opened from a file in
// headless Chromium (through chromedriver, as the web view's tests do):
// every plot is drawn by the inlined Chart.js with its series and the
// events' lines, nothing is fetched, and text from the report holding
// </script> shows as text and runs nothing. The screenshot is
// web-screenshots/rehearse-report.png in the build folder.
#include <gtest/gtest.h>

#include "rehearse_report.hpp"
#include "web_support.hpp"

namespace {

using namespace std::chrono_literals;
using namespace webtest;

json fixture() {
  std::ifstream in(LBPKIT_TESTS_DIR "/cli/rehearse_report_fixture.json");
  return json::parse(in);
}

std::size_t plotted(const json& report) {
  std::size_t n = 0;
  for (const auto& c : report["checks"]) n += c.contains("plot");
  return n;
}

// Writes the report's page to a file of the test's own and opens it.
class ReportPage {
 public:
  explicit ReportPage(const json& report) {
    std::ofstream(file_) << lbpkit::app::rehearse::reportHtml(report);
    browser.open("file://" + file_);
  }
  bool drawn(std::size_t charts) {
    return browser.waitFor(
        "return !!window.lbpkitReport && window.lbpkitReport.charts.length === " + std::to_string(charts) + ";",
        30000ms);  // Chromium's start, on a loaded machine
  }
  Browser browser;

 private:
  test_support::TempDir dir_{"lbpkit-report"};
  std::string file_ = dir_ / "report.html";
};

// Per canvas: its chart's datasets (label, points, stepped, axis), the
// pixels drawn (alpha not 0), and those in the fault's red (its line).
constexpr const char* kCanvases = R"js(
return Array.from(document.querySelectorAll('canvas')).map(canvas => {
  const chart = Chart.getChart(canvas);
  const pixels = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
  let ink = 0, faultRed = 0;
  for (let i = 0; i < pixels.length; i += 4) {
    if (pixels[i + 3] !== 0) ++ink;
    if (pixels[i + 3] > 200 && Math.abs(pixels[i] - 0xb0) < 12 && pixels[i + 1] < 12 && Math.abs(pixels[i + 2] - 0x20) < 12)
      ++faultRed;
  }
  return {
    id: canvas.id, chart: !!chart, ink: ink, faultRed: faultRed, area: canvas.width * canvas.height,
    datasets: chart ? chart.data.datasets.map(d => ({ label: d.label, points: d.data.length, stepped: d.stepped,
                                                      axis: d.yAxisID })) : []
  };
});
)js";

TEST(RehearseReportPage, EveryPlotIsDrawnFromTheFileAlone) {
  SKIP_WITHOUT_BROWSER();
  const json report = fixture();
  ReportPage page(report);
  ASSERT_TRUE(page.drawn(plotted(report)));
  Browser& b = page.browser;
  EXPECT_EQ(b.run("return Chart.version;"), "3.9.1");
  EXPECT_EQ(b.run("return performance.getEntriesByType('resource').length;"), 0) << "nothing fetched";
  EXPECT_EQ(b.run("return document.querySelectorAll('table.summary tbody tr').length;"), report["checks"].size());

  const json canvases = b.run(kCanvases);
  ASSERT_EQ(canvases.size(), plotted(report));
  std::size_t k = 0;
  for (const auto& check : report["checks"]) {
    if (!check.contains("plot")) continue;
    const json& canvas = canvases[k++];
    const json& plot = check["plot"];
    SCOPED_TRACE(check["id"].get<std::string>());
    EXPECT_TRUE(canvas["chart"].get<bool>());
    ASSERT_EQ(canvas["datasets"].size(), plot["series"].size());
    for (const auto& d : canvas["datasets"]) {
      EXPECT_EQ(d["points"], plot["time_s"].size());
      // On/off signals (unit "") are stepped on their own axis; the rest are not.
      const std::string label = d["label"];
      const bool signal = label.find('(') == std::string::npos;
      EXPECT_EQ(d["stepped"].get<bool>(), signal) << label;
      EXPECT_EQ(d["axis"] == "onoff", signal) << label;
    }
    // Drawn: lines, axes and labels cover a few percent of the canvas,
    // and the fault's dashed red line is there.
    EXPECT_GT(canvas["ink"].get<double>(), 0.02 * canvas["area"].get<double>());
    EXPECT_GT(canvas["faultRed"].get<int>(), 30);
  }
  // The runaway's datasets by name, with their units.
  std::vector<std::string> labels;
  for (const auto& d : canvases[0]["datasets"]) labels.push_back(d["label"]);
  EXPECT_EQ(labels, (std::vector<std::string>{"command (mm)", "enabled", "following error (mm)", "position (mm)"}));
  b.run("window.scrollTo(0, 0);");
  const auto shot = b.screenshot("rehearse-report");
  std::printf("report: %s\n", shot.c_str());
  b.run("document.getElementById('check-2').scrollIntoView();");
  b.screenshot("rehearse-report-limits");
}

TEST(RehearseReportPage, TextFromTheReportRunsNothing) {
  SKIP_WITHOUT_BROWSER();
  json report = fixture();
  const std::string hostile = "X</script><script>window.injected = 1;</script><!--";
  report["checks"][0]["title"] = hostile;
  report["checks"][0]["plot"]["events"][0]["what"] = hostile;
  report["checks"][0]["plot"]["series"][hostile] = report["checks"][0]["plot"]["series"]["position"];
  report["checks"][0]["plot"]["units"][hostile] = "mm";
  report["machine"] = "<img src=x onerror=\"window.injected = 2\">";
  ReportPage page(report);
  ASSERT_TRUE(page.drawn(plotted(report))) << "the data, holding </script>, parsed whole";
  Browser& b = page.browser;
  EXPECT_EQ(b.run("return typeof window.injected;"), "undefined");
  EXPECT_EQ(b.run("return document.querySelectorAll('img').length;"), 0);
  EXPECT_EQ(b.run("return document.querySelector('table.summary tbody tr td:nth-child(2) a').textContent;"), hostile);
  EXPECT_EQ(b.run("return Chart.getChart(document.getElementById('plot-0')).data.datasets.some(d => d.label === '" +
                  std::string("X<\\/script><script>window.injected = 1;<\\/script><!-- (mm)") + "');"),
            true);
}

}  // namespace
