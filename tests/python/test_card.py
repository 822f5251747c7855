# SPDX-License-Identifier: MIT
"""The host library through Python, on the in-process virtual 7I92 + 7I77:
discovery, process data by name, parameters, faults, simulated time."""

import math
import os

import pytest

import lbpkit

# 13-bit DAC at 10 V full scale (manual: ANALOG SERVO DRIVE INTERFACE).
DAC_STEP = 10.0 / 4095


def test_discovery_finds_both_7i77_processors():
    c = lbpkit.Card.sim()
    assert c.board_name == "MESA7I92"
    assert "SSerial" in [m.name for m in c.modules]
    remotes = {r.channel: r for r in c.discover() if r.present}
    assert sorted(remotes) == [0, 1]
    assert remotes[0].name == "7I77" and remotes[0].function == "field I/O"
    assert remotes[1].function == "analog"
    assert c.channels == [0, 1]
    assert [e.name for e in c.process_data(0)] == ["Input", "Output"]
    assert [e.name for e in c.process_data(1)][:2] == ["AnalogOut0", "AnalogOut1"]
    out0 = c.process_data(1)[0]
    assert (out0.type, out0.direction, out0.bits, out0.min, out0.max, out0.unit) == \
        ("SIGNED", "out", 13, -10.0, 10.0, "V")
    assert "WatchDogTime" in [e.name for e in c.parameters(1)]


def test_field_input_reaches_the_host_by_name(card):
    card.board.set_input(3, True)
    assert card.get("input") == 0, "nothing is read before a cycle"
    assert card.cycle().ok
    assert card.get("input") == 1 << 3
    assert card.bit("input", 3) and not card.bit("input", 2)
    card.board.set_input(3, False)
    card.cycle()
    assert card.get("input") == 0


def test_analog_output_reaches_the_terminal(card):
    card.set("analogena", True)
    card.set("AnalogOut0", 2.5)
    card.set("analogout1", -7.25)
    card.cycle()
    assert card.board.enable(0) and card.board.enable(4)
    assert not card.board.enable(5), "ENA5 follows SpinEna alone"
    assert card.board.analog_output(0) == pytest.approx(2.5, abs=DAC_STEP)
    assert card.board.analog_output(1) == pytest.approx(-7.25, abs=DAC_STEP)
    card.set("analogout0", 25.0)  # beyond PARAM_MAX: clamped to it
    card.cycle()
    assert card.board.analog_output(0) == pytest.approx(10.0, abs=DAC_STEP)


def test_field_output_drives_its_terminal(card):
    card.set_bit("output", 5)
    card.cycle()
    assert card.board.output(5) and not card.board.output(4)
    assert card.board.output_voltage(5) == pytest.approx(24.0, abs=0.5)
    card.set("output", 0)
    card.cycle()
    assert not card.board.output(5)


def test_parameter_round_trip_keeps_the_outputs(card):
    assert card.read_parameter("WatchDogTime", channel=1) == 50
    card.set("analogena", True)
    card.set("analogout0", 3.0)
    card.cycle()
    card.write_parameter("watchdogtime", 120, channel=1)
    assert card.read_parameter("WATCHDOGTIME", channel=1) == 120
    assert card.read_parameter("watchdogtime", channel=0) == 50, "the other processor keeps its own"
    # The card was restarted for setup mode with its outputs as they were.
    assert card.running
    card.cycle()
    assert card.board.analog_output(0) == pytest.approx(3.0, abs=DAC_STEP)


def test_non_volatile_parameter_takes_effect_at_power_up(card):
    card.write_parameter("NVWatchDogTimeout", 75, channel=1)
    assert card.read_parameter("NVWatchDogTimeout", channel=1) == 75
    assert card.read_parameter("WatchDogTime", channel=1) == 50
    card.power_cycle()
    card.start()
    assert card.read_parameter("WatchDogTime", channel=1) == 75


def test_parameter_mistakes_say_what_is_wrong(card):
    with pytest.raises(lbpkit.Error, match=r"WatchDogTime.* channels 0 1"):
        card.read_parameter("WatchDogTime")
    with pytest.raises(lbpkit.Error, match=r"no parameter \"Nope\".*WatchDogTime"):
        card.read_parameter("Nope", channel=1)
    with pytest.raises(lbpkit.Error, match="read only"):
        card.write_parameter("SwRevision", 1, channel=0)
    with pytest.raises(ValueError, match="does not fit"):
        card.write_parameter("WatchDogTime", 70000, channel=1)


def test_process_data_mistakes_say_what_is_wrong(card):
    with pytest.raises(lbpkit.Error, match=r"no process data element \"AnalogOut9\".*AnalogOut5"):
        card.set("AnalogOut9", 1.0)
    with pytest.raises(lbpkit.Error, match="is an input"):
        card.set("input", 1)
    with pytest.raises(ValueError, match="whole number"):
        card.set("output", 1.5)
    with pytest.raises(IndexError):
        card.set_bit("output", 16)
    with pytest.raises(lbpkit.Error, match="start"):
        lbpkit.Card.sim().get("input")


