// SPDX-License-Identifier: MIT
// The servo cycle over the smart-serial channels and the muxed encoders
// (servo_cycle.hpp): what a servo thread calls once a period.
#include "lbpkit/servo_cycle.hpp"

namespace lbpkit {

CycleStatus servoCycle(Transport& t, SmartSerial& sserial, MuxedEncoders* encoders) {
  sserial.queueOutputs();
  if (encoders != nullptr) encoders->queue();
  (void)t.tryFlush();  // a lost reply is in the status collectInputs() gives
  const CycleStatus status = sserial.collectInputs();
  if (encoders != nullptr) (void)encoders->update();
  return status;
}

}  // namespace lbpkit
