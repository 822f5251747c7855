#!/usr/bin/python3
# SPDX-License-Identifier: MIT
"""A headless LinuxCNC display for the end-to-end test of the virtual mill.

`linuxcnc` starts it as the INI's [DISPLAY]DISPLAY (the test replaces only
that line of examples/linuxcnc/mill/mill.ini), with `-ini FILE` and the
arguments below. It operates the machine through LinuxCNC's `linuxcnc`
Python module (command, stat, error_channel) as a user would through AXIS,
and looks at the simulated machine through `lbpkit sim`'s control API
(GET/POST /api/machine). It judges nothing: every step is one JSON line in
--out, with what LinuxCNC said and what the machine did, for
tests/e2e/linuxcnc_mill_test.cpp to assert on.

The last step starts a move and reports "ready_for_kill"; the test then kills
LinuxCNC (all of it, at once) and watches the machine through the API.

--scenario stepper-z is for examples/linuxcnc/mill-7i76 (Z a stepper on a
DPLL-timed StepGen): start-up, homing, the MDI moves and the program, each
compared within one count or step per axis, then "stepper_z": Z's steps as
the machine took them and as LinuxCNC counted them, and "finished".

Runs under Debian's /usr/bin/python3, where linuxcnc-uspace puts the module.
"""
import argparse
import json
import os
import subprocess
import sys
import threading
import time
import urllib.request

import hal
import linuxcnc

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import display  # noqa: E402  (the general display, beside this file)

AXES = "xyz"


class Machine:
    """The simulated machine, through lbpkit sim's control API."""

    def __init__(self, url):
        self.url = url.rstrip("/") + "/api/machine"

    def get(self):
        with urllib.request.urlopen(self.url, timeout=5) as r:
            return json.load(r)

    def post(self, **action):
        req = urllib.request.Request(self.url, data=json.dumps(action).encode(),
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=5) as r:
            return json.load(r)

    @staticmethod
    def axis(m, name):
        return next(a for a in m["axes"] if a["name"] == name)

    def positions(self, m=None):
        m = m or self.get()
        return [self.axis(m, a)["position"] for a in AXES]


