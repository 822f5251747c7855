// SPDX-License-Identifier: MIT
// Protocol decoding: what a host said to a HostMot2 card over LBP16, and
// what it said to a smart-serial remote over LBP, in words (`lbpkit decode`).
// The caller brings the packets (lbpkit decode reads pcap files
// with libpcap); this names every command: LBP16 space, address and the
// register's name from the card's IDROM (`sserial.0.command`,
// `encoder.03.count`, `watchdog.timer`), the SSLBP commands written (STOP,
// START, DOIT, setup-mode remote accesses with the remote's local register
// named as the manual's LBP chapter names it), and the LBP commands on a
// serial line with their CRC checked.
//
// Decoders never throw on bad input: a truncated or malformed datagram or
// command becomes an event that says what is wrong.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "lbpkit/hostmot2.hpp"

namespace lbpkit::decode {

// One decoded line: when (the packet's time, nanoseconds since the epoch)
// and what.
struct Event {
  std::int64_t ns = 0;
  std::string text;
  bool malformed = false;  // the packet or command was not well formed
};

// HostMot2 register names from a card's IDROM (module descriptors), in
// LinuxCNC's words where it has them (watchdog, ioport, encoder, sserial).
class RegisterNames {
 public:
  RegisterNames() = default;
  explicit RegisterNames(CardInfo info);

  // "sserial.0.command", "sserial.0.ch2.cs", "encoder.03.count",
  // "watchdog.timer", "ioport.1.ddr", "idrom.cookie", "idrom.module[3]",
  // "idrom.pin[17]"; "" when no module or IDROM field is there.
  [[nodiscard]] std::string name(std::uint16_t address) const;

  // Where an SSerial register is: its instance, register (0 COMMAND, 1
  // DATA, 2 CS, 3..5 interface 0..2) and channel (registers 2..5).
  struct Sserial {
    unsigned instance = 0;
    unsigned reg = 0;
    unsigned channel = 0;
  };
  [[nodiscard]] std::optional<Sserial> sserial(std::uint16_t address) const;

  [[nodiscard]] const CardInfo& card() const { return info_; }

 private:
  CardInfo info_;
  std::uint16_t idrom_ = 0x400;
};

// The card's IDROM as the host library reads it (readCardInfo), from the
// HostMot2 register values a capture shows the host reading. Throws
// lbpkit::Error naming the first register the capture does not have.
CardInfo cardInfoFromRegisters(const std::map<std::uint16_t, std::uint32_t>& registers);

// LBP16 over UDP: feed it the datagrams to the card (request) and from it
// (reply) in capture order. A request's reads are told when their reply
// comes (or the next request does, without one).
class Lbp16Decoder {
 public:
  explicit Lbp16Decoder(CardInfo info = {});

  void request(std::int64_t ns, std::span<const std::uint8_t> datagram, std::vector<Event>& out);
  void reply(std::int64_t ns, std::span<const std::uint8_t> datagram, std::vector<Event>& out);
  // The end of the capture: reads still waiting for a reply are told.
  void finish(std::vector<Event>& out);

  // Every HostMot2 register value read in the replies so far (the last
  // value for each address): what cardInfoFromRegisters() wants.
  [[nodiscard]] const std::map<std::uint16_t, std::uint32_t>& registersRead() const { return read_; }

 private:
  struct Access;
  void emit(const Access& a, std::span<const std::uint8_t> data, bool answered, std::vector<Event>& out);
  [[nodiscard]] std::string describeWrite(std::uint16_t address, std::uint32_t value);
  [[nodiscard]] std::string describeRead(std::uint16_t address, std::uint32_t value) const;
  [[nodiscard]] std::string remoteAccess(unsigned instance, unsigned channel) const;

  RegisterNames names_;
  struct Access {
    std::int64_t ns = 0;
    std::uint16_t word = 0;
    std::uint16_t address = 0;
    bool hasAddress = false;
    unsigned offset = 0;  // where its data starts in the reply
  };
  std::vector<Access> pending_;  // the last request's reads
  unsigned pendingBytes_ = 0;
  std::int64_t pendingNs_ = 0;
  std::uint16_t pointer_[8] = {};  // each space's address pointer, for commands without an address
  std::map<std::uint16_t, std::uint32_t> read_;
  // SSLBP state per instance and channel, as the host's writes set it.
  struct Channel {
    bool setup = false;
    std::uint32_t cs = 0;          // the last CS written
    std::uint32_t interface0 = 0;  // the last interface 0 written
    bool remoteRead = false;       // the last DOIT was a setup-mode read: interface 0 holds its answer
  };
  struct Instance {
    Channel channel[8];
    std::uint32_t lastCommand = 0;
  };
  std::map<unsigned, Instance> sserial_;
};

// LBP on a serial line (or an SSLBP channel): the bytes to the remote and
// from it, in capture order.
class LbpStreamDecoder {
 public:
  void toRemote(std::int64_t ns, std::span<const std::uint8_t> bytes, std::vector<Event>& out);
  void fromRemote(std::int64_t ns, std::span<const std::uint8_t> bytes, std::vector<Event>& out);
  void finish(std::vector<Event>& out);

 private:
  struct Command {
    std::int64_t ns = 0;
    std::vector<std::uint8_t> bytes;  // header, address, data, CRC
    std::string text;
    int replyBytes = -1;  // with its CRC; -1: not known (a stored RPC)
    bool crcOk = true;
  };
  void parse(std::vector<Event>& out);
  void answer(std::vector<Event>& out);
  void tell(const Command& c, std::span<const std::uint8_t> reply, bool answered, std::vector<Event>& out);

  std::vector<std::uint8_t> in_;     // bytes to the remote not yet parsed
  std::int64_t inNs_ = 0;            // when the first of them came
  std::int64_t lastInNs_ = 0;        // when the last bytes to the remote came
  std::int64_t replyNs_ = 0;         // when the last bytes from the remote came
  std::vector<std::uint8_t> reply_;  // bytes from the remote not yet matched
  std::vector<Command> waiting_;     // commands whose answer is due
  unsigned rxSize_ = 0, txSize_ = 0;  // from the last discovery RPC's answer (0xBD's sizes)
  bool sizesKnown_ = false;
};

// The remote's local LBP registers by their manual names (LBP chapter:
// LOCAL LBP READ/WRITE COMMANDS): "FaultStatus" for 0xD7, "LEDs" for 0xF7.
std::string localRegisterName(std::uint8_t command);
// An LBP command header in words: "read 1 byte, 2-byte address,
// auto-increment", "local read FaultStatus", "RPC 0xBB Discovery".
std::string lbpHeaderName(std::uint8_t header);

}  // namespace lbpkit::decode
