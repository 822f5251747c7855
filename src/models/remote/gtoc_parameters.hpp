// SPDX-License-Identifier: MIT
// The parameters each 7I77 processor lists in its GTOC: the one table that
// decides which exist and which a host may write (docs/protocol-facts.md#gtoc-parameters).
//
// No public source shows a real 7I77's GTOC. The manual's FIELD I/O
// PARAMETERS table names NVBAUDRATE, NVUNITNUMBER, UNITNUMBER,
// NVWATCHDOGTIME and WATCHDOGTIME, and its RPD/WPD examples read FAULT; where
// the 7I77 is unattested, the rows follow what LinuxCNC's sserial(9) man page
// shows its documented siblings report: 7I76, 7I69, 7I70, 7I71 list
// `nvbaudrate`, `nvunitnumber`, `nvwatchdogtimeout` and `swrevision`, all
// "(u32 ro)"; the 7I73 (the sibling with MPG counters) lists
// `nvencmode0..3`, also ro. No sibling lists a working `encmode`, a
// `hwrevision`, or its analog inputs as parameters, so none is here.
//
// LinuxCNC makes each non-BITS row a HAL parameter named after it, read only
// when its direction is Input (LinuxCNC: sserial.c, hm2_sserial_create_params),
// so the direction column is the ro/rw choice. NV rows are written with NV
// access on (0xEC = 1) whatever their direction, as `lbpkit wpd` and the
// manual's WPD do. Unit strings are "None" where mesaflash looks for that
// spelling (mesaflash: sserial_module.c).
#pragma once

#include <cstdint>
#include <string_view>

#include "lbp/protocol.hpp"

namespace lbpkit::model::remote {

// Which processor lists a row.
enum Processors : std::uint8_t {
  kFieldIoProcessor = 0x01,
  kAnalogProcessor = 0x02,
  kBothProcessors = 0x03,
};

struct GtocParameter {
  lbp::ProcessDataDescriptor descriptor;
  std::uint8_t processors;
};

namespace gtoc {
using lbp::DataType;
using lbp::Direction;
inline constexpr Direction kReadOnly = Direction::Input;           // LinuxCNC: HAL_RO
inline constexpr Direction kReadWrite = Direction::Bidirectional;  // LinuxCNC: HAL_RW
}  // namespace gtoc

// Rows in GTOC order. NV rows take EEPROM bytes in this order (NVEncMode0/1
// first), so the field I/O EEPROM keeps the layout earlier lbpkit versions
// wrote to --state files. Both processors' rows include the Standard ones
// (remote_device.hpp), found by name.
inline constexpr GtocParameter kGtocParameters[] = {
    // name, unit, type, ro/rw, bits, min, max                              who     source
    {{"NVEncMode0", "None", gtoc::DataType::NonVolUnsigned, gtoc::kReadOnly, 8, 0.0F, 2.0F},
     kFieldIoProcessor},  // manual: MPG INPUTS "default counter mode is 1X"; 7I73: nvencmodeN (u32 ro)
    {{"NVEncMode1", "None", gtoc::DataType::NonVolUnsigned, gtoc::kReadOnly, 8, 0.0F, 2.0F},
     kFieldIoProcessor},
    {{"SwRevision", "None", gtoc::DataType::Unsigned, gtoc::kReadOnly, 16, 0.0F, 65535.0F},
     kBothProcessors},  // siblings: swrevision (u32 ro); mesaflash reads 16 bits
    {{"NVBaudRate", "None", gtoc::DataType::NonVolUnsigned, gtoc::kReadOnly, 16, 0.0F, 11.0F},
     kBothProcessors},  // manual: NVBAUDRATE UINT; siblings: nvbaudrate (u32 ro)
    {{"NVUnitNumber", "None", gtoc::DataType::NonVolUnsigned, gtoc::kReadOnly, 32, 0.0F, 4294967295.0F},
     kBothProcessors},  // manual: NVUNITNUMBER ULONG; siblings: nvunitnumber (u32 ro)
    {{"NVWatchDogTimeout", "mS", gtoc::DataType::NonVolUnsigned, gtoc::kReadOnly, 16, 0.0F, 65535.0F},
     kBothProcessors},  // manual: NVWATCHDOGTIME UINT; siblings: nvwatchdogtimeout (u32 ro)
    {{"UnitNumber", "None", gtoc::DataType::Unsigned, gtoc::kReadWrite, 32, 0.0F, 4294967295.0F},
     kBothProcessors},  // manual: UNITNUMBER ULONG, "user settable"
    {{"WatchDogTime", "mS", gtoc::DataType::Unsigned, gtoc::kReadWrite, 16, 0.0F, 65535.0F},
     kBothProcessors},  // manual: WATCHDOGTIME UINT; WPD WATCHDOGTIME 0
    {{"Fault", "None", gtoc::DataType::Bits, gtoc::kReadOnly, 8, 0.0F, 0.0F},
     kBothProcessors},  // manual: RPD FAULT H; BITS make no LinuxCNC parameter
};

inline constexpr std::size_t kStandardParameterCount = 7;

}  // namespace lbpkit::model::remote
