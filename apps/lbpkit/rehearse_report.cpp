// SPDX-License-Identifier: MIT
#include "rehearse_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <vector>

#include "web/web_assets.hpp"

namespace lbpkit::app::rehearse {

namespace {

using nlohmann::json;

// The report's fields, read leniently: a report from an older or newer
// lbpkit, or a check that failed before it measured anything, still prints.
const json& field(const json& j, const char* key) {
  static const json none;
  if (!j.is_object()) return none;
  const auto it = j.find(key);
  return it == j.end() ? none : *it;
}
std::string str(const json& j, const char* key, const char* otherwise = "") {
  const json& v = field(j, key);
  return v.is_string() ? v.get<std::string>() : otherwise;
}
std::optional<double> num(const json& j, const char* key) {
  const json& v = field(j, key);
  if (!v.is_number()) return std::nullopt;
  return v.get<double>();
}

// `decimals` places; a value that would print as zero but is not prints
// with two significant digits instead (0.0004 s is not "0.000 s").
std::string figure(std::optional<double> v, int decimals) {
  if (!v) return "?";
  if (!std::isfinite(*v)) return fmt::format("{}", *v);
  const std::string fixed = fmt::format("{:.{}f}", *v, decimals);
  if (*v != 0.0 && fixed.find_first_not_of("-0.") == std::string::npos) return fmt::format("{:.2g}", *v);
  return fixed;
}
std::string seconds(std::optional<double> v) { return figure(v, 3) + " s"; }

// One of the JSON's values, as printed for a figure this does not know.
std::string plain(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) return fmt::format("{}", v.get<double>());
  return v.dump();
}

// What the figures say, in the order a reader wants them: how fast, how
// far (against how far it may), how close to the hard stop, then the rest.
std::vector<std::string> figureTexts(const json& figures, std::string_view units) {
  std::vector<std::string> out;
  if (!figures.is_object()) return out;
  const auto length = [&](const char* key) { return figure(num(figures, key), 1) + " " + std::string(units); };
  std::vector<std::string> known;
  const auto has = [&](const char* key) {
    known.emplace_back(key);
    return figures.contains(key);
  };
  if (has("time_to_disable_s")) out.push_back("drives off after " + seconds(num(figures, "time_to_disable_s")));
  if (has("time_to_zero_volts_s"))
    out.push_back("analog outputs at 0 V after " + seconds(num(figures, "time_to_zero_volts_s")));
  if (has("time_to_ena_off_s")) out.push_back("ENA off after " + seconds(num(figures, "time_to_ena_off_s")));
  if (has("time_to_outputs_off_s"))
    out.push_back("field outputs off after " + seconds(num(figures, "time_to_outputs_off_s")));
  const bool bound = has("bound");
  if (has("distance"))
    out.push_back(length("distance") + " travelled" + (bound ? " (bound " + length("bound") + ")" : ""));
  else if (bound)
    out.push_back("bound " + length("bound"));
  if (has("peak_velocity"))
    out.push_back("peak " + figure(num(figures, "peak_velocity"), 1) + " " + std::string(units) + "/s");
  if (has("past_switch")) out.push_back(length("past_switch") + " past the switch");
  const bool left = has("left_to_hard_stop");
  if (left) out.push_back(length("left_to_hard_stop") + " left to the hard stop");
  if (has("hit_hard_stop")) {
    const json& hit = field(figures, "hit_hard_stop");
    if (hit == true)
      out.emplace_back("HIT THE HARD STOP");
    else if (hit != false)
      out.push_back("hit_hard_stop = " + plain(hit));
    else if (!left)
      out.emplace_back("hard stop not reached");
  }
  if (has("error_counts")) {
    const json& counts = field(figures, "error_counts");
    std::string s = "errors:";
    if (counts.is_object() && !counts.empty()) {
      for (const auto& [name, count] : counts.items())
        s += fmt::format("{} {} {}", s.back() == ':' ? "" : ",", name, plain(count));
    } else {
      s += " " + plain(counts);
    }
    out.push_back(s);
  }
  for (const auto& [name, value] : figures.items())
    if (std::find(known.begin(), known.end(), name) == known.end()) out.push_back(name + " = " + plain(value));
  return out;
}

std::string join(const std::vector<std::string>& parts, std::string_view separator) {
  std::string s;
  for (const auto& p : parts) s += (s.empty() ? "" : std::string(separator)) + p;
  return s;
}

// The verdict as the terminal shows it: a failure stands out in capitals.
std::string verdictWord(const json& check) {
  const std::string v = str(check, "verdict", "?");
  if (v == "pass") return "pass";
  if (v == "fail") return "FAIL";
  if (v == "not applicable") return "n/a";
  return v;
}

// The text after the title: figures, then the reason.
std::string details(const json& check, std::string_view units) {
  std::string s = join(figureTexts(field(check, "figures"), units), ", ");
  const std::string reason = str(check, "reason");
  if (!reason.empty()) s += (s.empty() ? "" : "; ") + reason;
  return s;
}

// Control characters (a newline, an escape sequence) from the JSON would
// break the line or drive the terminal: spaces instead.
std::string oneLine(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return s;
}

// `s` with each character that `escapes` names replaced by its escape.
struct Escape {
  char c;
  std::string_view as;
};
std::string escaped(std::string_view s, std::initializer_list<Escape> escapes) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    const auto e = std::find_if(escapes.begin(), escapes.end(), [c](const Escape& x) { return x.c == c; });
    if (e == escapes.end())
      out += c;
    else
      out += e->as;
  }
  return out;
}

