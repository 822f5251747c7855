#!/bin/bash
# SPDX-License-Identifier: MIT
# Regenerates the comparison in docs/sslbp-vs-firmware.md:
#   tools/sslbp-compare/build-oracle-ports.sh ORACLE_DIR 3       # + 3 channels, as on a 7I92 with one 7I77
#   tools/sslbp-compare/run.sh ORACLE_DIR [LBPKIT_BUILD_DIR]     # builds, runs (about 3 min), prints the table
# ORACLE_DIR: a build of the external sslbp-oracle tool (Mesa's SSLBP 43 sources from
# LinuxCNC/hostmot2-firmware under Verilator; not part of this repository; see README.md).
# Logs go to ORACLE_DIR/compare/.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ORACLE=$(cd "${1:?usage: run.sh ORACLE_DIR [LBPKIT_BUILD_DIR]}" && pwd)
LBP=${2:-$HERE/../../build/hH}
OUT=$ORACLE/compare
mkdir -p "$OUT"
PORTS=3 "$HERE/build.sh" "$ORACLE" "$LBP" "$OUT" >/dev/null
PORTS=6 "$HERE/build.sh" "$ORACLE" "$LBP" "$OUT" >/dev/null
"$OUT/sslbp_compare_p3" oracle 1000 > "$OUT/oracle_p3.log"
"$OUT/sslbp_compare_p6" oracle 1000 > "$OUT/oracle_p6.log"
"$OUT/sslbp_compare_p3" lbpkit 1000 > "$OUT/lbpkit.log"
python3 "$HERE/compare.py" "$OUT/oracle_p3.log" "$OUT/lbpkit.log" "$OUT/oracle_p6.log"
