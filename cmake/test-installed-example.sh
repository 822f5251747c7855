#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# ctest InstalledExample: install lbpkit from a build tree, build
# examples/cycle against the installed files alone, three ways (CMake
# find_package with lbpkit::host, the shared library; CMake with
# lbpkit::host_static; pkg-config lbpkit), and run each for a few cycles
# against `lbpkit sim` on a loopback address of its own. Everything it makes
# stays in the build tree.
#
#   test-installed-example.sh CMAKE BUILD_DIR SOURCE_DIR LBPKIT_BINARY CXX BUILD_TYPE LAUNCHER CXX_FLAGS
set -euo pipefail
cmake=$1 build=$2 source=$3 lbpkit=$4 cxx=$5 build_type=$6 launcher=$7 flags=$8
prefix=$build/install
example=$build/example

echo "== install to $prefix"
rm -rf "$prefix" "$example"
"$cmake" --install "$build" --prefix "$prefix" >/dev/null
# Only what is public: the tool with its man page and bash completion, the
# library (shared and static, headers), its CMake package and lbpkit.pc, the
# Python module, and the licences (share/doc/lbpkit/copyright).
unexpected=$(cd "$prefix" && find . \( -type f -o -type l \) ! -path './include/lbpkit/*.hpp' \
             ! -path './lib*/liblbpkit_wire.a' ! -path './lib*/liblbpkit_host.a' ! -path './lib*/liblbpkit_host.so*' \
             ! -path './lib*/cmake/lbpkit/*.cmake' ! -path './lib*/pkgconfig/lbpkit.pc' ! -path ./bin/lbpkit \
             ! -path ./share/man/man1/lbpkit.1.gz ! -path ./share/bash-completion/completions/lbpkit \
             ! -path ./share/doc/lbpkit/copyright \
             ! -path './lib/python3/dist-packages/lbpkit/*')
if [[ -n $unexpected ]]; then
  echo "installed files that are not public:"; echo "$unexpected"; exit 1
fi
libdir=$(dirname "$(find "$prefix" -name liblbpkit_host.so)")
soname=$(readelf -d "$libdir/liblbpkit_host.so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[[ $soname == liblbpkit_host.so.* ]] || { echo "liblbpkit_host.so has no SONAME"; exit 1; }

echo "== build examples/cycle against it: CMake (shared, static), pkg-config"
for kind in shared static; do
  static=OFF
  [[ $kind == static ]] && static=ON
  "$cmake" -S "$source/examples/cycle" -B "$example/$kind" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_COMPILER="$cxx" \
        -DCMAKE_BUILD_TYPE="$build_type" -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DCMAKE_CXX_FLAGS="$flags" \
        -DCYCLE_STATIC=$static -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON >/dev/null
  "$cmake" --build "$example/$kind"
done
pc_dir=$(dirname "$(find "$prefix" -name lbpkit.pc)")
# shellcheck disable=SC2046,SC2086  # flags are words
$launcher "$cxx" -std=c++20 -O2 $flags "$source/examples/cycle/cycle.cpp" \
  $(PKG_CONFIG_LIBDIR=$pc_dir pkg-config --cflags --libs lbpkit) -o "$example/cycle-pkgconfig"
# The shared builds load the installed library, the static one nothing of ours.
needs() { grep -q "(NEEDED).*\[$soname\]" <<<"$(readelf -d "$1")"; }
needs "$example/shared/cycle" || { echo "the CMake build with lbpkit::host does not load $soname"; exit 1; }
needs "$example/cycle-pkgconfig" || { echo "the pkg-config build does not load $soname"; exit 1; }
if needs "$example/static/cycle"; then echo "the build with lbpkit::host_static loads $soname"; exit 1; fi

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
# The log exists before the sim starts: the shell opens the redirection in
# the forked child, and the loop below may read before that child has run.
: >"$tmp/sim.log"
"$lbpkit" sim --bind "$address:0" --no-api --demo --no-realtime --state "$tmp/eeprom" >>"$tmp/sim.log" 2>&1 &
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
for program in "$example/shared/cycle" "$example/static/cycle" "$example/cycle-pkgconfig"; do
  echo "== ${program#"$example/"}"
  status=0
  # The pkg-config build has no run path: it finds the library as a user's
  # program finds one outside the system's folders. The CMake one has.
  search=()
  [[ $program == *pkgconfig ]] && search=("LD_LIBRARY_PATH=$libdir")
  env "${search[@]}" timeout 30 "$program" "$address:$port" 300 500 | tee "$tmp/out" || status=$?
  if ((status != 0)); then
    echo "$program failed (exit $status); lbpkit sim said:"; cat "$tmp/sim.log"; exit 1
  fi
  grep -q "channel 0: 7I77 field I/O" "$tmp/out" || { echo "no 7I77 field I/O found"; exit 1; }
  # Input 0 follows output 0 through the demo wiring: an odd last hex digit.
  grep -Eq "output 0 on, inputs 0x[0-9a-f]*[13579bdf]$" "$tmp/out" ||
    { echo "input 0 never followed output 0"; exit 1; }
done
echo "InstalledExample: passed"