def test_shorted_output_trips_and_the_host_sees_overcurrent(card):
    card.set_bit("output", 0)
    card.cycle()
    assert card.board.output(0)
    assert card.remote_faults(0) == 0
    card.board.short_output(0)
    for _ in range(5):
        card.cycle()
    assert card.board.output_tripped(0)
    assert not card.board.output(0)
    assert card.board.output_voltage(0) == pytest.approx(0.0, abs=0.1)
    assert card.remote_faults(0) & 0x08
    assert "OverCurrentFault" in lbpkit.fault_bits(card.remote_faults(0))
    assert "OverCurrentFault" in lbpkit.describe_faults(card.remote_faults(0))


def test_analog_watchdog_bites_when_the_host_stops(card):
    card.set("analogena", True)
    card.set("analogout0", 5.0)
    card.cycle()
    assert card.board.analog_output(0) == pytest.approx(5.0, abs=DAC_STEP)
    card.step(0.045)  # within the 7I77's 50 ms: nothing happens
    assert card.board.analog_output(0) == pytest.approx(5.0, abs=DAC_STEP)
    assert card.board.enable(0)
    card.step(0.010)  # 55 ms without the host
    assert card.board.analog_output(0) == 0.0
    assert not card.board.enable(0)
    assert card.board.analog_faults() & 0x01
    card.cycle()
    assert "WatchdogFault" in lbpkit.fault_bits(card.remote_faults(1))


def test_step_moves_simulated_time_exactly(card):
    t0 = card.time
    card.step(0.1)
    assert card.time - t0 == pytest.approx(0.1, abs=1e-12)
    card.period = 0.002
    t1 = card.time
    card.run(50)
    assert card.time - t1 == pytest.approx(0.1, abs=1e-12)
    assert card.cycles >= 50


def test_encoder_counts_over_simulated_time(card):
    card.board.set_encoder(3, counts_per_second=10000)
    card.cycle()
    start = card.encoder_counts(3)
    card.run(100)  # 0.1 s
    assert card.encoder_counts(3) - start == pytest.approx(1000, abs=20)
    card.set_encoder_scale(3, 100.0)
    assert card.encoder_position(3) == pytest.approx(card.encoder_counts(3) / 100.0)
    assert card.encoder_velocity(3) == pytest.approx(100.0, rel=0.05)


def test_pulled_cable_shows_in_the_cycle_status(card):
    assert card.cycle().fresh_mask == 0b11
    card.board.set_cable(1, False)
    status = card.run(3)
    assert not status.ok
    assert status.failed_mask & 0b10
    assert not status.fresh_mask & 0b10


def test_network_card_that_is_not_there():
    # A port nothing listens on: refused or no reply within the timeout.
    with pytest.raises(lbpkit.Error):
        lbpkit.Card.open("127.0.0.1", port=9, timeout=0.05)


def test_board_is_only_in_process():
    assert math.isfinite(lbpkit.Card.sim().board.field_voltage())
    assert lbpkit.Card.sim().machine is None


def _python(script):
    """`script` in a Python of its own, with this one's lbpkit: (status, output)."""
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(lbpkit.__file__)))
    r = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=60)
    return r.returncode, r.stdout + r.stderr


def test_run_is_interrupted_by_a_real_sigint():
    status, out = _python(
        "import os, signal, threading, time, lbpkit\n"
        "c = lbpkit.Card.sim(); c.start()\n"
        "threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()\n"
        "t = time.monotonic()\n"
        "try:\n"
        "    c.run(10**9)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted after', round(time.monotonic() - t, 1))\n")
    assert status == 0, out
    assert "interrupted after" in out, out


def test_run_refuses_more_cycles_than_can_finish(card):
    with pytest.raises(ValueError, match="at most 1000000000000 cycles"):
        card.run(2**63)


def test_the_interpreter_exits_cleanly_with_a_thread_inside_run():
    status, out = _python(
        "import threading, time, lbpkit\n"
        "c = lbpkit.Card.sim(); c.start()\n"
        "threading.Thread(target=lambda: c.run(10**8), daemon=True).start()\n"
        "time.sleep(0.3)\n"
        "print('main thread ends')\n")
    assert status == 0, out
    assert "terminate called" not in out, out


def test_a_state_file_the_card_will_not_use_is_refused_at_once(tmp_path):
    target = tmp_path / "real.eeprom"
    lbpkit.Card.sim(state=str(target)).start()  # makes the EEPROM image
    link = tmp_path / "link.eeprom"
    link.symlink_to(target)
    with pytest.raises(lbpkit.Error, match="symbolic link"):
        lbpkit.Card.sim(state=str(link))
    text = tmp_path / "notes.txt"
    text.write_text("a file of the user's\n")
    with pytest.raises(lbpkit.Error):
        lbpkit.Card.sim(state=str(text))
    assert text.read_text() == "a file of the user's\n"
