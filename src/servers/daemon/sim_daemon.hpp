// SPDX-License-Identifier: MIT
// `lbpkit sim`: a virtual 7I92 with 7I77s on the network.
//
// One thread owns the card: it waits on the LBP16 socket, answers each
// datagram, and lets simulated time follow the wall clock or the host's
// servo cycles (sim_clock.hpp), so the 7I77 and HostMot2 watchdogs bite when
// the host stops. The HTTP control
// API (api_routes.hpp) runs on its own threads and hands its work to the card
// thread as jobs, taken between datagrams without ever blocking it; what it
// answers is the models' state (state_json.hpp).
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "daemon/api_routes.hpp"
#include "daemon/fault_script.hpp"
#include "daemon/host_watch.hpp"
#include "daemon/pcap_recorder.hpp"
#include "daemon/sim_clock.hpp"
#include "daemon/trace_file.hpp"
#include "daemon/trace_ring.hpp"
#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"
#include "machine/machine.hpp"
#include "pty/pty_channel.hpp"

namespace lbpkit::server {

enum class LogLevel { Error, Warn, Info, Debug };

struct SimOptions {
  std::string bindAddress = "127.0.0.1";  // never anything else unless the user asks
  std::uint16_t port = lbp16::kPort;
  std::string apiAddress = "127.0.0.1";
  int apiPort = 27182;  // -1: no control API; 0: any free port
  std::string apiToken;  // when set, API requests carry "Authorization: Bearer TOKEN"
  double speed = 1.0;   // simulated seconds per wall-clock second
  bool paused = false;
  // Simulated time driven by the host's servo cycles instead of the wall
  // clock (`--clock host[=PERIOD]`, sim_clock.hpp); speed is then 1.
  std::optional<HostClock> hostClock;
  LogLevel logLevel = LogLevel::Info;
  // Run the card thread at a real-time priority (SCHED_FIFO) when allowed,
  // so a host's read is answered within its period even on a busy machine.
  bool realtime = true;
  // The one CPU the card thread runs on (`--cpu N`); empty: any. With the
  // host's process on the same CPU, below the card thread's SCHED_FIFO, a
  // datagram the host sends wakes the card thread at once on that CPU, and
  // the reply is in the host's socket before the host runs again to look
  // for it, however the machine around them is scheduled: a real card
  // answers in microseconds whatever the PC does (docs/sim.md: Scheduling).
  std::optional<unsigned> cpu;
  // Hold the CPUs' wake-up latency at most this long while the sim runs
  // (Linux PM QoS, /dev/cpu_dma_latency, root): 0 keeps idle CPUs polling
  // instead of halting, so no thread waits for a CPU to wake. A machine-
  // wide request, dropped when the sim exits; empty: none.
  std::optional<std::chrono::microseconds> cpuLatency;
  // A little world for demonstrations: the 7I77's field outputs wired back
  // to its inputs 0..15, and encoder 0 turning at 10 000 counts/s.
  bool demo = false;
  // A machine behind the 7I77 on connector 0: servo axes,
  // switches, spindle (machine/machine.hpp). Excludes `demo`.
  std::optional<model::machine::MachineDescription> machine;
  std::string machineSource;  // where it came from, for the banner ("built-in mill", a file)
  // With a machine: its servo-cycle trace also goes to this CSV file.
  std::string recordFile;
  // How many servo cycles the trace keeps for GET /api/machine/trace (60 s at 1 kHz).
  std::size_t traceRows = 60'000;
  model::hm2::HostMot2Card::Options card;
  // The 7I92's configuration flash, kept across runs (lbp16/flash_file.hpp);
  // empty: in memory, blank at every start.
  std::filesystem::path flashFile;
  std::string configDescription = "built-in default";
  // Faults at set simulated times (the TOML's [[fault]] entries).
  std::vector<ScriptedFault> faultScript;
  // SSLBP channels brought out to a pseudo-terminal each, for a remote of
  // the user's own (`--remote 2=pty`; pty/pty_channel.hpp).
  std::vector<unsigned> externalRemotes;
  // Every datagram in and every reply out, with its time, to this pcap file
  // (`--trace FILE.pcap`; daemon/pcap_recorder.hpp).
  std::string packetTraceFile;
};

struct SimState;
class ControlApi;
class UdpServer;

class SimDaemon {
 public:
  explicit SimDaemon(SimOptions options);
  ~SimDaemon();
  SimDaemon(const SimDaemon&) = delete;
  SimDaemon& operator=(const SimDaemon&) = delete;

