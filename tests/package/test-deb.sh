#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# ctest PackageDeb: build lbpkit_<version>_amd64.deb with CPack from a built
# tree, and check it as `apt install ./lbpkit_<version>_amd64.deb` on a fresh
# Debian 12 would meet it, without installing anything on this machine and
# without the network:
#   1. its control fields and its files (tool, man page, bash completion,
#      shared and static library, headers, CMake package, lbpkit.pc);
#   2. apt's resolver, simulating (-s) the install on a fresh Debian 12: a
#      dpkg status holding only the packages every Debian 12 has (priority
#      required and important), apt's package lists as they are here; it must
#      find every dependency in the archive and install nothing else broken;
#   3. dpkg --root into a throwaway root under the build tree (its maintainer
#      scripts run chrooted there, with a shell and ldconfig), whose status is
#      that fresh system plus what apt chose: dpkg checks Depends itself, and
#      every library each ELF file in the package loads must come from the
#      package or a package in that root (so Depends is sufficient);
#   4. the installed files at work: `lbpkit --version`, the man page rendered
#      without a warning and naming every command, the bash completion
#      (sourced, its function called), the example built against the root's
#      library both ways (CMake find_package, pkg-config) and its SONAME;
#   5. dpkg --purge leaves the root as it was.
#
#   test-deb.sh CPACK BUILD_DIR SOURCE_DIR VERSION CXX [LAUNCHER]
set -euo pipefail
cpack=$1 build=$2 source=$3 version=$4 cxx=$5 launcher=${6:-}
work=$build/package-test
deb=$work/lbpkit_${version}_amd64.deb
root=$work/root
fail() { echo "PackageDeb: $*" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"

echo "== cpack -G DEB"
"$cpack" --config "$build/CPackConfig.cmake" -G DEB -B "$work" >"$work/cpack.log" 2>&1 ||
  { cat "$work/cpack.log"; fail "cpack failed"; }
[[ -f $deb ]] || { cat "$work/cpack.log"; fail "no $deb"; }
rm -rf "$work/_CPack_Packages"

echo "== control fields"
dpkg-deb --field "$deb" Package Version Architecture Maintainer Depends Section
field() { dpkg-deb --field "$deb" "$1"; }
[[ $(field Package) == lbpkit ]] || fail "Package is not lbpkit"
[[ $(field Version) == "$version" ]] || fail "Version $(field Version) is not $version"
[[ $(field Architecture) == amd64 ]] || fail "Architecture is not amd64"
depends=$(field Depends)
for needed in libc6 libstdc++6 libgcc-s1 libfmt9; do
  [[ ", $depends," == *", $needed "* || ", $depends," == *", $needed,"* ]] || fail "Depends lacks $needed: $depends"
done

echo "== files"
dpkg-deb --contents "$deb" | awk '{ print $6 $7 $8 }' | sed 's|^\./|/|' >"$work/contents"
has() { grep -Eq "$1" "$work/contents" || fail "the package has no file matching $1"; }
has '^/usr/bin/lbpkit$'
has '^/usr/share/man/man1/lbpkit\.1\.gz$'
has '^/usr/share/bash-completion/completions/lbpkit$'
has '^/usr/share/doc/lbpkit/copyright$'
has "^/usr/lib/(.*/)?liblbpkit_host\.so\.${version//./\\.}$"
has '^/usr/lib/(.*/)?liblbpkit_host\.so->liblbpkit_host\.so\.[0-9]+\.[0-9]+$'
has '^/usr/lib/(.*/)?liblbpkit_host\.a$'
has '^/usr/lib/(.*/)?liblbpkit_wire\.a$'
has '^/usr/include/lbpkit/sserial\.hpp$'
has '^/usr/include/lbpkit/wire/'
has '^/usr/lib/(.*/)?cmake/lbpkit/lbpkitConfig\.cmake$'
has '^/usr/lib/(.*/)?pkgconfig/lbpkit\.pc$'
# The models, servers and adapters are internal.
if grep -E 'lbpkit_(models|servers|config|sim_adapter|hal|web)|/src/' "$work/contents"; then
  fail "the package has internal files"
fi

echo "== apt install ./$(basename "$deb") on a fresh Debian 12 (apt-get --simulate)"
compgen -G '/var/lib/apt/lists/*_Packages*' >/dev/null ||
  fail "apt has no package lists here (apt-get update once, as scripts/deps does)"
# A fresh Debian 12: what every installation has (priority required and
# important, and what they depend on), as this machine's dpkg knows them.
# status_of FILE-OF-NAMES: those packages' entries in this machine's status.
status_of() {
  # The names a line each, then the status a paragraph each (RS=).
  awk -v ORS='\n\n' 'NR == FNR { want["Package: " $0] = 1; next }
    /\nStatus: install ok installed(\n|$)/ { split($0, line, "\n"); if (line[1] in want) print }' \
    "$1" RS= /var/lib/dpkg/status
}
awk -f "$(dirname "$0")/fresh-debian.awk" /var/lib/dpkg/status >"$work/fresh-packages"
status_of "$work/fresh-packages" >"$work/status-fresh"
(($(grep -c '^Package: ' "$work/status-fresh") > 50)) || fail "a fresh Debian 12 of only $(grep -c '^Package: ' "$work/status-fresh") packages"
apt_sim=(apt-get --simulate --no-install-recommends -o Dir::State::status="$work/status-fresh"
         -o Dir::Cache="$work/apt-cache" -o Dir::Cache::pkgcache= -o Dir::Cache::srcpkgcache=
         -o Debug::NoLocking=true -o APT::Get::AllowUnauthenticated=false)
mkdir -p "$work/apt-cache/archives/partial"
"${apt_sim[@]}" install "$deb" >"$work/apt.log" 2>&1 || { cat "$work/apt.log"; fail "apt cannot install it on a fresh Debian 12"; }
grep -q "^Inst lbpkit " "$work/apt.log" || { cat "$work/apt.log"; fail "apt would not install lbpkit"; }
grep '^Inst ' "$work/apt.log" | awk '{ print $2 }' >"$work/apt-installs"
echo "apt would install: $(tr '\n' ' ' <"$work/apt-installs")"

echo "== dpkg --root $root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/var/lib/dpkg/triggers"
touch "$root/var/lib/dpkg/available"
# The fresh system plus what apt chose besides lbpkit (their entries from this
# machine's dpkg, where the build put them).
cp "$work/status-fresh" "$root/var/lib/dpkg/status"
grep -vx lbpkit "$work/apt-installs" >"$work/apt-others" || true
status_of "$work/apt-others" >>"$root/var/lib/dpkg/status"
(($(grep -c '^Package: ' "$root/var/lib/dpkg/status") == $(wc -l <"$work/fresh-packages") + $(wc -l <"$work/apt-others"))) ||
  fail "apt chose packages this machine does not have installed to stand in for them: $(tr '\n' ' ' <"$work/apt-others")"
# The maintainer scripts (CPack's: ldconfig after installing and removing
# the shared library) run chrooted into the root: give it a shell and
# ldconfig (static), the only programs they call.
for program in /bin/sh /sbin/ldconfig $(ldd "$(realpath /bin/sh)" | grep -o '/[^ ]*'); do
  mkdir -p "$root$(dirname "$program")"
  cp -L "$program" "$root$program"
done
mkdir -p "$root/etc"
find "$root" ! -type d | sort >"$work/root-before"
dpkg --root="$root" --log="$work/dpkg.log" --no-triggers -i "$deb" >"$work/dpkg-i.log" 2>&1 ||
  { cat "$work/dpkg-i.log"; fail "dpkg -i into the throwaway root failed"; }
dpkg --root="$root" --log="$work/dpkg.log" --no-triggers --configure --pending >/dev/null
[[ $(dpkg-query --root="$root" -W -f='${Status} ${Version}' lbpkit) == "install ok installed $version" ]] ||
  fail "lbpkit is not installed in the root: $(dpkg-query --root="$root" -W -f='${Status}' lbpkit)"

echo "== every library each ELF file loads comes from a package in the root"
libdir=$(dirname "$(find "$root/usr/lib" -name 'liblbpkit_host.so' -print -quit)")
soname=$(readelf -d "$libdir/liblbpkit_host.so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[[ $soname == "liblbpkit_host.so.$(cut -d. -f1,2 <<<"$version")" ]] || fail "SONAME is '$soname'"
awk '/^Package:/ { print $2 }' "$root/var/lib/dpkg/status" | sort -u >"$work/root-packages"
checked=0
while read -r elf; do
  for lib in $(readelf -d "$elf" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    [[ $lib == "$soname" ]] && continue
    # (awk reads to the end: with pipefail an early exit could fail ldconfig)
    path=$(ldconfig -p | awk -v l="$lib" '$1 == l && /x86-64/ && !found++ { print $NF }')
    [[ -n $path ]] || fail "${elf#"$root"} needs $lib, which this machine does not have"
    owner=$(dpkg -S "$(realpath "$path")" 2>/dev/null | sed -n '1s/:.*//p') ||
      owner=$(dpkg -S "$path" 2>/dev/null | sed -n '1s/:.*//p') || true
    [[ -n $owner ]] || fail "no package owns $path (${elf#"$root"} needs it)"
    grep -qx "$owner" "$work/root-packages" ||
      fail "${elf#"$root"} needs $lib from $owner, which Depends does not bring: $depends"
    echo "  ${elf#"$root"}: $lib ($owner)"
    checked=$((checked + 1))
  done
done < <(find "$root/usr" -type f -exec sh -c 'head -c 4 "$1" | grep -q "ELF"' _ {} \; -print)
((checked > 0)) || fail "found no ELF file's libraries to check"

echo "== lbpkit --version, the man page, bash completion"
lbpkit=$root/usr/bin/lbpkit
[[ $("$lbpkit" --version) == "lbpkit $version" ]] || fail "lbpkit --version says '$("$lbpkit" --version)'"
commands=$("$lbpkit" --help | awk '/^Subcommands:/ { on = 1; next } on && /^  [^ ]/ { print $1 }')
[[ -n $commands ]] || fail "lbpkit --help lists no commands"
page=$(LC_ALL=C.UTF-8 MANWIDTH=80 man --warnings -l "$root/usr/share/man/man1/lbpkit.1.gz" 2>"$work/man.err")
[[ ! -s $work/man.err ]] || { cat "$work/man.err"; fail "the man page has warnings"; }
grep -q "lbpkit $version" <<<"$page" || fail "the man page does not name version $version"
for command in $commands; do
  grep -Eq "^   lbpkit $command\$" <<<"$page" || fail "the man page has no section for lbpkit $command"
done
grep -q -- "--bind" <<<"$page" || fail "the man page lacks lbpkit sim's --bind"
completed=$(PATH="$root/usr/bin:$PATH" bash -c '
  source "$1"
  complete() { COMP_WORDS=("$@"); COMP_CWORD=$((${#COMP_WORDS[@]} - 1)); _lbpkit; echo "${COMPREPLY[*]}"; }
  complete lbpkit ""; complete lbpkit s; complete lbpkit sim --b; complete lbpkit --v; complete lbpkit fault li
' _ "$root/usr/share/bash-completion/completions/lbpkit")
expected="$(tr '\n' ' ' <<<"$commands" | sed 's/ $//')
sim
--bind
--version
link"
[[ $completed == "$expected" ]] || fail "bash completion gave
$completed
where it should give
$expected"

echo "== examples/cycle against the root's library: pkg-config, then CMake"
pcdir=$(dirname "$(find "$root/usr/lib" -name lbpkit.pc)")
flags=$(PKG_CONFIG_PATH=$pcdir PKG_CONFIG_LIBDIR=$pcdir pkg-config --cflags --libs lbpkit)
[[ $(PKG_CONFIG_LIBDIR=$pcdir pkg-config --modversion lbpkit) == "$version" ]] || fail "lbpkit.pc's version"
# shellcheck disable=SC2086  # the flags are words
$launcher "$cxx" -std=c++20 -O1 -Wall -Wextra -Werror "$source/examples/cycle/cycle.cpp" $flags -o "$work/cycle-pkgconfig"
grep -q "NEEDED.*\[$soname\]" <<<"$(readelf -d "$work/cycle-pkgconfig")" || fail "cycle-pkgconfig does not load $soname"
cmake -S "$source/examples/cycle" -B "$work/cycle-cmake" -DCMAKE_PREFIX_PATH="$root/usr" -DCMAKE_CXX_COMPILER="$cxx" \
      -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON \
      -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF >"$work/cmake.log" || { cat "$work/cmake.log"; fail "cmake"; }
cmake --build "$work/cycle-cmake" >"$work/cmake-build.log" || { cat "$work/cmake-build.log"; fail "build"; }
grep -q "NEEDED.*\[$soname\]" <<<"$(readelf -d "$work/cycle-cmake/cycle")" || fail "the CMake build does not load $soname"
for program in "$work/cycle-pkgconfig" "$work/cycle-cmake/cycle"; do
  # Loaded from the root (the library is nowhere else): it prints its usage.
  status=0
  LD_LIBRARY_PATH=$libdir "$program" >/dev/null 2>"$work/usage" || status=$?
  ((status == 2)) && grep -q "usage:" "$work/usage" || fail "$program did not run ($status): $(cat "$work/usage")"
  # (grep -q on a pipe would stop ldd early: pipefail)
  grep -q "$soname => $libdir/" <<<"$(LD_LIBRARY_PATH=$libdir ldd "$program")" || fail "$program did not load the root's library"
done

echo "== dpkg --purge"
dpkg --root="$root" --log="$work/dpkg.log" --no-triggers --purge lbpkit >/dev/null
[[ -s $root/etc/ld.so.cache ]] || fail "the package's ldconfig did not run"
left=$(find "$root" -path "$root/var" -prune -o -path "$root/etc/ld.so.cache" -prune -o ! -type d -print | sort |
       comm -13 "$work/root-before" -)
[[ -z $left ]] || fail "files left after purge: $left"
rm -rf "$root" "$work/cycle-cmake" "$work/apt-cache"
echo "PackageDeb: passed ($(basename "$deb"), $(du -k "$deb" | cut -f1) KiB; Depends: $depends)"
