#!/usr/bin/env bash
# ctest InstalledExample: install lbpkit from a build tree, build
# examples/cycle against the installed package alone (find_package(lbpkit),
# lbpkit::host), and run it for a few cycles against `lbpkit sim` on a
# loopback address of its own. Everything it makes stays in the build tree.
#
#   test-installed-example.sh CMAKE BUILD_DIR SOURCE_DIR LBPKIT_BINARY CXX BUILD_TYPE LAUNCHER CXX_FLAGS
set -euo pipefail
cmake=$1 build=$2 source=$3 lbpkit=$4 cxx=$5 build_type=$6 launcher=$7 flags=$8
prefix=$build/install
example=$build/example

echo "== install to $prefix"
rm -rf "$prefix"
"$cmake" --install "$build" --prefix "$prefix" >/dev/null
# Only the public API: the two libraries, their headers, the package.
unexpected=$(cd "$prefix" && find . -type f ! -path './include/lbpkit/*.hpp' ! -path './lib*/liblbpkit_wire.a' \
             ! -path './lib*/liblbpkit_host.a' ! -path './lib*/cmake/lbpkit/*.cmake')
if [[ -n $unexpected ]]; then
  echo "installed files that are not the public API:"; echo "$unexpected"; exit 1
fi

echo "== build examples/cycle against it"
"$cmake" -S "$source/examples/cycle" -B "$example" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_COMPILER="$cxx" \
      -DCMAKE_BUILD_TYPE="$build_type" -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DCMAKE_CXX_FLAGS="$flags" \
      -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON >/dev/null
"$cmake" --build "$example"

echo "== run it against lbpkit sim --demo"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/lbpkit-example.XXXXXX")
sim_pid=""
cleanup() {
  if [[ -n $sim_pid ]]; then
    kill "$sim_pid" 2>/dev/null || true
    wait "$sim_pid" 2>/dev/null || true
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT
address=127.79.$(($$ % 200)).1
"$lbpkit" sim --bind "$address:0" --no-api --demo --no-realtime --state "$tmp/eeprom" >"$tmp/sim.log" 2>&1 &
sim_pid=$!
port=""
for _ in $(seq 100); do  # the banner names the port it got
  port=$(sed -n "s/.* on UDP $address:\([0-9]*\).*/\1/p" "$tmp/sim.log")
  [[ -n $port ]] && break
  kill -0 "$sim_pid" 2>/dev/null || break
  sleep 0.1
done
if [[ -z $port ]]; then
  echo "lbpkit sim did not start:"; cat "$tmp/sim.log"; exit 1
fi
status=0
timeout 30 "$example/cycle" "$address:$port" 300 500 | tee "$tmp/out" || status=$?
if ((status != 0)); then
  echo "examples/cycle failed (exit $status); lbpkit sim said:"; cat "$tmp/sim.log"; exit 1
fi
grep -q "channel 0: 7I77 field I/O" "$tmp/out" || { echo "no 7I77 field I/O found"; exit 1; }
# Input 0 follows output 0 through the demo wiring: an odd last hex digit.
grep -Eq "output 0 on, inputs 0x[0-9a-f]*[13579bdf]$" "$tmp/out" ||
  { echo "input 0 never followed output 0"; exit 1; }
echo "InstalledExample: passed"
