#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""A headless LinuxCNC display for any configuration, run by `lbpkit linuxcnc --display`.

`linuxcnc` starts it as the [DISPLAY]DISPLAY of the copy `lbpkit linuxcnc`
makes, with `-ini FILE`. Through LinuxCNC's `linuxcnc` Python module, as a
user would through AXIS: the POSTGUI_HALFILEs, E-stop reset and machine on,
home all joints, G53 MDI moves across each axis' travel (a tenth in from
each soft limit, the nearer first, then the middle), a short program of its own about the
middle, each ended by comparing every joint's feedback with LinuxCNC's
command, within one count of its ENCODER_SCALE (a step of its SCALE). It
judges nothing: every step is one JSON line in --out, for
tests/e2e/public_config_test.cpp to assert on; then it exits, and LinuxCNC with
it.

The machine is the one `lbpkit machine --from-config` derived (no control API
here: LinuxCNC's namespace reaches only the card). The operations are the
general display's (display.py), for N joints.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import linuxcnc  # noqa: E402

import display  # noqa: E402


class ConfigDisplay(display.Display):
    def __init__(self, args):  # noqa: D107 - no control API, N joints
        super().__init__(args, "config-display")
        kins = self.ini.find("KINS", "KINEMATICS") or ""
        coordinates = next((w.split("=", 1)[1] for w in kins.split() if w.startswith("coordinates=")),
                           self.ini.find("TRAJ", "COORDINATES") or "XYZ")
        self.letters = [c for c in coordinates.upper() if c.isalpha()]

    def settle_and_compare(self, timeout=10.0):
        """Each joint's feedback against LinuxCNC's command, in counts, once
        all are within one (the PID's integrator takes the last counts) or at
        the timeout."""
        end = time.monotonic() + timeout
        while True:
            self.poll()
            cmd = list(self.s.joint_position[:self.joints])
            fb = list(self.s.joint_actual_position[:self.joints])
            counts = [round((f - c) / u, 3) for f, c, u in zip(fb, cmd, self.unit)]
            ok = all(abs(e) <= 1.0 for e in counts)
            if ok or time.monotonic() > end:
                return {"commanded": cmd, "feedback": fb, "error_counts": counts, "within_one_count": ok}
            time.sleep(0.02)

    def limits(self, letter):
        for section in ("AXIS_%s" % letter, "AXIS_%d" % self.letters.index(letter)):
            lo, hi = self.ini.find(section, "MIN_LIMIT"), self.ini.find(section, "MAX_LIMIT")
            if lo is not None and hi is not None:
                return float(lo), float(hi)
        return None

    def points(self, fractions=(0.1, 0.9, 0.5), nearer_end_first=False):
        """G53 targets at these fractions of each axis' travel. With
        nearer_end_first, the first two (a tenth in from each soft limit) are
        swapped for an axis that stands nearer its upper limit, so that no
        axis crosses its travel once more than it must."""
        axes = [a for i, a in enumerate(self.letters) if a not in self.letters[:i] and self.limits(a)]
        self.poll()
        targets = []
        for n, fraction in enumerate(fractions):
            words = []
            for a in axes:
                lo, hi = self.limits(a)
                here = self.s.position["XYZABCUVW".index(a)]
                f = fractions[1 - n] if nearer_end_first and n < 2 and abs(hi - here) < abs(here - lo) else fraction
                words.append("%s%.4f" % (a, lo + f * (hi - lo)))
            targets.append(" ".join(words))
        return targets

    def timing(self):
        # What the configuration runs with, as lbpkit linuxcnc gave it
        # (docs/linuxcnc.md#on-a-pc-without-a-real-time-kernel): hm2_eth's
        # wait for a reply and the HostMot2 watchdog. Read, never changed:
        # the test runs what a user runs.
        params = subprocess.run(["halcmd", "list", "param"], capture_output=True, text=True).stdout.split()
        values = {}
        for n in params:
            if n.endswith(".packet-read-timeout") or n.endswith(".watchdog.timeout_ns"):
                got = subprocess.run(["halcmd", "getp", n], capture_output=True, text=True)
                values[n] = got.stdout.strip()
        self.report("timing", values=values, ok=bool(values))

    def run(self):
        self.wait(lambda: self.s.task_state != 0, 10)
        self.timing()
        self.postgui()
        self.start_up()
        self.home()
        for target in self.points(nearer_end_first=True):
            n = len(self.messages)
            command = "G53 G0 " + target
            ok = self.mdi(command, timeout=120)
            self.report("mdi", command=command, ok=ok, task_state=self.s.task_state,
                        messages=self.messages_since(n), **self.settle_and_compare())
        self.program()
        self.report("finished", all_messages=self.messages)

    def start_up(self):
        n = len(self.messages)
        # Out of E-stop: a configuration may turn the machine on by itself
        # then (a panel's maintained machine-on switch into halui.machine.on).
        self.c.state(linuxcnc.STATE_ESTOP_RESET)
        self.c.wait_complete(5)
        ok_reset = self.wait(lambda: self.s.task_state in (linuxcnc.STATE_ESTOP_RESET, linuxcnc.STATE_ON), 5)
        ok_on = self.set_state(linuxcnc.STATE_ON)
        self.report("machine_on", ok=ok_reset and ok_on, estop_reset=ok_reset, on=ok_on,
                    task_state=self.s.task_state, messages=self.messages_since(n))

    def home(self):
        n = len(self.messages)
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        started = time.monotonic()
        j = range(self.joints)
        ok = self.home_all()
        took = time.monotonic() - started
        self.wait(self.idle, 5)
        self.report("home", ok=ok, seconds=round(took, 2), homed=[bool(self.s.homed[k]) for k in j],
                    messages=self.messages_since(n), **self.settle_and_compare())

    def program(self):
        n = len(self.messages)
        # Around the middle of the travel, at most 0.8 of each axis' speed.
        points = self.points((0.4, 0.6, 0.5))
        text = "G90 G21\n" if (self.ini.find("TRAJ", "LINEAR_UNITS") or "mm") in ("mm", "metric") else "G90 G20\n"
        text += "".join("G53 G1 %s F%s\n" % (p, self.feed()) for p in points) + "M2\n"
        fd, path = tempfile.mkstemp(suffix=".ngc")
        with os.fdopen(fd, "w") as f:
            f.write(text)
        if not self.set_mode(linuxcnc.MODE_AUTO):
            self.report("program", ok=False, why="no auto mode", messages=self.messages_since(n))
            return
        self.c.program_open(path)
        self.c.wait_complete()
        started = time.monotonic()
        self.c.auto(linuxcnc.AUTO_RUN, 0)
        self.wait(lambda: self.s.interp_state != linuxcnc.INTERP_IDLE, 5)
        self.wait(lambda: self.s.interp_state == linuxcnc.INTERP_IDLE or self.s.task_state != linuxcnc.STATE_ON, 240)
        finished = self.s.interp_state == linuxcnc.INTERP_IDLE and self.s.task_state == linuxcnc.STATE_ON
        self.wait(self.idle, 5)
        self.report("program", ok=finished, seconds=round(time.monotonic() - started, 2), gcode=text,
                    messages=self.messages_since(n), **self.settle_and_compare())

    def feed(self):
        """0.8 of the slowest axis' MAX_VELOCITY, per minute."""
        speeds = []
        for a in set(self.letters):
            v = self.ini.find("AXIS_%s" % a, "MAX_VELOCITY")
            if v:
                speeds.append(float(v))
        return "%.1f" % (48.0 * min(speeds or [10.0]))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-ini", required=True)
    p.add_argument("--out", required=True, help="results, one JSON object a line")
    display.run_reporting(ConfigDisplay(p.parse_args()))


if __name__ == "__main__":
    main()
