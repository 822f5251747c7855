#!/bin/bash
# SPDX-License-Identifier: MIT
# Builds sslbp_compare: lbpkit's 7I77 processors against Mesa's real SSLBP 43 (Verilated by the
# external sslbp-oracle tool) and against lbpkit's own SSLBP model.
#   tools/sslbp-compare/build.sh ORACLE_DIR [LBPKIT_BUILD_DIR] [OUT_DIR]
# ORACLE_DIR: a build of the sslbp-oracle tool — Mesa's SSLBP sources from LinuxCNC/hostmot2-firmware
# (sserialwa.vhd, the DumbAss8 CPU, sslbprom43.vhd) run under Verilator; not part of this repository.
# It holds vl/sslbp_vsim.h and the Verilated model vl/obj_p6 (6 channels), and vl/obj_pN once
# build-oracle-ports.sh made another channel count; PORTS=N picks it (default: 3 if vl/obj_p3
# exists, else 6).
# LBPKIT_BUILD_DIR: a product build dir with liblbpkit_models.a (default build/hH).
# Not part of the product's build: nothing here is built by CMakeLists.txt or scripts/test.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
ORACLE=${1:?usage: build.sh ORACLE_DIR [LBPKIT_BUILD_DIR] [OUT_DIR]}
LBP=${2:-$ROOT/build/hH}
OUT=${3:-$ORACLE}
if [ -z "${PORTS:-}" ]; then if [ -d "$ORACLE/vl/obj_p3" ]; then PORTS=3; else PORTS=6; fi; fi
OBJ=$ORACLE/vl/obj_p$PORTS
VI=/usr/share/verilator/include
[ -f "$LBP/src/models/liblbpkit_models.a" ] || cmake --build "$LBP" --target lbpkit_models lbpkit_wire
# The Verilator runtime objects the oracle's own build made (verilated.o etc.); make them if missing.
if [ ! -f "$OBJ/verilated.o" ]; then make -C "$OBJ" -f Vsserialwa.mk verilated.o verilated_threads.o >/dev/null; fi
g++ -O2 -std=c++20 -DWITH_ORACLE -DORACLE_PORTS=$PORTS -I"$OBJ" -I$VI -I$VI/vltstd \
  -I"$ROOT/src/models" -I"$ROOT/src/wire/include" -I"$ORACLE/vl" \
  "$HERE/compare.cpp" "$OBJ/Vsserialwa__ALL.a" "$OBJ/verilated.o" "$OBJ/verilated_threads.o" \
  "$LBP/src/models/liblbpkit_models.a" "$LBP/src/wire/liblbpkit_wire.a" -pthread -latomic \
  -o "$OUT/sslbp_compare_p$PORTS"
echo "$OUT/sslbp_compare_p$PORTS"