  // What `lbpkit sim` prints at start: where it listens, what it carries.
  [[nodiscard]] std::string banner() const;
  // Serves until `stop` is set. The card thread sleeps until the next
  // datagram, API job or (with a machine, the demo world, a fault script
  // or an external remote) the next millisecond; `stopFd`, when given,
  // is a descriptor that becomes readable when `stop` is set (a signal
  // handler's eventfd), so a sleeping card thread hears of it at once.
  void run(const std::atomic<bool>& stop, int stopFd = -1);
  // The same for several cards on one thread (`lbpkit sim --bind A
  // --bind B ...`): one wait for all their sockets and job queues, each
  // card served when it has something to do. The thread's scheduling is
  // the first card's options'.
  static void runAll(std::span<SimDaemon* const> cards, const std::atomic<bool>& stop, int stopFd = -1);

  [[nodiscard]] std::uint16_t port() const;
  [[nodiscard]] int apiPort() const { return apiPort_; }
  // The SSLBP channels brought out to a pseudo-terminal (--remote CH=pty):
  // each channel with the terminal's path.
  [[nodiscard]] std::vector<std::pair<unsigned, std::string>> externalRemotes() const;
  // The whole board now (call on the card thread).
  [[nodiscard]] SimState state();
  // The same, and GET /api/machine's (with a machine), as the API's
  // answers: taken on the card thread, made text by whoever calls them.
  Answer stateAnswer();
  Answer machineAnswer();
  // "median 3 us, 99th percentile 9 us, max 40 us over N datagrams".
  [[nodiscard]] std::string latencySummary() const;
  // "N packets to FILE" (and how many were lost), or "" without --trace.
  [[nodiscard]] std::string packetTraceSummary() const;

 private:
  std::string runJob(std::function<Answer()> job);
  // The calling thread becomes the card thread: SCHED_FIFO (or a short
  // slice) and the CPU the options ask for; what it got, in words.
  std::string takeCardThread();
  // One round of the card thread: waits up to `wait` for a datagram and
  // answers it, then lets time pass, runs what is due and the API's jobs.
  void serve(std::chrono::milliseconds wait);
  // Hands the clock what the host watch saw (a sighting of the host's
  // process runnable) and what the network lost of the host's requests.
  void watchHost();
  // The card thread has stopped: queued jobs get their answers at once.
  void closeJobs();
  void drainJobs();
  // Brings the card up to the clock, with bounded work (SimClock::catchUp);
  // returns the card's time, the time everything happens at.
  model::lbp::SimTime catchUp(std::chrono::microseconds budget = SimClock::kBudget);
  // The same towards `target` (a simulated time not after the clock's).
  model::lbp::SimTime catchUpTo(model::lbp::SimTime target, std::chrono::microseconds budget = SimClock::kBudget);
  // The budget of a catch-up towards the clock: bounded on the wall clock;
  // driven by a host's cycles, the whole cycle (SimClock::kHostBudget).
  [[nodiscard]] std::chrono::microseconds budget() const {
    return clock_.drivenByHost() ? SimClock::kHostBudget : SimClock::kBudget;
  }
  // Whether anything moves on the card thread's own account between
  // datagrams and jobs: a machine, the demo world, a fault script still to
  // run, an external remote's pseudo-terminal. Without, the card thread
  // sleeps until a datagram or a job comes, and a sim nobody talks to
  // costs nothing.
  [[nodiscard]] bool ticks() const;
  // How long the card thread may wait for a datagram or a job: a
  // millisecond for the demo world, a fault script still to run or a
  // pseudo-terminal, at most SimClock::kHeldBackCheck while a host drives
  // time (so that a stall of its CPU is a timer missed), kMachineTick for
  // a machine alone, else until woken.
  [[nodiscard]] std::chrono::milliseconds idleWait() const;
  // A machine nobody talks to is caught up every this much simulated time
  // (at --speed 1, this often; at --speed 100, every 2.5 ms, at least
  // every millisecond): each catch-up is then 250 spans of its plant, a
  // few hundred microseconds at most, well within SimClock::kBudget, and
  // an idle sim with a machine wakes four times a second (a wake-up costs
  // tens of microseconds on a paravirtualised machine).
  static constexpr std::chrono::milliseconds kMachineTick{250};
  // A trace row when the host has run a servo cycle since the last look.
  void record();
  // --trace: the datagram just served and the reply to it (card thread).
  void traceDatagram(std::span<const std::uint8_t> request, std::span<const std::uint8_t> reply);
  void log(LogLevel level, const std::string& text) const;

