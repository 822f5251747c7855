// SPDX-License-Identifier: MIT
#include "lbp/parser.hpp"

#include <algorithm>

#include "lbp/protocol.hpp"

namespace lbpkit::model::lbp {

namespace {

constexpr std::uint8_t kTrue = 0xFF;

// Walks the RPC list of `header` in the table at 0..rpcSize-1, calling
// `visit` for each stored command. The list ends at a 0 byte, at a byte that
// is not a data command, or at the end of the table; it is linear, so the
// walk always terminates.
template <typename Visit>
void walkRpcList(Target& target, std::uint16_t rpcSize, std::uint8_t header, Visit&& visit) {
  using StoredCommand = Parser::StoredCommand;
  std::uint32_t p = static_cast<std::uint32_t>(header & 0x3FU) * kRpcPitch;
  auto next = [&]() { return target.readMemory(static_cast<std::uint16_t>(p++)); };
  while (p < rpcSize) {
    const std::uint8_t h = next();
    if (commandType(h) != CommandType::Data) break;
    StoredCommand s{DataCommand::decode(h), 0, {}};
    if (s.cmd.hasAddress) {
      if (p + 2 > rpcSize) break;
      const std::uint8_t lo = next();
      s.address = static_cast<std::uint16_t>(lo | (next() << 8));
    }
    if (s.cmd.write && s.cmd.rpcIncludesData) {
      if (p + s.cmd.dataSize > rpcSize) break;
      for (unsigned i = 0; i < s.cmd.dataSize; ++i) s.inlineData[i] = next();
    }
    visit(s);
  }
}

// A data command sent on its own, not stored in an RPC list: RID is "RPC
// only, ignored for non RPC commands" (manual: LBP DATA READ/WRITE COMMAND),
// so a write's data always follows its header (and address).
DataCommand direct(std::uint8_t header) {
  DataCommand cmd = DataCommand::decode(header);
  cmd.rpcIncludesData = false;
  return cmd;
}

}  // namespace

Parser::Parser(Target& target, ParserConfig config) : target_(target), config_(config) { reset(); }

void Parser::reset() {
  status_ = 0;
  crcEnabled_ = true;
  crcErrors_ = 0;
  rpcMem_ = false;
  timeout_ = config_.commandTimeout;
  updateGap();
  address_ = 0;
  unitId_ = 0;
  received_ = 0;
  length_ = 0;
  skipping_ = false;
  haveLast_ = false;
  responseLength_ = 0;
}

void Parser::updateGap() {
  // The gap has expired when the idle time between the end of the previous
  // character and the end of this one, less the character itself, exceeds
  // the timeout register (tenths of character times, manual: 0xCB):
  // idle * 10 > ch * timeout_, in whole nanoseconds idle > floor(ch * timeout_ / 10),
  // i.e. now - last_ >= ch + floor(ch * timeout_ / 10) + 1 ns.
  const SimTime ch = characterTime(config_.baud);
  gap_ = ch + (ch * timeout_) / 10 + SimTime{1};
}

void Parser::abandon(std::uint8_t statusBits) {
  raiseStatus(statusBits);
  length_ = 0;
  received_ = 0;
  ++discarded_;
}

void Parser::endGap() {
  if (length_ > 0) abandon(status::kCommandTimeout);
  skipping_ = false;
}

void Parser::complete(SimTime now) {
  execute(now);
  length_ = 0;
  received_ = 0;
}

void Parser::startCommand(std::uint8_t header) {
  std::size_t body = 0;
  switch (commandType(header)) {
    case CommandType::Undefined:
      // Not a header: nothing tells how long this is, so wait for a gap.
      skipping_ = true;
      ++discarded_;
      return;
    case CommandType::Data:
      body = direct(header).streamBytes();
      break;
    case CommandType::Local:
      if (header == local_write::kResetParser) return;  // a lone 0xFF resets the parser
      body = (header & 0x20U) ? 1 : 0;                   // writes carry one data byte
      break;
    case CommandType::Rpc: {
      if (auto sizes = target_.specialRpc(header)) {
        body = sizes->fromHost;
      } else {
        // The list is taken now, when the header says how long the command
        // is; a stored write that rewrites the table while the RPC runs
        // cannot change what this command consumes.
        rpcLength_ = 0;
        bool truncated = false;
        walkRpcList(target_, config_.rpcSize, header, [&](const StoredCommand& s) {
          if (rpcLength_ < rpcList_.size())
            rpcList_[rpcLength_++] = s;
          else
            truncated = true;
        });
        if (truncated) {  // longer than the parser keeps: a buffer overflow
          raiseStatus(status::kBufferOverflow);
          skipping_ = true;
          ++discarded_;
          return;
        }
        unsigned stream = 0;
        for (std::size_t i = 0; i < rpcLength_; ++i)
          if (rpcList_[i].cmd.write && !rpcList_[i].cmd.rpcIncludesData) stream += rpcList_[i].cmd.dataSize;
        body = stream;
      }
      break;
    }
  }
  const std::size_t total = 1 + body + 1;  // header, body, CRC
  if (total > kMaxCommand) {
    raiseStatus(status::kBufferOverflow);
    skipping_ = true;
    ++discarded_;
    return;
  }
  length_ = total;
  received_ = 0;
}

void Parser::emit(std::uint8_t byte) {
  // Data fills at most kMaxResponse bytes; the CRC always has its place after.
  if (responseLength_ < kMaxResponse) response_[responseLength_++] = byte;
}

void Parser::execute(SimTime now) {
  if (crcEnabled_ && crc8({command_.data(), length_}) != 0) {
    ++crcErrors_;  // wraps like the 8-bit counter it is
    raiseStatus(status::kCrcError);
    return;
  }
  target_.beginCommand(now);
  const std::uint8_t header = command_[0];
  const std::uint8_t* body = command_.data() + 1;
  switch (commandType(header)) {
    case CommandType::Data: {
      const DataCommand cmd = direct(header);
      std::uint16_t address = address_;
      if (cmd.hasAddress) {
        address = static_cast<std::uint16_t>(body[0] | (body[1] << 8));
        body += 2;
      }
      executeData(cmd, body, address, cmd.hasAddress, nullptr);
      break;
    }
    case CommandType::Local:
      if (header == local_write::kResetProcessor && body[0] == kResetKey) {
        // The processor restarts (a power-up without losing power): it
        // answers nothing, not even the CRC, and the parser is idle.
        target_.resetProcessor();
        responseLength_ = 0;
        return;
      }
      executeLocal(header, (header & 0x20U) ? body[0] : 0);
      break;
    case CommandType::Rpc:
      executeRpc(header, body);
      break;
    case CommandType::Undefined:
      break;
  }
  response_[responseLength_] = crc8({response_.data(), responseLength_});
  ++responseLength_;
  target_.endCommand(now);
}

void Parser::executeData(DataCommand cmd, const std::uint8_t*& stream, std::uint16_t address, bool addressGiven,
                         const std::uint8_t* inlineData) {
  if (addressGiven) address_ = address;
  for (unsigned i = 0; i < cmd.dataSize; ++i) {
    const auto a = static_cast<std::uint16_t>(address_ + i);
    if (!cmd.write) {
      emit(target_.readMemory(a));
      continue;
    }
    const std::uint8_t value = inlineData ? inlineData[i] : *stream++;
    // The RPC table is protected unless the RPCMEM flag is set (manual: RPC
    // COMMANDS), or something else is at its addresses.
    const bool allowed = (a >= config_.rpcSize || rpcMem_ || target_.rpcTableOverlaid()) && target_.writeMemory(a, value);
    if (!allowed) raiseStatus(status::kInvalidWrite);
  }
  if (cmd.autoInc) address_ = static_cast<std::uint16_t>(address_ + cmd.dataSize);
}

void Parser::executeRpc(std::uint8_t header, const std::uint8_t* stream) {
  if (auto sizes = target_.specialRpc(header)) {
    std::array<std::uint8_t, 256> out;  // the answer's bytes start cleared; the rest are not used
    std::fill_n(out.begin(), sizes->toHost, std::uint8_t{0});
    target_.runSpecialRpc(header, {stream, sizes->fromHost}, {out.data(), sizes->toHost});
    for (unsigned i = 0; i < sizes->toHost; ++i) emit(out[i]);
    return;
  }
  for (std::size_t i = 0; i < rpcLength_; ++i) {
    const StoredCommand& s = rpcList_[i];
    executeData(s.cmd, stream, s.address, s.cmd.hasAddress,
                s.cmd.write && s.cmd.rpcIncludesData ? s.inlineData.data() : nullptr);
  }
}

void Parser::executeLocal(std::uint8_t header, std::uint8_t value) {
  namespace r = local_read;
  namespace w = local_write;
  switch (header) {
    case r::kStatus: emit(status_); return;
    // Flags read back as the firmware stores true: 0xFF (LBP.INC).
    case r::kCrcEnable: emit(crcEnabled_ ? kTrue : 0); return;
    case r::kCrcErrorCount: emit(crcErrors_); return;
    case r::kRpcMemEnable: emit(rpcMem_ ? kTrue : 0); return;
    case r::kCommandTimeout: emit(timeout_); return;
    case r::kAddressLow: emit(static_cast<std::uint8_t>(address_ & 0xFFU)); return;
    case r::kAddressHigh: emit(static_cast<std::uint8_t>(address_ >> 8)); return;
    case r::kVersion: emit(config_.version); return;
    case r::kUnitId: emit(unitId_); return;
    case r::kRpcPitch: emit(kRpcPitch); return;
    case r::kRpcSizeLow: emit(static_cast<std::uint8_t>(config_.rpcSize & 0xFFU)); return;
    case r::kRpcSizeHigh: emit(static_cast<std::uint8_t>(config_.rpcSize >> 8)); return;
    case r::kCookie: emit(kCookie); return;

    case w::kStatus: status_ = value; return;
    case w::kCrcEnable: crcEnabled_ = config_.crcAlwaysEnabled || value != 0; return;
    case w::kCrcErrorCount: crcErrors_ = value; return;
    case w::kRpcMemEnable: rpcMem_ = value != 0; return;
    case w::kCommandTimeout:
      timeout_ = value;
      updateGap();
      return;
    case w::kAddressLow: address_ = static_cast<std::uint16_t>((address_ & 0xFF00U) | value); return;
    case w::kAddressHigh: address_ = static_cast<std::uint16_t>((address_ & 0x00FFU) | (static_cast<unsigned>(value) << 8)); return;
    case w::kAddToAddress: address_ = static_cast<std::uint16_t>(address_ + value); return;
    case w::kUnitId: unitId_ = value; return;
    case w::kResetProcessor:  // any other data byte: nothing (the key 0x5A is handled in execute())
      return;
    default: break;
  }
  if (header & 0x20U) {
    if (!target_.writeLocal(header, value)) raiseStatus(status::kInvalidWrite);
  } else {
    // Reserved read addresses answer 0 so the host stays in step.
    emit(target_.readLocal(header).value_or(0));
  }
}

}  // namespace lbpkit::model::lbp