std::string html(std::string_view s) {
  return escaped(s, {{'&', "&amp;"}, {'<', "&lt;"}, {'>', "&gt;"}, {'"', "&quot;"}, {'\'', "&#39;"}});
}

// JSON to sit inside a <script> element: <, > and & as \u escapes (only
// strings can hold them in JSON, where the escape means the same), so no
// "</script>" or "<!--" from the report can end or bend the element.
std::string scriptJson(const json& j) {
  return escaped(j.dump(-1, ' ', false, json::error_handler_t::replace),
                 {{'<', "\\u003c"}, {'>', "\\u003e"}, {'&', "\\u0026"}});
}

// Chart.js, as lbpkit embeds it for the web view (Debian's libjs-chart.js).
std::string chartJs() {
  for (const auto& asset : server::web::assets())
    if (asset.path == "/web/chart.min.js") {
      std::string js(asset.body);
      // Inside <script>, a "</script" in its text would end the element;
      // Debian's build has none, and "<\/" means the same in a JS string.
      for (auto at = js.find("</"); at != std::string::npos; at = js.find("</", at + 3)) js.replace(at, 2, "<\\/");
      return js;
    }
  throw std::logic_error("lbpkit was built without Chart.js (/web/chart.min.js)");
}

// A check's plot, as the page's script draws it: each series cut to
// time_s's length (a missing sample is null), or nothing to plot.
std::optional<json> plotData(const json& plot) {
  const json& time = field(plot, "time_s");
  const json& series = field(plot, "series");
  if (!time.is_array() || time.empty() || !series.is_object() || series.empty()) return std::nullopt;
  json t = json::array();
  for (const auto& v : time) t.push_back(v.is_number() ? v : json());
  json s = json::object();
  json units = json::object();
  for (const auto& [name, values] : series.items()) {
    json column = json::array();
    for (std::size_t i = 0; i < t.size(); ++i)
      column.push_back(values.is_array() && i < values.size() && values[i].is_number() ? values[i] : json());
    s[name] = std::move(column);
    units[name] = str(field(plot, "units"), name.c_str());
  }
  json events = json::array();
  for (const auto& e : field(plot, "events"))
    if (num(e, "t")) events.push_back({{"t", *num(e, "t")}, {"what", str(e, "what")}});
  return json{
      {"time_s", std::move(t)}, {"series", std::move(s)}, {"units", std::move(units)}, {"events", std::move(events)}};
}

