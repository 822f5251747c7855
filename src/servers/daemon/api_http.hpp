// SPDX-License-Identifier: MIT
// The control API's checks (who may use it) and routes on httplib's router
// (api_routes.cpp), for the HTTP server that answers with them
// (api_server.cpp). Only these two files see httplib.
#pragma once

#include <httplib.h>

#include "daemon/api_routes.hpp"

namespace lbpkit::server {

// Adds to `http` the checks every request passes first (Host, Origin, the
// token, for an API on `port`) and every route of ApiTarget's.
void addApiRoutes(httplib::Server& http, const ApiOptions& options, int port, const ApiTarget& target,
                  const CardThreadRunner& run);

}  // namespace lbpkit::server
