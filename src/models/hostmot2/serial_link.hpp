// The RS-422 link between an SSLBP channel and an LBP remote: characters at
// the channel's baud rate, so an exchange takes the time its characters take
// on the wire plus the remote's turnaround (manual: SSLBP, DOIT; LBP, FRAMING).
//
// The link can be cut, and can corrupt, drop or add characters, or carry a
// break, in either direction, for fault injection: SSLBP then reports what
// a real card would (CS REGISTER AFTER START, local fault bits).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "lbp/sim_time.hpp"
#include "remote/remote_device.hpp"

namespace hm2 {

using lbp::SimTime;

class SerialLink {
 public:
  // Time from the remote's last received character to its first reply
  // character: parser and RPC processing on the remote's processor.
  static constexpr SimTime kTurnaround = SimTime{2000};  // 2 us
  static constexpr std::size_t kMaxReply = 300;

  enum class Direction { ToRemote, FromRemote };

  void attach(remote::RemoteDevice* remote) { remote_ = remote; }
  [[nodiscard]] remote::RemoteDevice* remote() const { return remote_; }

  struct Reply {
    // The first `size` bytes are the reply; the rest are not set (not
    // cleared either: an exchange runs for every SSLBP transaction).
    std::array<std::uint8_t, kMaxReply> bytes;
    std::size_t size = 0;
    SimTime lastByteAt{};  // when the last reply character has arrived
    bool breakSeen = false;
  };
  // Sends `frame` starting at `start` at `baud` and collects what comes back.
  // On an external link the frame goes to the outbox and no reply comes back.
  Reply exchange(std::span<const std::uint8_t> frame, SimTime start, std::uint32_t baud);

  // --- External remote (lbpkit sim --remote CH=pty) ------------------------
  // The remote is another process: frames the channel sends wait in a fixed
  // outbox (no allocation per frame) until whoever serves the process takes
  // them; its reply comes back through SmartSerial::remoteBytes. Fault
  // injection applies to the frames sent; replies arrive as they are.
  static constexpr std::size_t kOutboxSize = 1024;
  void setExternal(bool external) {
    external_ = external;
    outboxSize_ = 0;
  }
  [[nodiscard]] bool external() const { return external_; }
  [[nodiscard]] std::span<const std::uint8_t> outbox() const { return {outbox_.data(), outboxSize_}; }
  // The first `count` outbox bytes have been taken.
  void consumeOutbox(std::size_t count);

  // --- Fault injection -------------------------------------------------------
  void setConnected(bool connected) { connected_ = connected; }
  [[nodiscard]] bool connected() const { return connected_; }
  // The next `count` characters in `dir` are damaged (bits flipped) or
  // dropped; `addExtra` puts noise characters right after the next frame or
  // reply; a break is a framing error on the next reply.
  void corruptNext(Direction dir, unsigned count = 1) { faults(dir).corrupt += count; }
  void dropNext(Direction dir, unsigned count = 1) { faults(dir).drop += count; }
  void addExtra(Direction dir, unsigned count = 1) { faults(dir).add += count; }
  void breakNext() { breakNext_ = true; }

  struct Counters {
    std::uint64_t toRemote = 0;
    std::uint64_t fromRemote = 0;
    std::uint64_t corrupted = 0;
    std::uint64_t dropped = 0;
    std::uint64_t added = 0;
    std::uint64_t breaks = 0;
    std::uint64_t outboxOverflows = 0;  // external: bytes lost, nobody took the outbox
  };
  [[nodiscard]] const Counters& counters() const { return counters_; }

 private:
  struct Faults {
    unsigned corrupt = 0;
    unsigned drop = 0;
    unsigned add = 0;
  };
  Faults& faults(Direction d) { return d == Direction::ToRemote ? toRemote_ : fromRemote_; }
  // Applies pending faults to one character; returns 0 when it is lost.
  unsigned damage(Faults& f, std::uint8_t& byte);
  // Noise characters to add after this frame.
  unsigned extras(Faults& f);
  static constexpr std::uint8_t kNoise = 0xA5;

  remote::RemoteDevice* remote_ = nullptr;
  bool connected_ = true;
  bool external_ = false;
  std::array<std::uint8_t, kOutboxSize> outbox_{};
  std::size_t outboxSize_ = 0;
  bool breakNext_ = false;
  Faults toRemote_;
  Faults fromRemote_;
  Counters counters_;
};

}  // namespace hm2
