#!/bin/bash
# SPDX-License-Identifier: MIT
# Adds a build of the real SSLBP with another channel count to ORACLE_DIR, a build of the external
# sslbp-oracle tool (Mesa's SSLBP sources from LinuxCNC/hostmot2-firmware — sserialwa.vhd, the
# DumbAss8 CPU, sslbprom43.vhd — under Verilator; not part of this repository), which builds 6
# channels: a 7I92 with one 7I77 has 3 SSerial channels, and local parameter 7 and local 0x234
# report the hardware's count.
#   tools/sslbp-compare/build-oracle-ports.sh ORACLE_DIR [PORTS=3]
# GHDL synthesis -> Verilog -> Verilator, about 1-2 minutes; result in ORACLE_DIR/vl/obj_pPORTS.
# Uses the oracle's own scripts (prep_synth.py, fix_pmux.py) and its unmodified sources.
set -euo pipefail
ORACLE=$(cd "${1:?usage: build-oracle-ports.sh ORACLE_DIR [PORTS]}" && pwd)
PORTS=${2:-3}
cd "$ORACLE"
[ -s src/sslbprom43.vhd ] || { echo "$ORACLE is not an sslbp-oracle build (no src/sslbprom43.vhd)"; exit 1; }
S=synth_p$PORTS
python3 prep_synth.py src "$S"
cp tb/srl16e_sim.vhd "$S"/
( cd "$S" && rm -rf work && mkdir work &&
  for f in log2 decodedstrobe oneofndecode adpram sslbprom43 sslbpram d8o8sqws srl16e_sim uartr8 uartx8 sserialwa; do
    ghdl-llvm -a --std=08 -fsynopsys --workdir=work $f.vhd 2>/dev/null; done
  G="-gPorts=$PORTS -gInterfaceRegs=$PORTS -gBaseClock=100000000 -gNeedCRC8=true"
  ghdl-llvm --synth --std=08 -fsynopsys --workdir=work $G --out=verilog sserialwa > sserialwa_p$PORTS.v 2>/dev/null
  ghdl-llvm --synth --std=08 -fsynopsys --workdir=work $G --out=vhdl sserialwa > sserialwa_p${PORTS}_net.vhd 2>/dev/null )
python3 fix_pmux.py "$S/sserialwa_p$PORTS.v" "$S/sserialwa_p${PORTS}_net.vhd" vl/sserialwa_p${PORTS}_fixed.v
( cd vl && verilator --cc sserialwa_p${PORTS}_fixed.v --top-module sserialwa -Wno-fatal -Wno-lint -Wno-style \
     -O3 --x-assign fast --x-initial fast -CFLAGS "-O2" --build -j 2 -Mdir obj_p$PORTS > build_p$PORTS.log 2>&1 )
echo "$ORACLE/vl/obj_p$PORTS"
