// SPDX-License-Identifier: MIT
// The web view on the control API: the page at / and its files
// (web/web_assets.hpp), and GET /api/events, the event stream that pushes the
// page a frame 25 times a second (web/event_stream.hpp).
//
// A frame is {"stream": what the stream has done, "state": GET /api/state,
// "trace": {"columns": [...], "rows": [...]}}: the state is the snapshot
// GET /api/state answers (taken on the card thread, made text on the
// stream's thread), the trace the machine's servo-cycle rows since the frame
// before (at most kTraceRowsPerFrame of them, evenly spread), read from the
// trace ring without the card thread. Everything the page does is an
// ordinary POST of the control API.
#pragma once

#include <functional>
#include <memory>

#include "daemon/api_routes.hpp"

namespace httplib {
class Server;
}
namespace lbpkit::server::web {
class EventStream;
}

namespace lbpkit::server {

class WebView {
 public:
  static constexpr std::size_t kTraceRowsPerFrame = 8;

  WebView(const ApiTarget& target, CardThreadRunner run);
  ~WebView();
  WebView(const WebView&) = delete;
  WebView& operator=(const WebView&) = delete;

  // GET / and /web/... (the files), and GET /api/events, whose handler calls
  // `takeOver`: the API then hands the connection's socket to adopt()
  // instead of answering on it (api_routes.cpp).
  void addRoutes(httplib::Server& http, std::function<void()> takeOver);
  // Takes over a socket whose request for the event stream passed the API's
  // checks (Host, Origin, token).
  void adopt(int fd);

 private:
  std::unique_ptr<web::EventStream> stream_;
};

}  // namespace lbpkit::server
