// SPDX-License-Identifier: MIT
// The web view's files: the page, its script and style, and the
// plotting library (Chart.js, from Debian's libjs-chart.js), compiled into
// lbpkit at build time (embed_assets.cmake), so `lbpkit sim` serves them
// offline, with nothing beside the binary and no CDN.
#pragma once

#include <string_view>
#include <vector>

namespace lbpkit::server::web {

struct Asset {
  std::string_view path;  // the URL path it is served at ("/", "/web/app.js")
  std::string_view type;  // its Content-Type
  std::string_view body;
};

const std::vector<Asset>& assets();

}  // namespace lbpkit::server::web
