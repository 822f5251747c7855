// SPDX-License-Identifier: MIT
// One servo-thread period over every module the host library drives, as
// LinuxCNC's hostmot2 read and write functions cover all of a card's
// modules: the smart-serial outputs and DOIT, the muxed encoders' control
// changes and count reads, sent in one flush; then the DOIT's inputs and
// the encoders' counts. A real-time path: no allocation, no name lookups
// (elements are found beforehand with SmartSerial::find()).
#pragma once

#include "lbpkit/encoders.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/transport.hpp"

namespace lbpkit {

// SmartSerial::queueOutputs(), MuxedEncoders::queue(), Transport::tryFlush(),
// SmartSerial::collectInputs(), MuxedEncoders::update(). `encoders` may be
// null (a card without them, or a caller that reads none). Never throws:
// a lost reply is CycleStatus::replyLost, and the encoders then keep their
// last counts (MuxedEncoders::update() returns false).
CycleStatus servoCycle(Transport& t, SmartSerial& sserial, MuxedEncoders* encoders);

}  // namespace lbpkit