std::string verdictClass(const json& check) {
  const std::string v = str(check, "verdict");
  return v == "pass" ? "pass" : v == "fail" ? "fail" : v == "not applicable" ? "na" : "unknown";
}

constexpr const char* kStyle = R"css(
body { font: 15px/1.45 system-ui, sans-serif; margin: 24px auto; max-width: 1400px; padding: 0 16px; color: #1b1b1b; }
h1 { font-size: 24px; margin: 0 0 8px; }
h2 { font-size: 19px; margin: 28px 0 8px; border-bottom: 1px solid #ccc; }
h3 { font-size: 16px; margin: 20px 0 4px; }
dl { display: grid; grid-template-columns: max-content auto; gap: 2px 14px; margin: 0; }
dt { font-weight: 600; }
dd { margin: 0; }
table { border-collapse: collapse; width: 100%; }
th, td { border: 1px solid #ccc; padding: 5px 8px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.cites { font-size: 13px; color: #444; }
code { font-size: 12px; color: #555; }
.verdict { font-weight: 700; white-space: nowrap; }
.pass .verdict, .verdict.pass { color: #17692b; }
.fail .verdict, .verdict.fail { color: #b00020; }
.na .verdict, .unknown .verdict { color: #666; }
tr.fail { background: #fff1f1; }
.reason { font-style: italic; }
.chart { position: relative; height: 340px; }
.events { font-size: 13px; color: #444; }
)css";

// Draws each chart from the data element: a series per line, on an axis per
// unit (a commanded value dashed), in the upper part of the chart; on/off
// signals (unit "" and only 0 or 1) stepped, each in a lane of its own
// below them, as a logic analyser shows them; the events as dashed vertical
// lines, labelled, the fault's (the first) in red. Chart.js' annotation
// plugin is not in Debian: eventLines is the small part of it this needs.
constexpr const char* kScript = R"js(
(function () {
  'use strict';
  const report = JSON.parse(document.getElementById('lbpkit-report-data').textContent);
  const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#17becf'];
  const lane = 1.5;         // a signal's lane: off at k * lane, on 1 above
  const signalShare = 0.3;  // of the chart's height, for the lanes
  const eventLines = {
    id: 'lbpkitEvents',
    afterDatasetsDraw(chart, _args, options) {
      const area = chart.chartArea, x = chart.scales.x, ctx = chart.ctx;
      ctx.save();
      ctx.font = '12px system-ui, sans-serif';
      ctx.textBaseline = 'top';
      (options.events || []).forEach((e, i) => {
        const px = x.getPixelForValue(e.t);
        if (!(px >= area.left && px <= area.right)) return;
        const colour = i === 0 ? '#b00020' : '#333';
        ctx.strokeStyle = colour;
        ctx.lineWidth = 1.5;
        ctx.setLineDash([6, 4]);
        ctx.beginPath();
        ctx.moveTo(px, area.top);
        ctx.lineTo(px, area.bottom);
        ctx.stroke();
        const label = e.what + ' (' + e.t + ' s)';
        const width = ctx.measureText(label).width;
        const top = area.top + 4 + (i % 3) * 17;
        const left = px + 5 + width > area.right ? px - 5 - width : px + 5;
        ctx.fillStyle = 'rgba(255, 255, 255, 0.85)';
        ctx.fillRect(left - 2, top - 2, width + 4, 16);
        ctx.fillStyle = colour;
        ctx.fillText(label, left, top);
      });
      ctx.restore();
    }
  };
  const charts = [];
  for (const plot of report.plots) {
    const names = Object.keys(plot.series);
    const isSignal = name => (plot.units[name] || '') === '' &&
                             plot.series[name].every(v => v === null || v === 0 || v === 1);
    const signals = names.filter(isSignal);
    const share = signals.length ? signalShare : 0;
    const scales = { x: { type: 'linear', title: { display: true, text: 'time (s)' } } };
    // An axis per unit, its data kept above the lanes, its ticks only there.
    const axisOf = {};
    for (const name of names.filter(n => !isSignal(n))) {
      const unit = plot.units[name] || '';
      if (!(unit in axisOf)) axisOf[unit] = { id: 'y' + Object.keys(axisOf).length, lo: Infinity, hi: -Infinity };
      for (const v of plot.series[name])
        if (v !== null) { axisOf[unit].lo = Math.min(axisOf[unit].lo, v); axisOf[unit].hi = Math.max(axisOf[unit].hi, v); }
    }
    for (const [unit, a] of Object.entries(axisOf)) {
      if (!(a.lo <= a.hi)) { a.lo = 0; a.hi = 1; }
      const span = a.hi - a.lo || Math.abs(a.hi) || 1;
      const low = a.lo - span * (share + 0.04) / (1 - share - 0.08);
      scales[a.id] = {
        type: 'linear', position: a.id === 'y0' ? 'left' : 'right',
        min: share ? low : undefined, max: share ? a.hi + span * 0.04 / (1 - share - 0.08) : undefined,
        title: { display: unit !== '', text: unit }, grid: { drawOnChartArea: a.id === 'y0' },
        afterBuildTicks: scale => {
          if (share) scale.ticks = scale.ticks.filter(t => t.value >= a.lo - span * 0.02 && t.value <= a.hi + span * 0.02);
        }
      };
    }
    if (signals.length) {
      const top = (signals.length - 1) * lane + 1;
      scales.onoff = {
        type: 'linear', position: 'right', min: -0.3, max: -0.3 + (top + 0.5) / share,
        grid: { drawOnChartArea: false },
        afterBuildTicks: scale => { scale.ticks = signals.map((_, k) => ({ value: k * lane + 0.5 })); },
        ticks: { callback: v => signals[Math.round((v - 0.5) / lane)].replace(/_/g, ' ') }
      };
    }
    const datasets = names.map((name, i) => {
      const unit = plot.units[name] || '';
      const colour = palette[i % palette.length];
      const k = signals.indexOf(name);
      const values = plot.series[name];
      return {
        label: name.replace(/_/g, ' ') + (unit ? ' (' + unit + ')' : ''),
        data: values.map((y, j) => ({ x: plot.time_s[j], y: y === null || k < 0 ? y : y + k * lane })),
        lane: k < 0 ? undefined : k * lane,
        yAxisID: k < 0 ? axisOf[unit].id : 'onoff', stepped: k >= 0,
        borderColor: colour, backgroundColor: colour, borderWidth: k < 0 ? 1.5 : 2,
        borderDash: k < 0 && /command/i.test(name) ? [6, 3] : [], pointRadius: 0
      };
    });
    const canvas = document.getElementById(plot.canvas);
    charts.push(new Chart(canvas, {
      type: 'line',
      data: { datasets: datasets },
      options: {
        animation: false, responsive: true, maintainAspectRatio: false, normalized: true,
        interaction: { mode: 'nearest', axis: 'x', intersect: false },
        scales: scales,
        plugins: {
          lbpkitEvents: { events: plot.events },
          legend: { position: 'bottom' },
          tooltip: { callbacks: { label: c => c.dataset.label + ': ' + (c.dataset.lane === undefined ? c.parsed.y
                                              : c.parsed.y - c.dataset.lane > 0.5 ? 'on' : 'off') } }
        }
      },
      plugins: [eventLines]
    }));
  }
  window.lbpkitReport = { charts: charts };
})();
)js";

}  // namespace

std::string checkLine(const json& check, std::string_view linearUnits) {
  std::string line = fmt::format("{:<4}  {}", verdictWord(check), str(check, "title", "?"));
  const std::string more = details(check, linearUnits);
  if (!more.empty()) line += " — " + more;
  return oneLine(line);
}

std::string reportHtml(const json& report) {
  const std::string units = str(report, "linear_units", "?");
  const std::string verdict = str(report, "verdict", "?");
  const json& checks = field(report, "checks");
  const json noChecks = json::array();
  const json& all = checks.is_array() ? checks : noChecks;

  std::size_t pass = 0, fail = 0, na = 0;
  for (const auto& c : all) {
    const std::string v = str(c, "verdict");
    pass += v == "pass";
    fail += v == "fail";
    na += v == "not applicable";
  }

  std::string rows, sections;
  json plots = json::array();
  for (std::size_t i = 0; i < all.size(); ++i) {
    const json& c = all[i];
    const std::string title = html(str(c, "title", "?"));
    const std::string figures = html(join(figureTexts(field(c, "figures"), units), ", "));
    const std::string reason = html(str(c, "reason"));
    const std::string word = html(verdictWord(c));
    auto plot = plotData(field(c, "plot"));
    const std::string anchor = fmt::format("check-{}", i);
    rows += fmt::format(
        "<tr class=\"{}\"><td class=\"verdict\">{}</td><td>{}<br><code>{}</code></td><td>{}{}</td>"
        "<td class=\"cites\">{}</td></tr>\n",
        verdictClass(c), word, plot ? fmt::format("<a href=\"#{}\">{}</a>", anchor, title) : title, html(str(c, "id")),
        figures,
        reason.empty() ? "" : fmt::format("{}<span class=\"reason\">{}</span>", figures.empty() ? "" : "<br>", reason),
        html(str(c, "cites")));
    if (!plot) continue;
    std::string events;
    for (const auto& e : (*plot)["events"])
      events += fmt::format("{}{} s: {}", events.empty() ? "" : "; ", figure(e["t"].get<double>(), 3),
                            html(e["what"].get<std::string>()));
    sections += fmt::format(
        "<section class=\"plot {}\" id=\"{}\">\n<h3><span class=\"verdict\">{}</span> {}</h3>\n<p>{}</p>\n"
        "<div class=\"chart\"><canvas id=\"plot-{}\" role=\"img\" aria-label=\"{}\"></canvas></div>\n{}</section>\n",
        verdictClass(c), anchor, word, title, html(details(c, units)), i, title,
        events.empty() ? "" : "<p class=\"events\">Events: " + events + "</p>\n");
    (*plot)["canvas"] = fmt::format("plot-{}", i);
    plots.push_back(std::move(*plot));
  }

  std::string page = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "<title>lbpkit rehearse: {} — {}</title>\n<style>{}</style>\n</head>\n<body>\n"
      "<h1>lbpkit rehearse: <span class=\"verdict {}\">{}</span></h1>\n<dl>\n"
      "<dt>Configuration</dt><dd>{}</dd>\n<dt>Machine</dt><dd>{}</dd>\n<dt>Units</dt><dd>{}, {}/s, s</dd>\n"
      "<dt>Checks</dt><dd>{} passed, {} failed, {} not applicable</dd>\n</dl>\n"
      "<h2>Summary</h2>\n<table class=\"summary\">\n<thead><tr><th>Verdict</th><th>Check</th><th>Figures</th>"
      "<th>Cites</th></tr></thead>\n<tbody>\n{}</tbody>\n</table>\n",
      html(str(report, "machine", "?")), html(verdict == "fail" ? "FAIL" : verdict), kStyle,
      verdict == "pass" ? "pass" : "fail", html(verdict == "fail" ? "FAIL" : verdict),
      html(str(report, "configuration", "?")), html(str(report, "machine", "?")), html(units), html(units), pass, fail,
      na, rows);
  if (!plots.empty()) {
    page += "<h2>Plots</h2>\n" + sections;
    page += "<script>\n" + chartJs() + "\n</script>\n";
    page +=
        "<script type=\"application/json\" id=\"lbpkit-report-data\">" + scriptJson({{"plots", plots}}) + "</script>\n";
    page += std::string("<script>") + kScript + "</script>\n";
  }
  page += "</body>\n</html>\n";
  return page;
}

}  // namespace lbpkit::app::rehearse
