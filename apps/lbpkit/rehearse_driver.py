#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""lbpkit rehearse's hands inside LinuxCNC: a headless display.

`lbpkit rehearse` runs the configuration with `lbpkit linuxcnc`, this file
as its [DISPLAY]DISPLAY (written by lbpkit, from the copy compiled into it,
to a folder of root's). LinuxCNC starts it with `-ini FILE`; it then
operates the machine through LinuxCNC's `linuxcnc` Python module as an
operator does through AXIS, one request at a time: each request is a JSON
line read from --requests (a FIFO), each answer a JSON line written to
--answers (another). It judges nothing: lbpkit rehearse decides what to ask
and what the answers and the machine (the sim's control API) mean.

Every answer has "ok" and "messages": what LinuxCNC's error channel said
since the last answer (following errors, limit switches, E-stop...).
"quit" ends it, and LinuxCNC with it.

Runs under Debian's /usr/bin/python3, where linuxcnc-uspace puts the module.
"""
import argparse
import json
import subprocess
import sys
import time
import traceback

import hal
import linuxcnc


class Driver:
    """LinuxCNC as a display sees it: its stat, command and error channel,
    the INI, and the operations an operator makes through AXIS. The requests
    lbpkit rehearse sends are its op_* methods. tests/e2e/display.py builds
    the end-to-end tests' displays on it."""

    def __init__(self, ini_path, name="lbpkit-rehearse"):
        self.ini_path = ini_path
        self.ini = linuxcnc.ini(ini_path)
        self.s = linuxcnc.stat()
        self.c = linuxcnc.command()
        self.e = linuxcnc.error_channel()
        self.messages = []
        # A HAL component of its own, so that hal.get_value reads pins.
        self.halcomp = hal.component(name)
        self.halcomp.ready()
        self.joints = int(float(self.ini.find("KINS", "JOINTS") or self.ini.find("TRAJ", "AXES") or 3))
        kins = self.ini.find("KINS", "KINEMATICS") or ""
        coordinates = next((w.split("=", 1)[1] for w in kins.split() if w.startswith("coordinates=")),
                           self.ini.find("TRAJ", "COORDINATES") or "XYZ")
        self.letters = [ch.upper() for ch in coordinates if ch.isalpha()][: self.joints]

    # -- LinuxCNC ---------------------------------------------------------
    def poll(self):
        self.s.poll()
        while True:
            m = self.e.poll()
            if not m:
                break
            self.messages.append(m[1].strip())

    def wait(self, predicate, timeout, period=0.005):
        end = time.monotonic() + timeout
        while True:
            self.poll()
            if predicate():
                return True
            if time.monotonic() > end:
                return False
            time.sleep(period)

    def set_mode(self, mode):
        self.poll()
        if self.s.task_mode != mode:
            self.c.mode(mode)
            self.c.wait_complete(5)
        return self.wait(lambda: self.s.task_mode == mode, 5)

    def set_state(self, state, timeout=5.0):
        self.c.state(state)
        self.c.wait_complete(timeout)
        return self.wait(lambda: self.s.task_state == state, timeout)

    def idle(self):
        return (self.s.interp_state == linuxcnc.INTERP_IDLE and self.s.inpos and self.s.queue == 0
                and self.s.state != linuxcnc.RCS_EXEC)

    def letter(self, joint):
        return self.letters[joint] if joint < len(self.letters) else "?"

    def section(self, joint, letter):
        for name in ("JOINT_%d" % joint, "AXIS_%d" % joint, "AXIS_%s" % letter):
            if self.ini.find(name, "TYPE") or self.ini.find(name, "FERROR") or self.ini.find(name, "MAX_VELOCITY"):
                return name
        return "JOINT_%d" % joint

    def number(self, section, key):
        v = self.ini.find(section, key)
        try:
            return float(v) if v is not None else None
        except ValueError:
            return None

    # -- requests ---------------------------------------------------------
    def op_describe(self, r):
        joints = []
        for j in range(self.joints):
            letter = self.letter(j)
            sec = self.section(j, letter)
            axis = "AXIS_%s" % letter
            joints.append({
                "joint": j, "letter": letter, "section": sec,
                "type": self.ini.find(sec, "TYPE") or "LINEAR",
                "ferror": self.number(sec, "FERROR"), "min_ferror": self.number(sec, "MIN_FERROR"),
                "max_velocity": self.number(sec, "MAX_VELOCITY") or self.number(axis, "MAX_VELOCITY"),
                "max_acceleration": self.number(sec, "MAX_ACCELERATION") or self.number(axis, "MAX_ACCELERATION"),
                "min_limit": self.number(sec, "MIN_LIMIT") if self.number(sec, "MIN_LIMIT") is not None
                else self.number(axis, "MIN_LIMIT"),
                "max_limit": self.number(sec, "MAX_LIMIT") if self.number(sec, "MAX_LIMIT") is not None
                else self.number(axis, "MAX_LIMIT"),
                "home_sequence": self.ini.find(sec, "HOME_SEQUENCE"),
                "home": self.number(sec, "HOME"),
                # Counts (steps) per unit: PNCconf's names, then the older ones.
                "encoder_scale": self.number(sec, "ENCODER_SCALE") or self.number(sec, "INPUT_SCALE"),
                "step_scale": self.number(sec, "STEP_SCALE") or self.number(sec, "SCALE"),
            })
        params = {}
        names = subprocess.run(["halcmd", "list", "param"], capture_output=True, text=True).stdout.split()
        for n in names:
            if n.endswith(".watchdog.timeout_ns") or n.endswith(".packet-read-timeout"):
                got = subprocess.run(["halcmd", "getp", n], capture_output=True, text=True)
                params[n] = got.stdout.strip()
        return {"joints": joints, "linear_units": self.ini.find("TRAJ", "LINEAR_UNITS") or "mm",
                "spindle_max_rpm": self.number("SPINDLE_0", "MAX_FORWARD_VELOCITY"),
                # AXIS's jog speed until the operator moves its slider (units/s).
                "default_jog_velocity": self.number("DISPLAY", "DEFAULT_LINEAR_VELOCITY"),
                "servo_period_ns": self.number("EMCMOT", "SERVO_PERIOD"), "params": params}

    def op_start(self, r):
        # As AXIS does once its window is up: the POSTGUI_HALFILEs.
        for f in self.ini.findall("HAL", "POSTGUI_HALFILE") or []:
            subprocess.run(["halcmd", "-i", self.ini_path, "-f", f], capture_output=True, text=True)
        self.wait(lambda: self.s.task_state != 0, 10)
        return self.op_machine_on(r)

    def op_machine_on(self, r):
        """Out of E-stop, then Machine On, each waited for `timeout` s."""
        timeout = r.get("timeout", 5)
        self.c.state(linuxcnc.STATE_ESTOP_RESET)
        self.c.wait_complete(timeout)
        reset = self.wait(lambda: self.s.task_state in (linuxcnc.STATE_ESTOP_RESET, linuxcnc.STATE_ON), timeout)
        on = reset and self.set_state(linuxcnc.STATE_ON, timeout)
        return {"ok": bool(on), "estop_reset": reset}

    def op_machine_off(self, r):
        return {"ok": self.set_state(linuxcnc.STATE_OFF)}

    def home_time(self, k):
        """How long joint k may take to home (s): its search across the
        whole travel at HOME_SEARCH_VEL, twice, and half a minute more (a
        joint left mid-travel by a fault searches from there), at most
        ten minutes."""
        sec = self.section(k, self.letter(k))
        lo, hi = self.number(sec, "MIN_LIMIT"), self.number(sec, "MAX_LIMIT")
        search = abs(self.number(sec, "HOME_SEARCH_VEL") or 0.0)
        if lo is None or hi is None or search == 0.0:
            return 60.0
        return min(600.0, 2.0 * abs(hi - lo) / search + 30.0)

    def home_all(self):
        """Every joint homed as an operator of AXIS homes them: Home All when
        every joint has a HOME_SEQUENCE (AXIS offers it then), else one joint
        at a time (without one, Home All does nothing). True when all are."""
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        j = range(self.joints)
        done = lambda k: self.s.homed[k] and not self.s.joint[k]["homing"]  # noqa: E731
        if all(self.ini.find(self.section(k, self.letter(k)), "HOME_SEQUENCE") is not None for k in j):
            self.c.home(-1)
            self.c.wait_complete()
            return self.wait(lambda: all(done(k) for k in j), sum(self.home_time(k) for k in j))
        ok = True
        for k in j:
            self.c.home(k)
            self.c.wait_complete()
            ok = self.wait(lambda: done(k), self.home_time(k)) and ok  # noqa: B023
        return ok

    def op_home(self, r):
        """Every joint homed (home_all), or the joints in "joints" alone, one
        at a time: what an operator does when one joint lost its position."""
        joints = r.get("joints")
        if joints is None:
            ok = self.home_all()
        else:
            self.set_mode(linuxcnc.MODE_MANUAL)
            self.c.teleop_enable(0)
            self.c.wait_complete()
            ok = True
            for k in joints:
                self.c.home(k)
                self.c.wait_complete()
                ok = self.wait(lambda: self.s.homed[k] and not self.s.joint[k]["homing"],  # noqa: B023
                               self.home_time(k)) and ok
        self.wait(self.idle, 5)
        return {"ok": ok}

    def op_mdi(self, r):
        if not self.set_mode(linuxcnc.MODE_MDI):
            return {"ok": False, "why": "no MDI mode"}
        self.c.mdi(r["command"])
        if not r.get("wait", True):
            return {"ok": True}
        self.c.wait_complete(r.get("timeout", 60))
        return {"ok": self.wait(self.idle, r.get("timeout", 60))}

    def op_wait_moving(self, r):
        """Until joint `joint` moves at `speed` units/s or more."""
        k, speed = r["joint"], r["speed"]
        ok = self.wait(lambda: abs(self.s.joint[k]["velocity"]) >= speed, r.get("timeout", 10), 0.001)
        return {"ok": ok}

    def op_jog(self, r):
        """Joint `joint` jogged as an operator jogs it in joint mode, on and
        on at `velocity` units/s (its sign the direction), until LinuxCNC
        has it on a limit, the machine is no longer on, or `timeout` s
        pass; then the jog is stopped."""
        k, v = r["joint"], r["velocity"]
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.jog(linuxcnc.JOG_CONTINUOUS, True, k, v)
        ok = self.wait(lambda: self.s.limit[k] != 0 or self.s.task_state != linuxcnc.STATE_ON,
                       r.get("timeout", 10), 0.001)
        self.c.jog(linuxcnc.JOG_STOP, True, k)
        self.poll()
        return {"ok": ok, "limit": self.s.limit[k], "task_state": self.s.task_state}

    def op_jog_off_limit(self, r):
        """Joint `joint`, on a limit switch, jogged off it as an operator
        does: Override Limits (as AXIS's checkbox), Machine On, a jog at
        `velocity` units/s until LinuxCNC no longer has it on a limit, then
        `beyond` s more."""
        k, v = r["joint"], r["velocity"]
        self.c.override_limits()
        self.c.wait_complete()
        on = self.op_machine_on({"timeout": 5})
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.override_limits()
        self.c.wait_complete()
        self.c.jog(linuxcnc.JOG_CONTINUOUS, True, k, v)
        ok = self.wait(lambda: self.s.limit[k] == 0, r.get("timeout", 10), 0.001)
        time.sleep(r.get("beyond", 0.2))
        self.c.jog(linuxcnc.JOG_STOP, True, k)
        self.poll()
        return {"ok": bool(ok and on["ok"]), "limit": self.s.limit[k], "task_state": self.s.task_state}

    def op_spindle(self, r):
        """Spindle 0 at `rpm` (negative: reverse) by MDI, as a program's
        M3/M4 S would; 0 stops it (M5)."""
        rpm = r["rpm"]
        command = "M5" if rpm == 0 else "%s S%g" % ("M3" if rpm > 0 else "M4", abs(rpm))
        return self.op_mdi({"command": command, "timeout": r.get("timeout", 10)})

    def op_wait_pin(self, r):
        """Until HAL pin `name` reads `value`, at most `timeout` s."""
        started = time.monotonic()
        ok = self.wait(lambda: hal.get_value(r["name"]) == r["value"], r.get("timeout", 10), 0.001)
        return {"ok": ok, "after_s": round(time.monotonic() - started, 3)}

    def op_wait_off(self, r):
        """Until the machine is no longer on (LinuxCNC took it off)."""
        started = time.monotonic()
        ok = self.wait(lambda: self.s.task_state != linuxcnc.STATE_ON, r.get("timeout", 5), 0.001)
        return {"ok": ok, "after_s": round(time.monotonic() - started, 3)}

    def op_wait_idle(self, r):
        return {"ok": self.wait(self.idle, r.get("timeout", 30))}

    def op_abort(self, r):
        self.c.abort()
        self.c.wait_complete()
        return {"ok": True}

    def op_unhome(self, r):
        """Joint `joint` (every joint without one) no longer homed."""
        k = r.get("joint", -1)
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.unhome(k)
        self.c.wait_complete()
        joints = range(self.joints) if k < 0 else [k]
        return {"ok": self.wait(lambda: not any(self.s.homed[j] for j in joints), 5)}

    def op_status(self, r):
        self.poll()
        return {"ok": True, "task_state": self.s.task_state, "homed": [bool(h) for h in self.s.homed[:self.joints]],
                "commanded": list(self.s.joint_position[:self.joints]),
                "feedback": list(self.s.joint_actual_position[:self.joints]),
                "limit": list(self.s.limit[:self.joints])}

    def op_pins(self, r):
        return {"ok": True, "values": {n: hal.get_value(n) for n in r["names"]}}

    def op_setp(self, r):
        got = subprocess.run(["halcmd", "setp", r["name"], str(r["value"])], capture_output=True, text=True)
        return {"ok": got.returncode == 0, "output": (got.stdout + got.stderr).strip()}

    def handle(self, r):
        op = r.get("op")
        f = getattr(self, "op_" + op, None) if isinstance(op, str) else None
        if f is None:
            return {"ok": False, "error": "no request %r" % op}
        answer = f(r)
        return answer if isinstance(answer, dict) else {"ok": bool(answer)}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-ini", required=True)
    p.add_argument("--requests", required=True, help="a FIFO: one JSON request a line")
    p.add_argument("--answers", required=True, help="a FIFO: one JSON answer a line")
    args = p.parse_args()
    answers = open(args.answers, "w", buffering=1)
    d = Driver(args.ini)
    answers.write(json.dumps({"ok": True, "ready": True}) + "\n")
    with open(args.requests) as requests:
        for line in requests:
            if not line.strip():
                continue
            r = json.loads(line)
            if r.get("op") == "quit":
                answers.write(json.dumps({"ok": True}) + "\n")
                return
            try:
                answer = d.handle(r)
            except Exception:
                answer = {"ok": False, "error": traceback.format_exc()}
            d.poll()
            answer["messages"] = d.messages
            d.messages = []
            answers.write(json.dumps(answer) + "\n")


if __name__ == "__main__":
    main()
