#!/bin/bash
# Regenerates the comparison in docs/sslbp-vs-firmware.md:
#   /work/shared/tools/sslbp-oracle/reproduce.sh /tmp/sslbp-oracle     # the oracle, 6 channels (2-5 min)
#   tools/sslbp-compare/build-oracle-ports.sh /tmp/sslbp-oracle 3      # + 3 channels, as on a 7I92 with one 7I77
#   tools/sslbp-compare/run.sh /tmp/sslbp-oracle [LBPKIT_BUILD_DIR]    # builds, runs (about 30 s), prints the table
# Logs go to ORACLE_BUILD_DIR/compare/.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ORACLE=$(cd "${1:?usage: run.sh ORACLE_BUILD_DIR [LBPKIT_BUILD_DIR]}" && pwd)
LBP=${2:-$HERE/../../build/hH}
OUT=$ORACLE/compare
mkdir -p "$OUT"
PORTS=3 "$HERE/build.sh" "$ORACLE" "$LBP" "$OUT" >/dev/null
PORTS=6 "$HERE/build.sh" "$ORACLE" "$LBP" "$OUT" >/dev/null
"$OUT/sslbp_compare_p3" oracle 1000 > "$OUT/oracle_p3.log"
"$OUT/sslbp_compare_p6" oracle 1000 > "$OUT/oracle_p6.log"
"$OUT/sslbp_compare_p3" lbpkit 1000 > "$OUT/lbpkit.log"
python3 "$HERE/compare.py" "$OUT/oracle_p3.log" "$OUT/lbpkit.log" "$OUT/oracle_p6.log"
