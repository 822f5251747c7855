# SPDX-License-Identifier: MIT
"""Machine logic in Python against the in-process mill (docs/machine-mill.md):
the analog outputs drive its amplifiers, its encoders count on the card, its
switches are field inputs, all in simulated time."""

import pytest

import lbpkit

COUNTS_PER_MM = 1600  # 2000 lines x 4 / 5 mm pitch
E_STOP_INPUT = 9


def power_drives(card):
    card.set("analogena", True)
    card.set_bit("output", 2)  # the Z brake released
    for axis in range(3):
        card.set_encoder_scale(axis, COUNTS_PER_MM)


def test_an_axis_moves_at_its_commanded_speed(mill):
    power_drives(mill)
    x0 = mill.machine.position("x")
    assert x0 == pytest.approx(200.0)
    mill.set("analogout0", 2.0)  # 2 V of 10 V at 250 mm/s: 50 mm/s
    mill.run(500)  # 0.5 s at 1 kHz
    assert mill.machine.velocity("x") == pytest.approx(50.0, rel=0.02)
    moved = mill.machine.position("x") - x0
    assert 22.0 < moved < 25.0, "25 mm less the drive's acceleration"
    # The host's encoder agrees with the truth to a count or two.
    assert mill.encoder_position(0) == pytest.approx(moved, abs=2.0 / COUNTS_PER_MM + 0.06)
    assert mill.machine.position("y") == pytest.approx(150.0, abs=1e-3)


def test_a_position_loop_in_python_reaches_its_target(mill):
    power_drives(mill)
    start = mill.machine.position("x")
    target = 10.0  # mm from where it is
    for _ in range(1500):
        error = target - mill.encoder_position(0)
        mill.set("analogout0", max(-10.0, min(10.0, 0.8 * error)))
        mill.cycle()
    assert mill.machine.position("x") - start == pytest.approx(target, abs=0.01)
    assert abs(mill.machine.velocity("x")) < 0.5


def test_the_same_run_gives_the_same_machine_bit_for_bit():
    def run():
        c = lbpkit.Card.sim(machine="mill")
        c.start()
        power_drives(c)
        c.set("analogout2", -3.0)
        c.run(200)
        c.step(0.1)  # and the drives stop: the watchdog
        return c.machine.position("z"), c.machine.velocity("z"), c.encoder_counts(2), c.time

    assert run() == run()


def test_estop_chain_is_a_field_input(mill):
    mill.cycle()
    assert mill.bit("input", E_STOP_INPUT), "normally closed: on while the chain is closed"
    mill.machine.estop(True)
    mill.cycle()
    assert not mill.bit("input", E_STOP_INPUT)
    assert not mill.machine.state().estop_ok
    mill.machine.estop(False)
    mill.cycle()
    assert mill.bit("input", E_STOP_INPUT)


def test_home_switch_trips_when_the_axis_reaches_it(mill):
    power_drives(mill)
    mill.set("analogout1", 8.0)  # Y at 200 mm/s towards its home switch at 295 mm
    for _ in range(2000):
        mill.cycle()
        if mill.bit("input", 3):
            break
    mill.set("analogout1", 0.0)
    mill.cycle()
    assert mill.bit("input", 3)
    assert mill.machine.position("y") == pytest.approx(295.0, abs=1.0)


def test_a_jammed_axis_does_not_follow(mill):
    power_drives(mill)
    mill.machine.jam("x")
    mill.set("analogout0", 2.0)
    mill.run(200)
    assert mill.machine.position("x") == pytest.approx(200.0, abs=1e-6)
    assert mill.machine.following_error("x") > 5.0
    assert mill.machine.state().axes[0].jammed


def test_drives_stop_when_the_host_stops(mill):
    power_drives(mill)
    mill.set("analogout0", 4.0)
    mill.run(300)
    assert mill.machine.velocity("x") > 90.0
    mill.step(0.3)  # no host: the analog watchdog bites at 50 ms, X coasts to rest
    assert mill.board.analog_output(0) == 0.0
    assert not mill.board.enable(0)
    assert mill.machine.velocity("x") == pytest.approx(0.0, abs=0.01)
    assert mill.machine.brake_engaged("z"), "output 2 off with the field I/O watchdog: Z on its brake"


def test_machine_inputs_are_the_machines(mill):
    with pytest.raises(lbpkit.Error, match="estop"):
        mill.board.set_input(E_STOP_INPUT, False)
    with pytest.raises(lbpkit.Error, match="no axis \"w\""):
        mill.machine.position("w")
    assert mill.machine.axes == ["x", "y", "z"]
    mill.board.set_input(20, True)  # a free input is the user's
    mill.cycle()
    assert mill.bit("input", 20)


def test_a_machine_file_mistake_is_an_error(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \"m\"\n[[axis]]\nname = \"x\"\nscew_pitch = 5\n")
    with pytest.raises(lbpkit.Error, match="scew_pitch"):
        lbpkit.Card.sim(machine=str(bad))
