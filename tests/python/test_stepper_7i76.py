# SPDX-License-Identifier: MIT
"""In Python: the 7I92T's 7I77+7I76 firmware in process, a stepper
axis on StepGen 0 (card.machine: steps, lost steps, stall) and the 7I76
beside the 7I77 (card.board.seven_i76: inputs, outputs, field power, the
spindle interface). The host writes the StepGen's registers as LinuxCNC's
hostmot2 does and cycles the 7I76 on SSerial channel 3."""

import pathlib

import pytest

import lbpkit

STEPS_PER_MM = 800
PULL_OUT = 40000  # steps/s: the file's max_step_rate
I76 = 3  # the 7I76's SSerial channel

# X a servo axis, Z a stepper on StepGen 0 (800 steps/mm, out of step above 40 000 steps/s).
ROUTER = pathlib.Path(__file__).resolve().parent.parent / "machines" / "router_stepper.toml"

# StepGen registers (docs/hostmot2-modules.md#stepgen): rate, dir setup,
# dir hold, pulse width, pulse idle, master rate.
RATE, DIR_SETUP, DIR_HOLD, PULSE_WIDTH, PULSE_IDLE, MASTER_RATE = 0, 3, 4, 5, 6, 9


class StepGen0:
    """StepGen 0 as LinuxCNC's hostmot2 stepgen sets it up and commands it."""

    def __init__(self, card):
        self.card = card
        self.module = next(m for m in card.modules if m.name == "StepGen")
        for reg, value in ((PULSE_WIDTH, 100), (PULSE_IDLE, 100), (DIR_SETUP, 1000), (DIR_HOLD, 1000),
                           (MASTER_RATE, 0xFFFFFFFF)):
            self.write(reg, value)

    def write(self, reg, value):
        self.card.write32(self.module.base_address + reg * self.module.register_stride, value)

    def rate(self, steps_per_second):
        # steps/s = rate register x ClockLow / 2^32, signed
        self.write(RATE, round(steps_per_second * 2**32 / self.module.clock_hz) & 0xFFFFFFFF)


@pytest.fixture
def router():
    c = lbpkit.Card.sim(machine=str(ROUTER), card="7I92T")
    c.start()
    return c


def test_a_stepper_axis_shows_its_steps_and_a_servo_axis_has_none(router):
    m = router.machine
    state = m.state()
    x, z = state.axes
    assert x.stepper is None and len(x.drives) == 1
    assert z.drives == [] and z.stepper is not None
    assert (z.stepper.stepgen, z.stepper.steps, z.stepper.lost_steps, z.stepper.stalled) == (0, 0, 0, False)
    assert m.stepper("x") is None
    assert m.steps("z") == 0 and m.lost_steps("z") == 0 and not m.stalled("z")
    with pytest.raises(lbpkit.Error, match="servo axis"):
        m.steps("x")
    with pytest.raises(lbpkit.Error, match="no axis \"w\""):
        m.stepper("w")


def test_steps_within_the_pull_out_rate_move_the_axis_exactly(router):
    stepgen = StepGen0(router)
    z0 = router.machine.position("z")
    stepgen.rate(20000)  # 25 mm/s
    router.run(200)
    assert router.machine.velocity("z") == pytest.approx(25.0, rel=1e-3)
    assert router.machine.state().axes[1].velocity == router.machine.velocity("z")
    stepgen.rate(0)
    router.run(5)
    m = router.machine
    steps = m.steps("z")
    assert steps == pytest.approx(4000, abs=25)
    assert m.lost_steps("z") == 0 and not m.stalled("z")
    assert m.position("z") == z0 + steps / STEPS_PER_MM


def test_past_the_pull_out_rate_the_motor_stalls_and_loses_the_steps(router):
    stepgen = StepGen0(router)
    z0 = router.machine.position("z")
    stepgen.rate(1.5 * PULL_OUT)
    router.run(100)
    m = router.machine
    assert m.stalled("z")
    s = m.stepper("z")
    assert s.stalled and s.lost_steps == s.steps and s.steps > 5000, repr(s)
    assert m.position("z") == pytest.approx(z0, abs=1 / STEPS_PER_MM)
    # Back within it: in step again, the lost steps stay lost.
    stepgen.rate(0)
    router.run(5)
    assert not m.stalled("z")
    assert m.lost_steps("z") >= s.lost_steps
    assert m.following_error("z") == pytest.approx(m.lost_steps("z") / STEPS_PER_MM)


def test_the_7i76_is_on_the_board_of_a_7i77_7i76_firmware(router):
    assert lbpkit.Card.sim().board.seven_i76 is None, "the 7I92's default firmware has two 7I77 slots, no 7I76"
    i76 = router.board.seven_i76
    assert i76 is not None
    assert i76.channel == I76
    assert i76.powered and i76.field_voltage == 24.0
    remote = router.remote(I76)
    assert remote.present and remote.name == "7I76"
    # An input reaches the host on channel 3, not the 7I77's.
    i76.set_input(20, True)
    assert i76.input(20) and i76.inputs == 1 << 20
    router.cycle()
    assert router.bit("input", 20, channel=I76)
    assert not router.bit("input", 20, channel=0)
    # The host's outputs and spindle command reach the terminals.
    router.set_bit("output", 3, channel=I76)
    router.set("spinout", 2.5, channel=I76)
    router.set("spinena", True, channel=I76)
    router.set("spindir", True, channel=I76)
    router.run(3)
    assert i76.output(3) and not i76.output(2) and i76.outputs == 1 << 3
    assert i76.output_voltage(3) == 24.0
    assert i76.spindle_volts == pytest.approx(2.5, abs=10 / 65535)
    assert i76.spindle_enable and i76.spindle_direction
    assert i76.faults == 0
    # Without the host its watchdog turns them off.
    router.step(0.2)
    assert not i76.output(3) and i76.spindle_volts == 0.0 and not i76.spindle_enable
    # Field power of its own.
    i76.set_field_voltage(12.0)
    assert i76.field_voltage == 12.0
    assert router.board.field_voltage() == 24.0
    with pytest.raises(IndexError, match="inputs 0..31"):
        i76.input(32)
    with pytest.raises(ValueError):
        i76.set_input_voltage(0, -1.0)


def test_card_and_pinout_choose_the_firmware():
    c = lbpkit.Card.sim(pinout="7I77+7I76")
    assert c.board.seven_i76 is not None
    assert "StepGen" in [m.name for m in c.modules]
    with pytest.raises(ValueError, match="7I99"):
        lbpkit.Card.sim(card="7I99")
    with pytest.raises(ValueError, match="no firmware \"7I77x9\""):
        lbpkit.Card.sim(pinout="7I77x9")
