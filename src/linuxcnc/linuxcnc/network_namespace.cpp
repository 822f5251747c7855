#include "linuxcnc/network_namespace.hpp"

#include <sys/stat.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <utility>

#include "lbpkit/error.hpp"

namespace lbpkit::linuxcnc {

namespace {
// Runs `command` through the shell: its exit status and what it printed.
std::pair<int, std::string> run(const std::string& command) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1 </dev/null").c_str(), "r");
  if (p == nullptr) return {-1, "cannot start a shell"};
  std::array<char, 512> buf{};
  while (std::fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) out += buf.data();
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}
}  // namespace

NetworkNamespace::NetworkNamespace(std::string name, std::vector<VethLink> links)
    : name_(std::move(name)), links_(std::move(links)) {
  const std::string in = "ip -n " + name_ + " ";
  std::vector<std::string> commands = {"ip netns add " + name_, in + "link set lo up"};
  for (const auto& l : links_) {
    const std::string inside = l.name + "h";
    commands.push_back("ip link add " + l.name + " type veth peer name " + inside);
    commands.push_back("ip link set " + inside + " netns " + name_);
    commands.push_back("ip addr add " + l.outsideAddress + " dev " + l.name);
    commands.push_back("ip link set " + l.name + " up");
    const auto slash = l.outsideAddress.find('/');
    if (l.routeTo)
      commands.push_back("ip route add " + *l.routeTo + " dev " + l.name + " src " + l.outsideAddress.substr(0, slash));
    commands.push_back(in + "addr add " + l.insideAddress + " dev " + inside);
    commands.push_back(in + "link set " + inside + " up");
  }
  for (const auto& c : commands) {
    const auto [status, out] = run(c);
    if (status != 0) {
      remove();
      throw Error("cannot set up network namespace " + name_ + ": `" + c + "` said: " + out);
    }
  }
}

NetworkNamespace::~NetworkNamespace() { remove(); }

void NetworkNamespace::remove() {
  // Deleting one end of a veth pair deletes both; the namespace's own go with it.
  for (const auto& l : links_)
    if (std::filesystem::exists("/sys/class/net/" + l.name)) run("ip link del " + l.name);
  if (std::filesystem::exists("/run/netns/" + name_)) run("ip netns del " + name_);
}

bool NetworkNamespace::gone() const {
  if (std::filesystem::exists("/run/netns/" + name_)) return false;
  for (const auto& l : links_)
    if (std::filesystem::exists("/sys/class/net/" + l.name)) return false;
  return true;
}

unsigned long NetworkNamespace::inode() const {
  struct stat st {};
  return ::stat(("/run/netns/" + name_).c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

std::string rtapiEnvironment(const std::string& fifo) {
  return "env RTAPI_UID=65534 RTAPI_FIFO_PATH=" + fifo + " ";
}

}  // namespace lbpkit::linuxcnc
