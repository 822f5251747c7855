#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Turns sslbp_compare logs into the markdown table of docs/sslbp-vs-firmware.md.
   compare.py ORACLE_LOG LBPKIT_LOG [ORACLE6_LOG]
Rows pair the logs' OP lines in order (both ran the same host code). Verdict: "same" when every
register value matches and the duration is within 3 % (or 3 us); otherwise what differs."""
import re
import sys


def ops(path):
    out = []
    for line in open(path):
        if not line.startswith("OP "):
            continue
        name, dur, rest = (x.strip() for x in line[3:].split("|", 2))
        out.append((name, int(dur.split()[0]), rest))
    return out


def fmt_dur(ns):
    if ns < 0:
        return ""
    if ns >= 1_000_000:
        return "%.3f ms" % (ns / 1e6)
    return "%.2f us" % (ns / 1e3)


def compact(regs):
    regs = regs.replace("IF=00000000,00000000,00000000", "IF=0")
    regs = re.sub(r"mean=[\d.]+us max=[\d.]+us ", "", regs)
    regs = re.sub(r"min=[\d.]+us mean=[\d.]+us max=[\d.]+us ", "", regs)
    regs = re.sub(r" \| PTOC .*", " (names identical)", regs) if "PTOC" in regs else regs
    return regs.replace("|", "/")


def mean(regs):
    m = re.search(r"mean=([\d.]+)us", regs)
    return float(m.group(1)) * 1000 if m else None


def main():
    real, lbp = ops(sys.argv[1]), ops(sys.argv[2])
    real6 = ops(sys.argv[3]) if len(sys.argv) > 3 else None
    print("| operation | real SSLBP 43 (3 channels) | lbpkit | verdict |")
    print("| --- | --- | --- | --- |")
    for i, ((name, dr, rr), (_, dl, rl)) in enumerate(zip(real, lbp)):
        a, b = mean(rr), mean(rl)
        cr = re.sub(r"(mean|min|max)=[\d.]+us ?", "", rr)
        cl = re.sub(r"(mean|min|max)=[\d.]+us ?", "", rl)
        notes = []
        if cr != cl:
            notes.append("values differ")
        if a and b:
            dr_, dl_ = a, b
        else:
            dr_, dl_ = dr, dl
        if dr_ >= 0 and dl_ >= 0 and dr_ > 0:
            rel = (dl_ - dr_) / dr_
            if abs(rel) > 0.03 and abs(dl_ - dr_) > 3000:
                notes.append("duration %+.1f %%" % (100 * rel))
            elif dr_ != dl_:
                notes.append("Δt %+.1f %%" % (100 * rel))
        verdict = "same" if not notes or notes[0].startswith("Δt") else "**differs**"
        if notes:
            verdict += " (" + ", ".join(notes) + ")"
        tr = fmt_dur(dr) + (" (mean %.2f us)" % (a / 1000) if a else "")
        tl = fmt_dur(dl) + (" (mean %.2f us)" % (b / 1000) if b else "")
        extra = ""
        if real6 and i < len(real6) and real6[i][2] != rr:
            extra = "; 6-channel build: " + compact(real6[i][2])
        print("| %s | %s %s%s | %s %s | %s |" % (name, tr, compact(rr), extra, tl, compact(rl), verdict))


main()
