#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""What every headless LinuxCNC display of the end-to-end tests shares.

A display is a configuration's [DISPLAY]DISPLAY, started by `linuxcnc` with
`-ini FILE`. It operates LinuxCNC through its `linuxcnc` Python module
(command, stat, error_channel) as a user would through AXIS, judges nothing,
and writes each step as one JSON line to --out for the C++ test to assert
on. `Display` is the general one: any configuration, N joints, one count of
each joint's feedback from its INI. mill_display.py (the example mill, with
the sim's control API) and config_display.py (any configuration, headless)
build on it.

Runs under the /usr/bin/python3 that has LinuxCNC's module (Debian's, or
another release's in its root).
"""
import json
import subprocess
import sys
import time
import traceback

import hal
import linuxcnc


class Display:
    def __init__(self, args, name):
        self.out = open(args.out, "a", buffering=1)
        self.args = args
        self.name = name
        self.ini = linuxcnc.ini(args.ini)
        self.joints = int(float(self.ini.find("KINS", "JOINTS") or self.ini.find("TRAJ", "AXES") or 3))
        # One count of each joint's feedback: an encoder count on a servo
        # joint (ENCODER_SCALE), a step on a stepper joint (SCALE).
        self.unit = []
        for j in range(self.joints):
            scale = None
            for section in ("JOINT_%d" % j, "AXIS_%d" % j):
                scale = self.ini.find(section, "ENCODER_SCALE") or self.ini.find(section, "SCALE")
                if scale:
                    break
            self.unit.append(1.0 / abs(float(scale or 1.0)))
        self.s = linuxcnc.stat()
        self.c = linuxcnc.command()
        self.e = linuxcnc.error_channel()
        self.messages = []  # every error/message LinuxCNC sent, in order
        self.t0 = time.monotonic()
        # A HAL component of its own, so that hal.get_value can read pins.
        self.halcomp = hal.component(name)
        self.halcomp.ready()

    # -- reporting -------------------------------------------------------
    def report(self, step, **fields):
        fields = {"step": step, "t": round(time.monotonic() - self.t0, 3), **fields, **self.extra_report()}
        self.out.write(json.dumps(fields) + "\n")
        print("%s: %s" % (self.name, json.dumps(fields)), flush=True)

    def extra_report(self):
        """Fields every report carries besides its own (none here)."""
        return {}

    # -- LinuxCNC --------------------------------------------------------
    def poll(self):
        self.s.poll()
        while True:
            m = self.e.poll()
            if not m:
                break
            self.messages.append(m[1].strip())

    def wait(self, predicate, timeout, period=0.005):
        """Polls LinuxCNC until predicate() holds; False after timeout s."""
        end = time.monotonic() + timeout
        while True:
            self.poll()
            if predicate():
                return True
            if time.monotonic() > end:
                return False
            time.sleep(period)

    def messages_since(self, n):
        return self.messages[n:]

    def set_mode(self, mode):
        self.poll()
        if self.s.task_mode != mode:
            self.c.mode(mode)
            self.c.wait_complete(5)
        return self.wait(lambda: self.s.task_mode == mode, 5)

    def set_state(self, state, timeout=5):
        self.c.state(state)
        self.c.wait_complete(timeout)
        return self.wait(lambda: self.s.task_state == state, timeout)

    def idle(self):
        return (self.s.interp_state == linuxcnc.INTERP_IDLE and self.s.inpos and self.s.queue == 0
                and self.s.state != linuxcnc.RCS_EXEC)

    def mdi(self, command, timeout=30):
        if not self.set_mode(linuxcnc.MODE_MDI):
            return False
        self.c.mdi(command)
        self.c.wait_complete(timeout)
        return self.wait(self.idle, timeout)

    def commanded(self):
        self.poll()
        return list(self.s.joint_position[:self.joints])

    def postgui(self):
        # As AXIS does once its window is up: the POSTGUI_HALFILEs.
        files = self.ini.findall("HAL", "POSTGUI_HALFILE") or []
        results = []
        for f in files:
            r = subprocess.run(["halcmd", "-i", self.ini_path(), "-f", f], capture_output=True, text=True)
            results.append({"file": f, "exit": r.returncode, "output": (r.stdout + r.stderr)[-500:]})
        self.report("postgui", files=results, ok=all(r["exit"] == 0 for r in results))

    def ini_path(self):
        return sys.argv[sys.argv.index("-ini") + 1]


def run_reporting(d):
    """Runs display `d`'s scenario; an exception is its last step, reported."""
    try:
        d.run()
    except Exception:
        d.report("exception", ok=False, traceback=traceback.format_exc(), messages=d.messages)
        sys.exit(1)