class Display(display.Display):
    def __init__(self, args):
        super().__init__(args, "mill-display")
        self.machine = Machine(args.api)
        self.program = args.program

    def extra_report(self):
        return {"hm2": hm2_health()}

    # -- positions at rest -----------------------------------------------
    def settle_and_compare(self, timeout=5.0):
        """After a move: waits for the model to come within one count (a step
        on a stepper joint) of the commanded position (the PID's integrator
        takes the last counts), and returns the comparison at that moment or
        at the timeout."""
        end = time.monotonic() + timeout
        while True:
            cmd = self.commanded()
            model = self.machine.positions()
            counts = [round((m - c) / u, 3) for m, c, u in zip(model, cmd, self.unit)]
            # Judged as reported (to a thousandth of a count): a stepper
            # joint can rest exactly one step off its command (its home
            # switch on a step's edge), which in floating point is a hair
            # over one step and would hold this loop to its timeout.
            ok = all(abs(e) <= 1.0 for e in counts)
            if ok or time.monotonic() > end:
                return {"commanded": cmd, "model": model, "error_counts": counts, "within_one_count": ok}
            time.sleep(0.02)

    # -- the scenario ----------------------------------------------------
    def run(self):
        self.wait(lambda: self.s.task_state != 0, 10)
        self.host_clock()
        self.postgui()
        self.start_up()
        self.home()
        self.mdi_moves()
        self.run_program()
        if self.args.scenario == "stepper-z":
            self.stepper_z()
            self.report("finished", all_messages=self.messages)
            time.sleep(60)
            return
        self.push_under_power()
        self.limit_fault()
        self.estop_fault()
        self.encoder_fault()
        self.ready_for_kill()

    def host_clock(self):
        # On the sim's host clock (lbpkit sim --clock host) a servo period
        # passes per LinuxCNC cycle, however late the cycle: a reply that
        # comes late only makes the period late, so hm2_eth may wait for it
        # (20 ms, under the 40 ms silence that hands the sim back to the wall
        # clock) instead of counting a packet error and going on without
        # feedback. On the wall clock the configuration stays as it is.
        with urllib.request.urlopen(self.machine.url.replace("/api/machine", "/api/state"), timeout=5) as r:
            clock = json.load(r)["clock"]
        fields = {"source": clock["source"]}
        if clock["source"] == "host":
            params = subprocess.run(["halcmd", "list", "param"], capture_output=True, text=True).stdout.split()
            names = [n for n in params if n.endswith(".packet-read-timeout")]
            results = [subprocess.run(["halcmd", "setp", n, "20000000"], capture_output=True, text=True)
                       for n in names]
            fields.update(packet_read_timeout_ns=20000000, boards=names,
                          ok=bool(names) and all(r.returncode == 0 for r in results))
        self.report("clock", **fields)

    def drives(self, m):
        return {a["name"]: [d["ena"] for d in a["drives"]] for a in m["axes"]}

    def start_up(self):
        n = len(self.messages)
        ok_reset = self.set_state(linuxcnc.STATE_ESTOP_RESET)
        ok_on = self.set_state(linuxcnc.STATE_ON)
        time.sleep(0.1)
        m = self.machine.get()
        self.report("machine_on", estop_reset=ok_reset, on=ok_on, task_state=self.s.task_state,
                    drive_ena=self.drives(m), z_brake_engaged=Machine.axis(m, "z")["brake_engaged"],
                    lube=self.output(m, "lube"), messages=self.messages_since(n))

    @staticmethod
    def output(m, name):
        return next((o["on"] for o in m.get("outputs", []) if o["name"] == name), None)

    def home(self):
        n = len(self.messages)
        before = self.machine.positions()
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        started = time.monotonic()
        self.c.home(-1)
        self.c.wait_complete()
        ok = self.wait(lambda: all(self.s.homed[:3]) and all(not self.s.joint[j]["homing"] for j in range(3)), 60)
        took = time.monotonic() - started
        self.wait(self.idle, 5)
        cmp = self.settle_and_compare()
        self.report("home", ok=ok, seconds=round(took, 2), homed=list(self.s.homed[:3]), before=before,
                    messages=self.messages_since(n), **cmp)

    MDI_MOVES = [
        "G53 G0 X100 Y100 Z-50",
        "G53 G1 X250.5 Y37.25 Z-120 F6000",
        "G53 G1 X333.3333 Y123.4567 Z-33.3333 F3000",
    ]

    def mdi_moves(self):
        for command in self.MDI_MOVES:
            n = len(self.messages)
            ok = self.mdi(command)
            cmp = self.settle_and_compare()
            self.report("mdi", command=command, ok=ok, task_state=self.s.task_state,
                        messages=self.messages_since(n), **cmp)

    def run_program(self):
        n = len(self.messages)
        if not self.set_mode(linuxcnc.MODE_AUTO):
            self.report("program", ok=False, why="no auto mode", messages=self.messages_since(n))
            return
        self.c.program_open(self.program)
        self.c.wait_complete()
        capture = FerrorCapture(self.args.ferror_dump)
        installed = capture.install()
        capture.start()
        spindle_rpm_max = 0.0
        coolant_seen = False
        started = time.monotonic()
        self.c.auto(linuxcnc.AUTO_RUN, 0)
        self.wait(lambda: self.s.interp_state != linuxcnc.INTERP_IDLE, 5)
        last_api = 0.0
        while True:
            self.poll()
            if self.s.interp_state == linuxcnc.INTERP_IDLE or self.s.task_state != linuxcnc.STATE_ON:
                break
            if time.monotonic() - started > 90:
                break
            if time.monotonic() - last_api > 0.5:
                last_api = time.monotonic()
                m = self.machine.get()
                if m.get("spindle"):
                    spindle_rpm_max = max(spindle_rpm_max, m["spindle"]["rpm"])
                coolant_seen = coolant_seen or bool(self.output(m, "coolant"))
            time.sleep(0.01)
        took = time.monotonic() - started
        finished = self.s.interp_state == linuxcnc.INTERP_IDLE and self.s.task_state == linuxcnc.STATE_ON
        self.wait(self.idle, 5)
        ferror = capture.stop()
        cmp = self.settle_and_compare()
        m = self.machine.get()
        self.report("program", ok=finished, seconds=round(took, 2), capture_error=installed, ferror=ferror,
                    spindle_rpm_max=spindle_rpm_max, coolant_seen=coolant_seen,
                    spindle_running_after=bool(m["spindle"] and m["spindle"]["running"]),
                    coolant_after=self.output(m, "coolant"), messages=self.messages_since(n), **cmp)

    def push_under_power(self):
        """What LinuxCNC reports first for a pushed axis while the drives hold
        it: the following error (motion/control.c checks it every period
        against MIN_FERROR at rest), here 1 mm into a 3 mm push, far from any
        switch. The machine goes off; the axis stays where it was pushed."""
        n = len(self.messages)
        self.mdi("G53 G0 X300 Y150 Z-20")
        before = self.machine.positions()
        self.machine.post(action="push", axis="x", distance=3.0, speed=20.0)
        got = self.wait(lambda: len(self.messages_since(n)) > 0, 3)
        off = self.wait(lambda: self.s.task_state != linuxcnc.STATE_ON, 3)
        self.wait_model(lambda m: not Machine.axis(m, "x")["pushing"], 3)
        m = self.machine.get()
        on = self.set_state(linuxcnc.STATE_ON)
        self.report("push_under_power", reported=got, machine_off=off, messages=self.messages_since(n),
                    x_before=before[0], x_after=Machine.axis(m, "x")["position"], on_again=on)

    def limit_fault(self):
        """A pushed axis on its limit switch, seen from LinuxCNC.

        LinuxCNC checks every enabled joint's following error each servo
        period (motion/control.c: the limit is MIN_FERROR at rest), so an axis
        pushed while the drives hold it shows a following error long before it
        reaches a limit switch 2 mm past the soft limit. The limit error is
        what LinuxCNC reports when the push happens while the machine is off
        (drives disabled, axis free, no following error checked): someone
        pushes the table onto the X+ limit switch, and Machine On is refused
        with "joint 0 on limit switch error" (while it was off, LinuxCNC
        only noted that homed X had gone past its soft limit). The way back
        is the one LinuxCNC asks for: override limits, Machine On, unhome X,
        jog it off the switch as a joint, home it again.
        """
        n = len(self.messages)
        self.mdi("G53 G0 X398 Y150 Z-20")
        self.set_state(linuxcnc.STATE_OFF)
        pushed = self.machine.post(action="push", axis="x", distance=5.0, speed=20.0)
        ok_pushed = self.wait_model(lambda m: not Machine.axis(m, "x")["pushing"] and Machine.axis(m, "x")["position"] > 402.5, 5)
        m = self.machine.get()
        max_switch = next(s for s in m["switches"] if s["name"] == "x-max")
        # LinuxCNC sees the switch some servo periods and a status update
        # after the model does: wait for that (a look at once raced it, and
        # Machine On then met a limit LinuxCNC had not flagged yet).
        self.wait(lambda: self.s.limit[0] != 0, 2)
        limit_flags = list(self.s.limit[:3])
        n_on = len(self.messages)
        self.c.state(linuxcnc.STATE_ON)
        self.c.wait_complete()
        self.wait(lambda: any("limit" in t for t in self.messages_since(n_on)), 3)
        time.sleep(0.2)
        self.poll()
        m_after = self.machine.get()
        refused = self.s.task_state != linuxcnc.STATE_ON
        on_messages = self.messages_since(n_on)
        # Recovery, as LinuxCNC asks for it: override limits, Machine On,
        # unhome X (it is past its soft limit), jog it off the switch as a
        # joint, home it again.
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.c.override_limits()
        self.c.wait_complete()
        on_again = self.set_state(linuxcnc.STATE_ON)
        self.c.teleop_enable(0)
        self.c.wait_complete()
        self.c.unhome(0)
        self.c.wait_complete()
        self.wait(lambda: not self.s.homed[0], 2)
        self.c.jog(linuxcnc.JOG_INCREMENT, True, 0, -5.0, 6.0)
        self.c.wait_complete()
        self.wait(lambda: self.s.joint[0]["inpos"] and self.s.joint_actual_position[0] < 398, 10)
        self.wait(self.idle, 5)
        m_back = self.machine.get()
        self.poll()
        limit_after_jog = list(self.s.limit[:3])
        self.c.home(0)
        self.c.wait_complete()
        rehomed = self.wait(lambda: self.s.homed[0] and not self.s.joint[0]["homing"], 30)
        self.wait(self.idle, 5)
        cmp = self.settle_and_compare()
        self.report("limit", push_answer_ok="error" not in pushed, pushed_onto_switch=ok_pushed,
                    model_x=Machine.axis(m, "x")["position"], x_max_switch=max_switch,
                    linuxcnc_limit_flags_before_on=limit_flags, machine_on_refused=refused,
                    messages_on_machine_on=on_messages, drive_ena_after=self.drives(m_after),
                    recovered_on=on_again, x_after_jog=Machine.axis(m_back, "x")["position"],
                    limit_flags_after_jog=limit_after_jog, rehomed=rehomed, task_state=self.s.task_state,
                    messages=self.messages_since(n), after=cmp)

    def wait_model(self, predicate, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate(self.machine.get()):
                return True
            time.sleep(0.02)
        return False

    def estop_fault(self):
        """The E-stop chain opened during a move: LinuxCNC goes to E-stop, the
        machine is off and the drives' enables drop (TB5 ENA0..2)."""
        n = len(self.messages)
        self.mdi("G53 G0 X300 Y150 Z-20")
        self.set_mode(linuxcnc.MODE_MDI)
        self.c.mdi("G53 G1 X200 F1200")
        self.wait(lambda: abs(self.s.current_vel) > 5, 5)
        self.machine.post(action="estop", pressed=True)
        in_estop = self.wait(lambda: self.s.task_state == linuxcnc.STATE_ESTOP, 3)
        time.sleep(0.1)
        m = self.machine.get()
        self.poll()
        report = dict(linuxcnc_in_estop=in_estop, task_state=self.s.task_state, estop_ok=m["estop_ok"],
                      drive_ena=self.drives(m), drive_enabled={a["name"]: [d["enabled"] for d in a["drives"]] for a in m["axes"]},
                      z_brake_engaged=Machine.axis(m, "z")["brake_engaged"])
        # Release the button: E-stop reset and Machine On work again.
        self.machine.post(action="estop", pressed=False)
        time.sleep(0.1)
        reset = self.set_state(linuxcnc.STATE_ESTOP_RESET)
        on = self.set_state(linuxcnc.STATE_ON)
        self.poll()
        report.update(reset_after_release=reset, on_after_release=on, homed_after=list(self.s.homed[:3]))
        cmp = self.settle_and_compare()
        self.report("estop", messages=self.messages_since(n), after=cmp, **report)

    def encoder_fault(self):
        """X's encoder loses channel A during a move: the count stops, the
        drive runs on (a runaway, as on a real machine), and LinuxCNC stops it
        with a following error. Repaired, the machine comes back on; X's
        position is lost (the counts missed stay missed) until it is homed
        again."""
        n = len(self.messages)
        self.mdi("G53 G0 X350 Y150 Z-20")
        self.machine.post(action="encoder", axis="x", drive=0, channel="A", broken=True)
        self.set_mode(linuxcnc.MODE_MDI)
        self.c.mdi("G53 G1 X340 F600")
        got = self.wait(lambda: any("following error" in t for t in self.messages_since(n)), 5)
        off = self.wait(lambda: self.s.task_state != linuxcnc.STATE_ON, 3)
        time.sleep(0.3)  # the axis coasts to a stop
        self.poll()
        m = self.machine.get()
        report = dict(following_error_reported=got, machine_off=off, task_state=self.s.task_state,
                      drive_ena=self.drives(m), x_encoder_broken=Machine.axis(m, "x")["drives"][0]["encoder_broken"],
                      model_x=Machine.axis(m, "x")["position"], linuxcnc_x=self.s.joint_actual_position[0])
        self.machine.post(action="encoder", axis="x", drive=0, channel="A", broken=False)
        on = self.set_state(linuxcnc.STATE_ON)
        m = self.machine.get()
        self.report("encoder", on_after_repair=on, drive_ena_after_repair=self.drives(m),
                    x_encoder_broken_after_repair=Machine.axis(m, "x")["drives"][0]["encoder_broken"],
                    messages=self.messages_since(n), **report)

    def stepper_z(self):
        """Z's steps: the machine's (what the motor took, and lost) beside
        LinuxCNC's (the StepGen count hm2 read, its position feedback), and a
        last move whose steps both count."""
        def look():
            self.wait(self.idle, 5)
            z = Machine.axis(self.machine.get(), "z")
            return {"model_z": z["position"], "stepper": z.get("stepper"),
                    "commanded_z": self.commanded()[2],
                    "counts": hal.get_value("hm2_7i92.0.stepgen.00.counts"),
                    "position_fb": hal.get_value("hm2_7i92.0.stepgen.00.position-fb")}
        n = len(self.messages)
        before = look()
        ok = self.mdi("G53 G1 Z-123.4567 F900")
        after = look()
        self.report("stepper_z", ok=ok, before=before, after=after, scale=1.0 / self.unit[2],
                    timer_number=hal.get_value("hm2_7i92.0.stepgen.timer-number"),
                    dpll_timer_us=hal.get_value("hm2_7i92.0.dpll.01.timer-us"),
                    dpll_phase_error_us=hal.get_value("hm2_7i92.0.dpll.phase-error-us"),
                    messages=self.messages_since(n))

    def ready_for_kill(self):
        """A move in progress when the test kills LinuxCNC."""
        # X's position is off by the counts it lost: moves stay in the middle.
        self.mdi("G53 G0 X300 Y220 Z-20")
        self.set_mode(linuxcnc.MODE_MDI)
        self.c.mdi("G53 G1 X120 Y100 F9000")
        moving = self.wait(lambda: abs(self.s.current_vel) > 90, 5)
        m = self.machine.get()
        self.report("ready_for_kill", moving=moving, velocities=[Machine.axis(m, a)["velocity"] for a in AXES],
                    all_messages=self.messages)
        time.sleep(60)


def hm2_health():
    """The 7I92 link as hostmot2 sees it (for the record when a step fails)."""
    names = ["hm2_7i92.0.watchdog.has_bit", "hm2_7i92.0.io_error", "hm2_7i92.0.packet-error-total",
             "hm2_7i92.0.sserial.port-0.fault-count", "hm2_7i92.0.sserial.port-0.port_state"]
    health = {}
    for name in names:
        try:
            health[name.split("hm2_7i92.0.")[1]] = hal.get_value(name)
        except Exception as e:  # noqa: BLE001 - diagnostics only
            health[name] = str(e)
    return health


class FerrorCapture:
    """LinuxCNC's following error of every servo period while running:
    joint.N.f-error and motion.servo.last-period through HAL's sampler
    component, read out with halsampler (an instrument added at run time,
    as halscope would be; the configuration is not touched).

    The PC here runs LinuxCNC without a real-time kernel, so the servo
    thread is now and then late; the drives keep the last command meanwhile
    and LinuxCNC catches up with short periods, which shows as a following
    error of about velocity x lateness (0.1 mm at 100 mm/s for 1 ms), and a
    reply hm2_eth waited for in vain leaves a period without feedback. The
    largest following error is given over all periods, and "on time":
    without the periods more than 20 % off the usual one or without
    feedback, and the 50 after each (what the tuned loop does on a host
    that keeps time)."""

    SETTLE = 50  # periods after a late one that are set aside

    def __init__(self, dump=None):
        self.dump = dump
        self.lines = []
        self.proc = None
        self.reader = None

    def halcmd(self, *args):
        return subprocess.run(["halcmd"] + list(args), capture_output=True, text=True)

    def install(self):
        steps = [("loadrt", "sampler", "depth=30000", "cfg=fffub"),
                 ("addf", "sampler.0", "servo-thread"),
                 ("setp", "sampler.0.enable", "0"),
                 ("net", "e2e-ferror-0", "joint.0.f-error", "=>", "sampler.0.pin.0"),
                 ("net", "e2e-ferror-1", "joint.1.f-error", "=>", "sampler.0.pin.1"),
                 ("net", "e2e-ferror-2", "joint.2.f-error", "=>", "sampler.0.pin.2"),
                 ("net", "e2e-servo-period", "motion.servo.last-period", "=>", "sampler.0.pin.3"),
                 ("net", "e2e-packet-error", "hm2_7i92.0.packet-error", "=>", "sampler.0.pin.4")]
        for step in steps:
            r = self.halcmd(*step)
            if r.returncode != 0:
                return " ".join(step) + ": " + (r.stdout + r.stderr).strip()
        return None

    def start(self):
        self.lines = []
        self.proc = subprocess.Popen(["stdbuf", "-oL", "halsampler", "-c", "0"], stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        self.reader = threading.Thread(target=lambda: self.lines.extend(self.proc.stdout), daemon=True)
        self.reader.start()
        self.halcmd("setp", "sampler.0.enable", "1")

    def stop(self):
        self.halcmd("setp", "sampler.0.enable", "0")
        end = time.monotonic() + 3
        while time.monotonic() < end:
            r = self.halcmd("getp", "sampler.0.curr-depth")
            if r.stdout.strip() == "0":
                break
            time.sleep(0.05)
        time.sleep(0.1)
        self.proc.send_signal(2)
        try:
            self.proc.wait(3)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.reader.join(3)
        rows = []
        for line in self.lines:
            f = line.split()
            if len(f) == 5:
                rows.append(([abs(float(v)) for v in f[:3]], int(f[3]), f[4] == "1"))
        if not rows:
            return {"periods": 0}
        if self.dump:
            with open(self.dump, "w") as f:
                f.writelines(self.lines)
        periods = sorted(r[1] for r in rows)
        usual = periods[len(periods) // 2]
        late = [i for i, r in enumerate(rows) if abs(r[1] - usual) > 0.2 * usual]
        lost = [i for i, r in enumerate(rows) if r[2]]
        excluded = set()
        for i in late + lost:
            excluded.update(range(i, min(i + self.SETTLE, len(rows))))
        worst = [max(r[0][j] for r in rows) for j in range(3)]
        calm = [r for i, r in enumerate(rows) if i not in excluded]
        worst_calm = [max((r[0][j] for r in calm), default=0.0) for j in range(3)]
        # Without the periods after a read hm2_eth gave up on (its thread
        # held back past packet-read-timeout: a period without feedback).
        unfed = set()
        for i in lost:
            unfed.update(range(i, min(i + self.SETTLE, len(rows))))
        fed = [r for i, r in enumerate(rows) if i not in unfed]
        worst_fed = [max((r[0][j] for r in fed), default=0.0) for j in range(3)]
        return {"periods": len(rows), "late_periods": len(late), "lost_packet_periods": len(lost),
                "periods_set_aside": len(excluded), "periods_after_lost_packets": len(unfed),
                "longest_period_ms": round(periods[-1] / usual, 2),  # the usual period is 1 ms
                "max_ferror_mm": worst, "max_ferror_on_time_mm": worst_calm, "max_ferror_with_feedback_mm": worst_fed}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-ini", required=True)
    p.add_argument("--api", required=True, help="lbpkit sim's control API, e.g. http://192.168.1.20:27182 (not on the card's link:"
                   " hm2_eth lets nothing else through there)")
    p.add_argument("--out", required=True, help="results, one JSON object a line")
    p.add_argument("--program", required=True, help="the G-code program to run")
    p.add_argument("--scenario", choices=["mill", "stepper-z"], default="mill",
                   help="mill: every step; stepper-z: up to the program, then Z's steps (mill-7i76)")
    p.add_argument("--ferror-dump", help="write every servo period of the program (HAL sampler lines) here")
    display.run_reporting(Display(p.parse_args()))


if __name__ == "__main__":
    main()
