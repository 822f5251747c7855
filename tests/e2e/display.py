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
import os
import subprocess
import sys
import time
import traceback

import linuxcnc

# lbpkit rehearse's driver (apps/lbpkit/rehearse_driver.py), copied beside
# this file by the tests: LinuxCNC as a display sees it.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rehearse_driver import Driver  # noqa: E402


class Display(Driver):
    def __init__(self, args, name):
        super().__init__(args.ini, name)
        self.out = open(args.out, "a", buffering=1)
        self.args = args
        self.name = name
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
        self.t0 = time.monotonic()

    # -- reporting -------------------------------------------------------
    def report(self, step, **fields):
        fields = {"step": step, "t": round(time.monotonic() - self.t0, 3), **fields, **self.extra_report()}
        self.out.write(json.dumps(fields) + "\n")
        print("%s: %s" % (self.name, json.dumps(fields)), flush=True)

    def extra_report(self):
        """Fields every report carries besides its own (none here)."""
        return {}

    # -- LinuxCNC --------------------------------------------------------
    # poll, wait, set_mode, set_state and idle: the driver's.
    def messages_since(self, n):
        return self.messages[n:]

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
            r = subprocess.run(["halcmd", "-i", self.ini_path, "-f", f], capture_output=True, text=True)
            results.append({"file": f, "exit": r.returncode, "output": (r.stdout + r.stderr)[-500:]})
        self.report("postgui", files=results, ok=all(r["exit"] == 0 for r in results))


def run_reporting(d):
    """Runs display `d`'s scenario; an exception is its last step, reported."""
    try:
        d.run()
    except Exception:
        d.report("exception", ok=False, traceback=traceback.format_exc(), messages=d.messages)
        sys.exit(1)
