// SPDX-License-Identifier: MIT
#include "support/sim_child.hpp"

#include <httplib.h>

#include <cstdlib>
#include <fstream>

namespace test_support {

SimChild::SimChild(SimOptions options) : options_(std::move(options)) {
  state_ = options_.state.empty() ? folder_ / "sim.eeprom" : options_.state;
  const std::string bind =
      options_.port < 0 ? options_.address : options_.address + ":" + std::to_string(options_.port);
  apiAddress_ = options_.apiAddress.empty() ? options_.address : options_.apiAddress;
  std::vector<std::string> args = {"sim", "--bind", bind, "--api", apiAddress_ + ":0", "--state", state_};
  if (options_.noRealtime) args.emplace_back("--no-realtime");
  args.insert(args.end(), options_.extra.begin(), options_.extra.end());
  // Up when it greets on descriptor 3 (lbpkit sim --ready-fd: docs/sim.md),
  // its card, control API and web view serving.
  args.insert(args.end(), {"--ready-fd", "3"});
  daemon_ = std::make_unique<Daemon>(args, true);
  const auto greeting = nlohmann::json::parse(daemon_->readyLine(), nullptr, false);
  if (!greeting.is_object() || !greeting.contains("cards") || greeting["cards"].empty()) return;
  const auto& card = greeting["cards"][0];
  udpPort_ = card["lbp16"]["port"].get<int>();
  if (card["api"].is_object()) apiPort_ = card["api"]["port"].get<int>();
}

SimChild::~SimChild() { daemon_.reset(); }  // stopped before its folder goes

std::string SimChild::url(const std::string& path) const {
  return "http://" + apiAddress_ + ":" + std::to_string(apiPort_) + path;
}

long SimChild::residentKb() const {
  std::ifstream f("/proc/" + std::to_string(pid()) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  return -1;
}

nlohmann::json httpGetJson(const std::string& host, int port, const std::string& path, std::chrono::seconds limit) {
  httplib::Client c(host, port);
  c.set_read_timeout(limit);
  const auto r = c.Get(path);
  if (!r || r->status != 200) return nlohmann::json();
  return nlohmann::json::parse(r->body, nullptr, false);
}

nlohmann::json SimChild::get(const std::string& path, std::chrono::seconds limit) const {
  return httpGetJson(apiAddress_, apiPort_, path, limit);
}

HttpReply SimChild::post(const std::string& path, const nlohmann::json& body, std::chrono::seconds limit) const {
  httplib::Client c(apiAddress_, apiPort_);
  c.set_read_timeout(limit);
  const auto r = c.Post(path, body.dump(), "application/json");
  if (!r) return {};
  return {r->status, nlohmann::json::parse(r->body, nullptr, false)};
}

int SimChild::stop(int sig) {
  if (!daemon_) return -1;
  const int rc = daemon_->stop(sig);
  daemon_.reset();
  return rc;
}

int SimChild::stopWithin(std::chrono::milliseconds limit, int sig) {
  if (!daemon_) return -1;
  const int rc = daemon_->stopWithin(limit, sig);
  if (rc != -2) daemon_.reset();
  return rc;
}

}  // namespace test_support
