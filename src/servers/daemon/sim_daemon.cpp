// SPDX-License-Identifier: MIT
#include "daemon/sim_daemon.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "daemon/api_routes.hpp"
#include "daemon/host_watch.hpp"
#include "daemon/state_json.hpp"
#include "lbp16/udp_server.hpp"
#include "process/process.hpp"

namespace lbpkit::server {

SimDaemon::SimDaemon(SimOptions options)
    : options_(std::move(options)),
      card_(options_.card),
      clock_(options_.hostClock ? SimClock(*options_.hostClock, options_.paused)
                                : SimClock(options_.speed, options_.paused)) {
  // First: a script that cannot run stops the sim before it binds anything.
  if (!options_.faultScript.empty())
    script_ = std::make_unique<FaultScript>(std::move(options_.faultScript), options_.card, options_.machine);
  for (const unsigned ch : options_.externalRemotes) {
    for (const auto& p : ptyChannels_)
      if (p->channel() == ch) throw std::invalid_argument(fmt::format("--remote: channel {} given twice", ch));
    try {
      ptyChannels_.push_back(std::make_unique<PtyChannel>(card_, ch));
    } catch (const std::invalid_argument& e) {  // a 7I77's channel, or none
      throw std::invalid_argument(fmt::format("--remote {}=pty: {}", ch, e.what()));
    }
  }
  if (options_.machine) {
    if (options_.demo) throw std::invalid_argument("a machine and the demo world both want the 7I77's terminals");
    machine_ = std::make_unique<model::machine::Machine>(*options_.machine, card_, card_.now(), 0);
    trace_ = std::make_unique<TraceRing>(machine_->traceColumns(), std::max<std::size_t>(options_.traceRows, 1));
    traceRow_.assign(trace_->width(), 0.0);
    analogExchanges_ = card_.daughtercard(0).analog.processDataCount();
  } else if (!options_.recordFile.empty()) {
    throw std::invalid_argument("a trace needs a machine to record");
  }
  udp_ = std::make_unique<UdpServer>(options_.bindAddress, options_.port);
  if (options_.hostClock) hostWatch_ = std::make_unique<HostWatch>();
  jobsReady_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (jobsReady_ < 0) throw std::runtime_error("cannot create an eventfd for the card thread's jobs");
  udp_->alsoWakeOn(jobsReady_);
  Lbp16Card::Identity id;
  id.name = std::string(card_.description().name);  // the card's LBP16 board name (hm2_eth, mesaflash)
  std::array<std::uint8_t, 6> mac{};
  // hm2_eth pins an ARP entry to the MAC the card reports: it must be the
  // MAC of the interface we answer on.
  if (interfaceMac(options_.bindAddress, mac, interface_)) {
    id.mac = mac;
    macFromInterface_ = true;
  }
  unsigned a[4] = {127, 0, 0, 1};
  std::sscanf(options_.bindAddress.c_str(), "%u.%u.%u.%u", &a[0], &a[1], &a[2], &a[3]);
  for (int i = 0; i < 4; ++i) id.ip[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(a[i]);
  id.flashFile = options_.flashFile;
  lbp16_ = std::make_unique<Lbp16Card>(card_, id);
  // A driver developer needs to see "hm2_eth wrote 0x5A04 to 0x1234, which
  // nothing decodes": at debug level every such access is logged as it
  // happens (the card counts them by kind at every level, /api/state).
  if (options_.logLevel >= LogLevel::Debug)
    card_.setAccessObserver(
        [](void* self, const model::hm2::AccessEvent& e) {
          static_cast<const SimDaemon*>(self)->log(
              LogLevel::Debug, fmt::format("{}: address 0x{:04X}, value 0x{:08X}, at {:.6f} s simulated",
                                           model::hm2::accessKindName(e.kind), e.address, e.value,
                                           std::chrono::duration<double>(e.at).count()));
        },
        this);

  target_ = std::make_unique<ApiTarget>(ApiTarget{card_, clock_, [this] { return stateAnswer(); }, machine_.get(),
                                                  [this] { return machineAnswer(); }, trace_.get(), udp_.get()});
  scriptLog_ = [this](const std::string& text) { log(LogLevel::Info, text); };
  if (options_.apiPort >= 0) {
    ApiOptions api;
    api.address = options_.apiAddress;
    api.port = options_.apiPort;
    api.token = options_.apiToken;
    api_ = std::make_unique<ControlApi>(api, *target_,
                                        [this](std::function<Answer()> job) { return runJob(std::move(job)); });
    apiPort_ = api_->port();
  }
  // Last, so a sim that cannot start leaves no file behind it. Never over
  // one of the sim's own files: its EEPROMs and its flash.
  std::vector<std::filesystem::path> own{options_.flashFile};
  for (const auto* d : {&options_.card.first, options_.card.second ? &*options_.card.second : nullptr})
    if (d != nullptr) own.insert(own.end(), {d->fieldIo.nvFile, d->analog.nvFile});
  if (!options_.recordFile.empty())
    traceFile_ = std::make_unique<TraceFile>(
        *trace_, options_.recordFile, [this](const std::string& text) { log(LogLevel::Warn, text); }, own);
  if (!options_.packetTraceFile.empty()) {
    cardEndpoint_ = {static_cast<std::uint32_t>(a[0] << 24 | a[1] << 16 | a[2] << 8 | a[3]), udp_->port()};
    packetTrace_ = std::make_unique<PcapRecorder>(
        options_.packetTraceFile, PcapRecorder::Link::Ipv4Udp,
        [this](const std::string& text) { log(LogLevel::Warn, text); }, 4096, own);
  }
}

SimDaemon::~SimDaemon() {
  // No card thread runs jobs any more (run() has returned, or never ran):
  // jobs still queued are dropped, so requests waiting on them fail at once
  // (a broken promise) instead of after their timeout.
  {
    std::lock_guard<std::mutex> lock(jobsMutex_);
    jobsClosed_ = true;
    jobs_.clear();
  }
  // Stop the API first: its threads may be waiting on jobs for this daemon.
  api_.reset();
  if (jobsReady_ >= 0) ::close(jobsReady_);
  if (cpuLatencyFd_ >= 0) ::close(cpuLatencyFd_);  // the PM QoS request ends with it
}

bool SimDaemon::ticks() const {
  return machine_ || options_.demo || !ptyChannels_.empty() || (script_ && script_->pending());
}

std::chrono::milliseconds SimDaemon::idleWait() const {
  // The demo world, a fault script and a pseudo-terminal act on the card
  // every millisecond; a machine alone only moves (exactly over any span,
  // machine/machine.hpp), and is caught up whenever anything looks, so it
  // needs a tick only to keep each catch-up short.
  if (options_.demo || !ptyChannels_.empty() || (script_ && script_->pending())) return std::chrono::milliseconds(1);
  if (clock_.drivenByHost()) return SimClock::kHeldBackCheck;
  // kMachineTick of simulated time between looks: faster than the wall
  // clock, as often as the speed asks (a catch-up stays short).
  if (machine_) return clock_.wallFor(kMachineTick);
  return std::chrono::hours(1);
}

std::uint16_t SimDaemon::port() const { return udp_->port(); }

std::string SimDaemon::packetTraceSummary() const {
  if (!packetTrace_) return {};
  const std::uint64_t lost = packetTrace_->dropped();
  return fmt::format("the datagrams in and out are in {}{}", packetTrace_->path(),
                     lost ? fmt::format(" ({} lost: the writer fell behind)", lost) : std::string());
}

model::lbp::SimTime SimDaemon::catchUp(std::chrono::microseconds budget) { return catchUpTo(clock_.now(), budget); }

model::lbp::SimTime SimDaemon::catchUpTo(model::lbp::SimTime target, std::chrono::microseconds budget) {
  // The machine first: each plant span sets its encoders' velocities to
  // reach the shaft at the span's end, so the counters then follow the
  // plant over the card's advance (machine/machine.hpp). It is a slice
  // ahead of the card at most. Its slices stay short even while it rests
  // (Machine::resting, which makes each one cheap): a watchdog's bite in
  // the card can start it moving (a drive enabled active-low), and it
  // starts within a slice of it.
  return clock_.catchUpTo(
      card_.now(), target,
      [this](model::lbp::SimTime t) {
        if (machine_) machine_->advance(t);
        card_.advance(t);
      },
      budget, machine_ ? SimClock::kSlice : SimClock::kCardSlice);
}

void SimDaemon::traceDatagram(std::span<const std::uint8_t> request, std::span<const std::uint8_t> reply) {
  // Copies into the recorder's ring only: no allocation, no file I/O here.
  const sockaddr_in& p = udp_->peer();
  const PcapRecorder::Endpoint host{ntohl(p.sin_addr.s_addr), ntohs(p.sin_port)};
  packetTrace_->udp(udp_->receivedNs(), host, cardEndpoint_, request);
  if (!reply.empty()) packetTrace_->udp(PcapRecorder::nowNs(), cardEndpoint_, host, reply);
}

void SimDaemon::record() {
  // The host's servo thread exchanges the analog processor's process data
  // once a period (hm2_eth: one DOIT per read/write cycle); a count that
  // moved is a cycle. Polled after each datagram and catch-up: no callback
  // into the models, no allocation.
  const std::uint32_t n = card_.daughtercard(0).analog.processDataCount();
  if (n == analogExchanges_) return;
  analogExchanges_ = n;
  // Two exchanges with no simulated time between them (a host's start-up
  // chatter) would give two rows of the same instant: the first stands for both.
  if (traced_ && machine_->time() == lastTraced_) return;
  traced_ = true;
  lastTraced_ = machine_->time();
  machine_->traceRow(traceRow_);
  trace_->push(traceRow_);
}

SimState SimDaemon::state() {
  // A step by hand (paused) is shown whole when it can be had in 200 ms:
  // stepping is what the user asked for, and paused time keeps no host's
  // watchdog waiting. Beyond that it goes on between datagrams.
  const auto now = catchUp(clock_.paused() ? std::chrono::microseconds(200'000) : SimClock::kBudget);
  SimState s;
  s.time = now;
  s.clock = {clock_.speed(),
             clock_.paused(),
             clock_.behind(),
             clock_.slips(),
             clock_.source() == SimClock::Source::Host,
             clock_.period(),
             clock_.drivenByHost(),
             clock_.hostCycles(),
             clock_.silences(),
             clock_.heldBackFor(),
             clock_.heldBackTimes(),
             clock_.cyclesLeft(),
             clock_.runningHolds(),
             hostWatch_ ? hostWatch_->pid() : 0};
  const auto& id = lbp16_->identity();
  s.card = {id.name, options_.bindAddress, udp_->port(), id.mac, lbp16_->eeprom()};
  s.lbp16 = lbp16_->counters();
  s.server = {latency_.count,
              schedule_,
              latency_.percentileUs(0.5),
              latency_.percentileUs(0.99),
              static_cast<double>(latency_.maxNs) / 1000.0,
              queueing_.percentileUs(0.5),
              queueing_.percentileUs(0.99),
              static_cast<double>(queueing_.maxNs) / 1000.0,
              latency_.percentileUs(0.999),
              queueing_.percentileUs(0.999),
              {}};
  for (std::size_t i = 0; i < s.server.atLeast.size(); ++i)
    s.server.atLeast[i] = latency_.countAtLeastUs(SimState::Server::kAtLeastUs[i]);
  s.watchdog = card_.part<model::hm2::Watchdog>().state(now);
  s.cardLeds = card_.part<model::hm2::Led>().state();
  s.sserial = card_.part<model::hm2::Sslbp>().state();
  s.accessCounters = card_.accessCounters();
  const auto encoders = card_.part<model::hm2::MuxedEncoder>().state();
  for (unsigned d = 0; d < card_.daughtercards(); ++d) {
    auto& b = card_.daughtercard(d);
    SimState::Daughtercard board{b.fieldIo.state(), b.analog.state(), {}};
    for (unsigned n = 0; n < SimState::kEncodersPerDaughtercard; ++n)
      board.encoders[n] = encoders.counter.at(SimState::kEncodersPerDaughtercard * d + n);
    s.daughtercards.push_back(board);
  }
  if (auto* i76 = card_.sevenI76()) {
    // PIN_7I77_7I76_34.vhd: the 7I76 on IO17..33, the card's second connector.
    constexpr unsigned kConnector = SimState::SevenI76::kConnector;
    s.sevenI76 = SimState::SevenI76{kConnector, std::string(card_.description().connectors.at(kConnector)),
                                    model::hm2::cards::sevenI76Channel(card_.firmware()).value_or(0), i76->state()};
  }
  if (machine_) s.machine = machine_->state();
  return s;
}

Answer SimDaemon::machineAnswer() {
  catchUp(clock_.paused() ? std::chrono::microseconds(200'000) : SimClock::kBudget);
  return [s = machine_->state()] { return server::toJson(s).dump(); };
}

Answer SimDaemon::stateAnswer() {
  return [s = state()] { return server::stateJson(s); };
}

std::vector<std::pair<unsigned, std::string>> SimDaemon::externalRemotes() const {
  std::vector<std::pair<unsigned, std::string>> out;
  for (const auto& p : ptyChannels_) out.emplace_back(p->channel(), p->path());
  return out;
}

std::string SimDaemon::banner() const {
  const auto& id = lbp16_->identity();
  std::string s = fmt::format("lbpkit sim: virtual {} (HostMot2, SSLBP {}.{}) on UDP {}:{}\n", id.name,
                              model::hm2::Sslbp::kMajorRevision, model::hm2::Sslbp::kMinorRevision,
                              options_.bindAddress, udp_->port());
  s += fmt::format("  MAC {:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}{}\n", id.mac[0], id.mac[1], id.mac[2], id.mac[3],
                   id.mac[4], id.mac[5],
                   macFromInterface_ ? fmt::format(" (of {})", interface_) : std::string(" (locally administered)"));
  for (unsigned d = 0; d < card_.daughtercards(); ++d) {
    auto& b = const_cast<model::hm2::HostMot2Card&>(card_).daughtercard(d);
    s += fmt::format(
        "  connector {}: {} field I/O unit 0x{:08X} on channel {}, analog unit 0x{:08X} on channel {}, "
        "6 encoders, field {:.1f} V{}\n",
        d, b.fieldIo.outputType() == model::remote::OutputType::Sinking ? "7I77D" : "7I77", b.fieldIo.unitNumber(),
        3 * d, b.analog.unitNumber(), 3 * d + 1, b.fieldIo.fieldVoltage(),
        b.fieldIo.nvStore().file().empty() ? "" : ", EEPROM " + b.fieldIo.nvStore().file().string());
  }
  if (auto* i76 = const_cast<model::hm2::HostMot2Card&>(card_).sevenI76())
    s += fmt::format(
        "  connector {}: 7I76 field I/O unit 0x{:08X} on channel {} (32 inputs, 16 outputs, spindle), "
        "field {:.1f} V\n",
        SimState::SevenI76::kConnector, i76->unitNumber(),
        model::hm2::cards::sevenI76Channel(card_.firmware()).value_or(0), i76->fieldVoltage());
  for (const auto& p : ptyChannels_)
    s += fmt::format("  channel {}: external remote on {} (LBP at {} baud; reply timeouts x{})\n", p->channel(),
                     p->path(), p->baud(), model::hm2::Sslbp::kExternalTimeoutFactor);
  s += fmt::format("  configuration: {}\n", options_.configDescription);
  if (script_) s += fmt::format("  fault script: {} entries, from {}\n", script_->size(), options_.configDescription);
  if (machine_) {
    const auto& d = machine_->description();
    std::string axes;
    for (const auto& a : d.axes) axes += (axes.empty() ? "" : ", ") + a.name;
    s += fmt::format("  machine: {} ({}) on connector 0: axes {}{}, {} switches, {} outputs\n", d.name,
                     options_.machineSource.empty() ? "given" : options_.machineSource, axes,
                     d.spindle ? ", spindle" : "", d.switches.size(), d.outputs.size());
    if (apiPort_ >= 0)
      s += fmt::format("  machine API: http://{}:{}/api/machine (trace: /api/machine/trace)\n", options_.apiAddress,
                       apiPort_);
    if (traceFile_) s += fmt::format("  recording: every servo cycle to {}\n", traceFile_->path());
  }
  if (packetTrace_)
    s += fmt::format("  packet trace: every datagram in and reply out to {} (pcap; lbpkit decode reads it)\n",
                     packetTrace_->path());
  if (apiPort_ >= 0)
    s += fmt::format("  control API: http://{}:{}/api/state{}\n", options_.apiAddress, apiPort_,
                     options_.apiToken.empty() ? "" : " (with its token: Authorization: Bearer TOKEN)");
  if (apiPort_ >= 0)  // the board and the machine, live
    s += fmt::format("  web view: http://{}:{}/{}\n", options_.apiAddress, apiPort_,
                     options_.apiToken.empty() ? "" : "?token=TOKEN");
  if (clock_.source() == SimClock::Source::Host)
    s += fmt::format("  time: {}one servo period ({}) per host cycle (each DOIT taken); the wall clock while the "
                     "host is silent over {} ms\n",
                     options_.paused ? "paused; then " : "",
                     clock_.period().count() > 0
                         ? fmt::format("{:g} ms", std::chrono::duration<double, std::milli>(clock_.period()).count())
                         : fmt::format("learned from the host's first {} cycles", SimClock::kLearnCycles),
                     clock_.silence().count());
  else
    s += fmt::format("  time: {}{}\n", options_.paused ? "paused" : "follows the wall clock",
                     options_.speed != 1.0 ? fmt::format(" x{}", options_.speed) : "");
  return s;
}

std::string SimDaemon::runJob(std::function<Answer()> job) {
  // What the job throws does not cross threads as an exception object (the
  // card thread may free the task's state while the API thread still reads
  // the exception's text): its kind and text do, and the API thread throws
  // its own copy.
  std::packaged_task<Answer()> task([job = std::move(job)]() -> Answer {
    try {
      return job();
    } catch (const std::invalid_argument& e) {
      return [why = std::string(e.what())]() -> std::string { throw std::invalid_argument(why); };
    } catch (const std::exception& e) {
      return [why = std::string(e.what())]() -> std::string { throw std::runtime_error(why); };
    }
  });
  auto result = task.get_future();
  {
    std::lock_guard<std::mutex> lock(jobsMutex_);
    if (jobsClosed_) throw std::runtime_error("the sim is stopping");
    jobs_.push_back(std::move(task));
    // Set under the lock, so it is set exactly while jobs wait.
    const std::uint64_t one = 1;
    (void)!::write(jobsReady_, &one, sizeof one);
  }
  if (result.wait_for(std::chrono::seconds(5)) != std::future_status::ready)
    throw std::runtime_error("the card thread is busy: the request is queued and will still be applied");
  // The snapshot becomes text here, on the API's thread.
  return result.get()();
}

void SimDaemon::drainJobs() {
  // Never wait for the API threads: if they hold the lock, try next time.
  // The jobs run with the lock released, so API threads never wait on them.
  // `ready_` is a member: a deque allocates even when empty, and this runs
  // after every datagram (a local one cost two allocations per loop).
  {
    std::unique_lock<std::mutex> lock(jobsMutex_, std::try_to_lock);
    if (!lock.owns_lock() || jobs_.empty()) return;
    // Cleared with the queue, under the lock: set exactly while jobs wait.
    std::uint64_t count = 0;
    (void)!::read(jobsReady_, &count, sizeof count);
    ready_.swap(jobs_);
  }
  for (auto& task : ready_) task();
  ready_.clear();
}

void SimDaemon::log(LogLevel level, const std::string& text) const {
  if (level > options_.logLevel) return;
  static constexpr const char* kNames[] = {"error", "warning", "info", "debug"};
  std::fprintf(stderr, "lbpkit sim: %s: %s\n", kNames[static_cast<int>(level)], text.c_str());
}

void SimDaemon::Latency::add(std::chrono::nanoseconds d) {
  const auto us = static_cast<std::size_t>(std::max<std::int64_t>(d.count(), 0) / 1000);
  const std::size_t i = us < kFine ? us : kFine + (us - kFine) / kCoarseUs;
  ++buckets[std::min(i, buckets.size() - 1)];
  ++count;
  maxNs = std::max<std::uint64_t>(maxNs, static_cast<std::uint64_t>(d.count()));
}

double SimDaemon::Latency::percentileUs(double p) const {
  if (count == 0) return 0;
  const auto want = static_cast<std::uint64_t>(p * static_cast<double>(count - 1)) + 1;
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < buckets.size(); ++i) {
    seen += buckets[i];
    if (seen >= want)
      return i < kFine ? static_cast<double>(i) + 0.5
                       : static_cast<double>(kFine + (i - kFine) * kCoarseUs) + static_cast<double>(kCoarseUs) / 2;
  }
  return static_cast<double>(kFine + kCoarse * kCoarseUs);
}

std::uint64_t SimDaemon::Latency::countAtLeastUs(unsigned us) const {
  // Exact below 1 ms (1 us buckets); above, to the 100 us bucket holding `us`.
  const std::size_t from = us < kFine ? us : kFine + (us - kFine) / kCoarseUs;
  std::uint64_t n = 0;
  for (std::size_t i = std::min(from, buckets.size()); i < buckets.size(); ++i) n += buckets[i];
  return n;
}

std::string SimDaemon::latencySummary() const {
  return fmt::format("median {:.1f} us, 99th percentile {:.1f} us, max {:.1f} us over {} datagrams",
                     latency_.percentileUs(0.5), latency_.percentileUs(0.99), static_cast<double>(latency_.maxNs) / 1000.0,
                     latency_.count);
}

namespace {

// Without the privilege for SCHED_FIFO, the next best for a card that must
// answer within 80 % of the host's period (hm2_eth's packet-read-timeout):
// a short time slice for this thread under the kernel's fair scheduler
// (EEVDF, Linux 6.6 and later, where sched_attr.sched_runtime of a
// SCHED_OTHER thread is its requested slice; 6.12 lets a woken task with a
// shorter slice preempt). Needs no privilege. On an older kernel the call
// fails or is ignored, and the thread keeps the default slice. Measured here without
// CAP_SYS_NICE beside LinuxCNC on 2 cores (docs/sim.md: Scheduling): the slice
// turns a datagram queued for up to 2.8 ms into one taken at once.
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t policy;
  std::uint64_t flags;
  std::int32_t nice;
  std::uint32_t priority;
  std::uint64_t runtime;
  std::uint64_t deadline;
  std::uint64_t period;
};

bool requestShortSlice() {
#ifdef SYS_sched_setattr
  SchedAttr a{};
  a.size = sizeof a;
  a.policy = SCHED_OTHER;
  a.runtime = 100'000;  // ns: the kernel's smallest slice
  if (::syscall(SYS_sched_setattr, 0, &a, 0U) != 0) return false;
  // An older kernel takes the call and ignores the slice: ask what it kept.
  SchedAttr kept{};
  return ::syscall(SYS_sched_getattr, 0, &kept, static_cast<unsigned>(sizeof kept), 0U) == 0 &&
         kept.runtime == a.runtime;
#else
  return false;
#endif
}

}  // namespace

std::string SimDaemon::takeCardThread() {
  std::string schedule = "normal scheduling";
  if (options_.realtime) {
    sched_param p{};
    p.sched_priority = 40;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0) {
      schedule = "SCHED_FIFO priority 40";
    } else if (requestShortSlice()) {
      schedule = "normal scheduling, 100 us slice";
      log(LogLevel::Info,
          "real-time scheduling not permitted: running at normal priority with a 100 us time slice "
          "(SCHED_FIFO needs CAP_SYS_NICE)");
    } else {
      log(LogLevel::Info, "real-time scheduling not permitted: running at normal priority");
    }
  }
  if (options_.cpu) {
    if (!lbpkit::process::pinToCpu(*options_.cpu))  // this thread alone
      log(LogLevel::Warn, fmt::format("the card thread cannot run on CPU {} alone: it runs on any", *options_.cpu));
    else
      schedule += fmt::format(", on CPU {}", *options_.cpu);
  }
  if (options_.cpuLatency && cpuLatencyFd_ < 0) {
    // The kernel's PM QoS CPU latency request: a 32-bit value in us, held
    // while the file stays open (Documentation/power/pm_qos_interface.rst).
    const auto us = static_cast<std::int32_t>(options_.cpuLatency->count());
    const int fd = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    if (fd >= 0 && ::write(fd, &us, sizeof us) == static_cast<ssize_t>(sizeof us)) {
      cpuLatencyFd_ = fd;
      schedule += fmt::format(", CPU wake-up latency held at {} us", us);
    } else {
      const std::string why = std::strerror(errno);
      if (fd >= 0) ::close(fd);
      log(LogLevel::Warn, fmt::format("cannot hold the CPUs' wake-up latency at {} us (/dev/cpu_dma_latency: {}; "
                                      "it needs root)", us, why));
    }
  }
  return schedule;
}

void SimDaemon::serve(std::chrono::milliseconds wait) {
  // The card answers at the simulated time the datagram arrived (its
  // kernel receive timestamp), caught up to it with bounded work. Normally
  // that is microseconds ago; when this thread was held up (descheduled,
  // a long API job) and datagrams queued, each is still taken at its own
  // time, so a host that kept its period is not seen falling silent by the
  // 7I77's 50 ms watchdog, which a stall here must not bite.
  //
  // On the host clock, a datagram that carried a DOIT ends the host's
  // servo cycle (hostmot2 and lbpkit's host library write one a cycle,
  // after the cycle's outputs): time moves one period on, so the host's
  // next cycle finds the DOIT done and the plant moved under its outputs.
  // One that carried any other command takes the host out of its cycle
  // (SimClock::hostLeftItsCycle): the wall clock again.
  const auto until = NetworkFaults::Clock::now() + wait;
  const bool served = udp_->serveOnce(wait, [&](std::span<const std::uint8_t> req, std::span<std::uint8_t> reply) {
    watchHost();
    const auto before = card_.part<model::hm2::Sslbp>().counters();
    const std::size_t n = lbp16_->handle(req, reply, catchUpTo(clock_.ago(udp_->sinceReceived()), budget()));
    const auto& after = card_.part<model::hm2::Sslbp>().counters();
    if (after.doits != before.doits) {
      clock_.hostCycle(udp_->sinceReceived());
      if (hostWatch_) hostWatch_->cycled(udp_->peer());
    } else if (after.commands != before.commands)
      clock_.hostLeftItsCycle();
    if (packetTrace_) traceDatagram(req, reply.first(n));
    return n;
  });
  // From the kernel's receive timestamp, so time queued in the socket
  // counts: that is what the host waits.
  if (served) {
    latency_.add(udp_->sinceReceived());
    queueing_.add(udp_->lastQueueing());
  }
  // How late this thread ran: a datagram's time in its socket, or how long
  // after its timer it woke. On the host clock that is no silence of the
  // host (SimClock::heldBack). Its own work is not counted: a datagram the
  // host sends meanwhile has its kernel time, and a stopped host's silence
  // must not wait for the API's requests.
  watchHost();
  clock_.heldBack(served ? udp_->lastQueueing()
                         : std::max(std::chrono::nanoseconds{0}, NetworkFaults::Clock::now() - until));
  // A reply the network would not take: the card's TX error (space 6).
  for (; sendFailuresSeen_ < udp_->sendFailures(); ++sendFailuresSeen_) lbp16_->noteSendFailed();
  // A datagram that queued for long says more may be waiting: they come
  // first, each at its own time, before the card runs on to the clock.
  constexpr std::chrono::milliseconds kBacklog{1};
  if (!served || udp_->lastQueueing() < kBacklog) catchUp(budget());
  if (machine_) record();
  if (script_) script_->runDue(card_.now(), *target_, scriptLog_);
  if (options_.demo) {
    auto& io = card_.daughtercard(0).fieldIo;
    for (unsigned i = 0; i < model::remote::FieldIoProcessor::kOutputs; ++i) {
      const double v = io.outputOn(i) ? io.fieldVoltage() : 0.0;
      if (io.inputVoltage(i) != v) io.setInputVoltage(i, v);
    }
  }
  drainJobs();
  for (auto& p : ptyChannels_) p->pump(card_, card_.now());
  // Bad datagrams: logged, at most once a second, with how many.
  const auto& c = lbp16_->counters();
  const std::uint64_t errors = c.parseErrors + c.memoryErrors + c.writeErrors;
  if (errors != errorsSeen_ && options_.logLevel >= LogLevel::Warn) {
    const auto wall = std::chrono::steady_clock::now();
    if (wall - lastBadLog_ > std::chrono::seconds(1)) {
      log(LogLevel::Warn, fmt::format("{} bad LBP16 requests so far ({} malformed, {} bad addresses, {} refused writes)",
                                      errors, c.parseErrors, c.memoryErrors, c.writeErrors));
      lastBadLog_ = wall;
      errorsSeen_ = errors;
    }
  }
  // Simulated time falling behind: logged, at most once a second.
  if (clock_.slips() != slipsLogged_ && options_.logLevel >= LogLevel::Warn) {
    const auto wall = std::chrono::steady_clock::now();
    if (wall - lastSlipLog_ > std::chrono::seconds(1)) {
      log(LogLevel::Warn,
          fmt::format("the card cannot keep up at speed {:g}: simulated time has fallen {:.0f} ms behind the wall "
                      "clock so far ({} slips)",
                      clock_.speed(), std::chrono::duration<double, std::milli>(clock_.behind()).count(),
                      clock_.slips()));
      lastSlipLog_ = wall;
      slipsLogged_ = clock_.slips();
    }
  }
}

void SimDaemon::watchHost() {
  if (!hostWatch_) return;
  // A request the network lost: the card heard nothing of the host then,
  // however its process ran.
  const auto& r = udp_->faults().counters().request;
  const std::uint64_t lost = r.dropped + r.silenced + r.corrupted + r.overflowed;
  if (lost != requestsLostSeen_) {
    requestsLostSeen_ = lost;
    clock_.hostUnheard();
  }
  const auto seen = hostWatch_->runningAt();
  if (seen != hostSeenTaken_) {
    hostSeenTaken_ = seen;
    clock_.hostRunning(SimClock::Wall::time_point{seen});
  }
}

void SimDaemon::run(const std::atomic<bool>& stop, int stopFd) {
  SimDaemon* self = this;
  runAll(std::span<SimDaemon* const>(&self, 1), stop, stopFd);
}

void SimDaemon::runAll(std::span<SimDaemon* const> cards, const std::atomic<bool>& stop, int stopFd) {
  if (cards.empty()) return;
  const std::string schedule = cards.front()->takeCardThread();
  for (SimDaemon* d : cards) {
    d->schedule_ = schedule;
    if (d->options_.demo) d->card_.part<model::hm2::MuxedEncoder>().setVelocity(0, 10000, d->card_.now());
  }
  // Between datagrams the thread sleeps until the next one, a job or the
  // stop, or for idleWait(): a card alone is caught up exactly when next
  // looked at.
  if (cards.size() == 1) {
    SimDaemon& d = *cards.front();
    if (stopFd >= 0) d.udp_->alsoWakeOn(stopFd);
    while (!stop.load()) d.serve(d.idleWait());
  } else {
    // Several cards, one thread: one wait for all their sockets and job
    // queues, then each card with something to do is served. Datagrams
    // that came together cost one wake-up, not one each.
    std::vector<pollfd> fds;
    for (SimDaemon* d : cards) {
      fds.push_back({d->udp_->fd(), POLLIN, 0});
      fds.push_back({d->jobsReady_, POLLIN, 0});
    }
    if (stopFd >= 0) fds.push_back({stopFd, POLLIN, 0});
    while (!stop.load()) {
      auto wait = std::chrono::nanoseconds::max();
      const auto now = NetworkFaults::Clock::now();
      // Each card's idle wait, or sooner a datagram its network holds back.
      for (SimDaemon* d : cards)
        wait = std::min({wait, std::chrono::nanoseconds(d->idleWait()), d->udp_->untilDue(now)});
      const timespec ts{static_cast<time_t>(wait.count() / 1'000'000'000),
                        static_cast<long>(wait.count() % 1'000'000'000)};
      const int ready = ::ppoll(fds.data(), fds.size(), &ts, nullptr);
      if (ready == 0) {  // the timer: how late it woke this thread (SimClock::heldBack)
        const auto late = NetworkFaults::Clock::now() - (now + wait);
        for (SimDaemon* d : cards) {
          d->watchHost();
          d->clock_.heldBack(std::max(std::chrono::nanoseconds{0}, late));
        }
      }
      for (std::size_t i = 0; i < cards.size(); ++i) {
        SimDaemon& d = *cards[i];
        const bool readable = ready > 0 && ((fds[2 * i].revents | fds[2 * i + 1].revents) & POLLIN) != 0;
        if (readable || d.ticks() || d.udp_->untilDue(NetworkFaults::Clock::now()) <= std::chrono::nanoseconds(0))
          d.serve(std::chrono::milliseconds(0));
      }
    }
  }
  for (SimDaemon* d : cards) d->closeJobs();
}

void SimDaemon::closeJobs() {
  // No job is taken after this one last round: the API's threads get their
  // answers (or "stopping") at once instead of waiting for a thread that is
  // gone.
  std::deque<std::packaged_task<Answer()>> last;
  {
    std::lock_guard<std::mutex> lock(jobsMutex_);
    jobsClosed_ = true;
    last.swap(jobs_);
  }
  for (auto& task : last) task();
}

}  // namespace lbpkit::server
