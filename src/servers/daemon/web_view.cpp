// SPDX-License-Identifier: MIT
#include "daemon/web_view.hpp"

#include <httplib.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "web/event_stream.hpp"
#include "web/web_assets.hpp"

namespace lbpkit::server {

namespace {

// The machine's rows after row `next` (when there is a machine), at most
// WebView::kTraceRowsPerFrame of them spread evenly, the newest always among
// them; `next` moves past them.
std::string traceRows(const TraceRing* trace, std::uint64_t& next) {
  if (trace == nullptr) return "null";
  std::string out = "{\"columns\":" + nlohmann::json(trace->columns()).dump() + ",\"rows\":[";
  const std::uint64_t end = trace->pushed();
  // A first frame, or one after a long gap: only the last few rows.
  const std::uint64_t from = std::max({next, trace->oldest(), end - std::min<std::uint64_t>(end, WebView::kTraceRowsPerFrame)});
  const std::uint64_t count = end - from;
  const std::uint64_t taken = std::min<std::uint64_t>(count, WebView::kTraceRowsPerFrame);
  std::vector<double> row(trace->width());
  bool first = true;
  for (std::uint64_t i = 0; i < taken; ++i) {
    const std::uint64_t n = from + (i + 1) * count / taken - 1;
    if (!trace->read(n, row)) continue;  // overwritten meanwhile
    out += first ? "[" : ",[";
    first = false;
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (k > 0) out += ',';
      out += std::isfinite(row[k]) ? fmt::format("{:.9g}", row[k]) : std::string("null");
    }
    out += ']';
  }
  next = end;
  return out + "]}";
}

}  // namespace

WebView::WebView(const ApiTarget& target, CardThreadRunner run) {
  // One snapshot per frame, whatever the number of pages: a job on the card
  // thread like GET /api/state, made text here.
  stream_ = std::make_unique<web::EventStream>(
      web::EventStreamOptions{},
      [t = target, run = std::move(run), next = std::uint64_t{0}](const web::EventStreamCounters& c) mutable {
        std::string state = run([t] { return t.state(); });
        return fmt::format(R"({{"stream":{{"clients":{},"frames":{},"skipped":{},"dropped":{}}},"state":{},"trace":{}}})",
                           c.clients, c.frames, c.skipped, c.dropped, state, traceRows(t.trace, next));
      });
}

WebView::~WebView() = default;

void WebView::adopt(int fd) { stream_->adopt(fd); }

void WebView::addRoutes(httplib::Server& http, std::function<void()> takeOver) {
  for (const auto& a : web::assets()) {
    std::string type(a.type);
    if (type.rfind("text/", 0) == 0) type += "; charset=utf-8";
    http.Get(std::string(a.path), [body = a.body, type](const httplib::Request&, httplib::Response& res) {
      // The files change with lbpkit: a page never runs an old script.
      res.set_header("Cache-Control", "no-cache");
      res.set_header("X-Content-Type-Options", "nosniff");
      res.set_content(body.data(), body.size(), type);
    });
  }
  http.Get("/api/events", [takeOver = std::move(takeOver)](const httplib::Request&, httplib::Response& res) {
    // The stream writes its own answer on the socket the API hands over.
    takeOver();
    res.status = 200;
  });
}

}  // namespace lbpkit::server
