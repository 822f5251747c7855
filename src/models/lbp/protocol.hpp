// SPDX-License-Identifier: MIT
// The LBP facts the models share with the host (lbpkit_wire), named in the
// models' own `lbp` namespace, so a model says lbp::local_read::kStatus:
// each of wire's LBP names the models use, declared here by name.
#pragma once

#include "lbpkit/wire/crc8.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/process_data.hpp"

namespace lbpkit::model::lbp {
// The local registers, status and capability bits, RPCs and records.
namespace local_read = wire::lbp::local_read;
namespace local_write = wire::lbp::local_write;
namespace status = wire::lbp::status;
namespace capability = wire::lbp::capability;
namespace nonvolatile = wire::lbp::nonvolatile;
namespace flash = wire::lbp::flash;
namespace special_rpc = wire::lbp::special_rpc;
namespace pdd = wire::lbp::pdd;
namespace mode_record = wire::lbp::mode_record;
// Commands and their headers.
using wire::lbp::CommandType;
using wire::lbp::commandType;
using wire::lbp::DataCommand;
using wire::lbp::kBitsPerCharacter;
using wire::lbp::kCookie;
using wire::lbp::kHwMode;
using wire::lbp::kResetKey;
using wire::lbp::kRpcCommandBase;
using wire::lbp::kRpcPitch;
using wire::lbp::kSwMode;
using wire::lbp::readHeader;
using wire::lbp::writeHeader;
// The CRC.
using wire::lbp::Crc8;
using wire::lbp::crc8;
// Process data.
using wire::lbp::byteSize;
using wire::lbp::DataType;
using wire::lbp::Direction;
using wire::lbp::isDirection;
using wire::lbp::isKnownDataType;
using wire::lbp::isNonVolatile;
using wire::lbp::isSigned;
using wire::lbp::kModeRecord;
using wire::lbp::kPackingRoom;
using wire::lbp::kProcessDataRecord;
using wire::lbp::packBits;
using wire::lbp::ProcessDataDescriptor;
using wire::lbp::signExtend;
using wire::lbp::unpackBits;
}  // namespace lbpkit::model::lbp
