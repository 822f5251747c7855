# SPDX-License-Identifier: MIT
"""lbpkit: Mesa smart-serial (7I77) cards from Python.

The host library on a card over the network (``Card.open("192.168.1.121")``,
LBP16 over UDP: a 7I92 or ``lbpkit sim``) or in process (``Card.sim()``, the
virtual 7I92 + 7I77 in simulated time, optionally with a machine behind its
terminals: ``Card.sim(machine="mill")``)::

    import lbpkit
    card = lbpkit.Card.sim(machine="mill")
    card.start()                      # discover the 7I77 and start it
    card.set("analogena", True)
    card.set_bit("output", 2)         # the Z brake released
    card.set("analogout0", 2.0)       # X at 2 V: 50 mm/s
    card.run(500)                     # 0.5 s of 1 kHz cycles
    print(card.machine.position("x"), card.encoder_position(0))

Errors from the library raise ``lbpkit.Error``.
"""

from ._lbpkit import (  # noqa: F401
    FAULT_NAMES,
    Card,
    CycleStatus,
    Element,
    Error,
    MachineState,
    Module,
    Remote,
    VirtualBoard,
    VirtualMachine,
    describe_cs,
    describe_faults,
)

__all__ = [
    "FAULT_NAMES",
    "Card",
    "CycleStatus",
    "Element",
    "Error",
    "MachineState",
    "Module",
    "Remote",
    "VirtualBoard",
    "VirtualMachine",
    "describe_cs",
    "describe_faults",
    "fault_bits",
]


def fault_bits(fault_byte):
    """The names of the bits set in a 7I77 fault byte, bit 0 first."""
    return [name for bit, name in enumerate(FAULT_NAMES) if fault_byte & (1 << bit)]