  SimOptions options_;
  model::hm2::HostMot2Card card_;
  // Stepped on the card thread, before the card (catchUp).
  std::unique_ptr<model::machine::Machine> machine_;
  // Its trace: a row per host cycle, seen as a new process data exchange
  // of the analog processor (one DOIT of its channel per servo period).
  std::unique_ptr<TraceRing> trace_;
  std::vector<double> traceRow_;  // allocated once
  std::uint32_t analogExchanges_ = 0;
  bool traced_ = false;  // a trace row has been taken, at lastTraced_ (the plant's time)
  model::lbp::SimTime lastTraced_{};
  std::unique_ptr<TraceFile> traceFile_;  // after trace_: it reads it until it goes
  std::unique_ptr<Lbp16Card> lbp16_;
  std::unique_ptr<UdpServer> udp_;
  std::unique_ptr<PcapRecorder> packetTrace_;  // --trace: written on a thread of its own
  PcapRecorder::Endpoint cardEndpoint_{};
  // What the API's routes and the fault script act on.
  std::unique_ptr<ApiTarget> target_;
  std::unique_ptr<FaultScript> script_;
  // The external remotes' channels, pumped on the card thread (after card_:
  // they go first).
  std::vector<std::unique_ptr<PtyChannel>> ptyChannels_;
  std::uint64_t sendFailuresSeen_ = 0;
  std::uint64_t errorsSeen_ = 0;  // bad datagrams logged so far
  std::function<void(const std::string&)> scriptLog_;
  SimClock clock_;
  // On the host clock: the watch on the host's process, and what of it the
  // clock has taken (watchHost(), on the card thread).
  std::unique_ptr<HostWatch> hostWatch_;
  HostWatch::Clock::duration hostSeenTaken_{0};
  std::uint64_t requestsLostSeen_ = 0;
  std::string interface_;
  std::string schedule_ = "normal scheduling";
  bool macFromInterface_ = false;
  // Readable while jobs wait: wakes the card thread from its sleep.
  int jobsReady_ = -1;
  int cpuLatencyFd_ = -1;  // /dev/cpu_dma_latency, open while the request holds
  std::mutex jobsMutex_;
  std::deque<std::packaged_task<Answer()>> jobs_;
  std::deque<std::packaged_task<Answer()>> ready_;  // the jobs being run (card thread only)
  bool jobsClosed_ = false;  // the card thread has stopped: no job would run
  // Server-side time per datagram: from the kernel's receive
  // timestamp to the reply sent (latency_), and of that the time it queued
  // in the socket (queueing_).
  struct Latency {
    // 1 us buckets below 1 ms, then 100 us buckets to 100 ms (queueing in a
    // flood reaches milliseconds); the last one: 100 ms and more.
    static constexpr std::size_t kFine = 1000, kCoarseUs = 100, kCoarse = 990;
    std::array<std::uint64_t, kFine + kCoarse + 1> buckets{};
    std::uint64_t count = 0;
    std::uint64_t maxNs = 0;
    void add(std::chrono::nanoseconds d);
    [[nodiscard]] double percentileUs(double p) const;
    [[nodiscard]] std::uint64_t countAtLeastUs(unsigned us) const;
  } latency_, queueing_;
  // Rate-limited logging of bad datagrams.
  std::chrono::steady_clock::time_point lastBadLog_{};
  // Rate-limited logging of simulated time falling behind.
  std::chrono::steady_clock::time_point lastSlipLog_{};
  std::uint64_t slipsLogged_ = 0;
  // Last: its threads call into the members above until it is gone.
  std::unique_ptr<ControlApi> api_;
  int apiPort_ = -1;
};

}  // namespace lbpkit::server
