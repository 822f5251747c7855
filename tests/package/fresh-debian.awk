# SPDX-License-Identifier: MIT
# tests/package/test-deb.sh: what a fresh Debian 12 has installed, from this
# machine's dpkg status (stdin): the installed packages of priority required or
# important (debootstrap's base) and every installed package they depend on
# (Depends, Pre-Depends; the first installed alternative, or a provider).
BEGIN { RS = ""; FS = "\n" }
/\nStatus: install ok installed(\n|$)/ {
  name = ""; deps = ""; prio = ""
  for (i = 1; i <= NF; i++) {
    if ($i ~ /^Package: /) name = substr($i, 10)
    else if ($i ~ /^Priority: /) prio = substr($i, 11)
    else if ($i ~ /^(Pre-)?Depends: /) deps = deps "," substr($i, index($i, ":") + 2)
    else if ($i ~ /^Provides: /) {
      n = split(substr($i, 11), p, ",")
      for (j = 1; j <= n; j++) { gsub(/\(.*\)|[ ]/, "", p[j]); if (!(p[j] in provider)) provider[p[j]] = name }
    }
  }
  installed[name] = 1; depends[name] = deps
  if (prio == "required" || prio == "important") want[name] = 1
}
END {
  do {
    added = 0
    for (name in want) {
      n = split(depends[name], d, ",")
      for (j = 1; j <= n; j++) {
        m = split(d[j], alt, "|"); pick = ""
        for (k = 1; k <= m && pick == ""; k++) {
          a = alt[k]; gsub(/\(.*\)|\[.*\]|:any|[ ]/, "", a)
          if (a in installed) pick = a; else if (a in provider) pick = provider[a]
        }
        if (pick != "" && !(pick in want)) { want[pick] = 1; added = 1 }
      }
    }
  } while (added)
  for (name in want) print name
}
