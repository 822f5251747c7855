# SPDX-License-Identifier: MIT
"""The host library over LBP16/UDP against `lbpkit sim --demo` (its field
outputs wired back to its inputs), started by the test on a free port."""

import lbpkit


def test_a_card_on_the_network_by_address(sim_address):
    address, port = sim_address
    card = lbpkit.Card.open(address, port=port)
    assert card.board_name == "MESA7I92"
    assert not card.in_process
    found = [r for r in card.discover() if r.present]
    assert [(r.channel, r.function) for r in found] == [(0, "field I/O"), (1, "analog")]
    assert card.read_parameter("WatchDogTime", channel=0) == 50
    card.start()
    card.set_bit("output", 3)
    # The sim follows the wall clock: a few 1 ms cycles for the output to
    # reach the terminal and come back on input 3. (A reply late on a busy
    # machine fails one cycle, not the test: the next one brings the inputs.)
    ok = 0
    for _ in range(500):
        ok += card.cycle().ok
        if card.bit("input", 3):
            break
    assert ok > 0
    assert card.get("input") & 0xFFFF == 1 << 3
    card.set_bit("output", 3, False)
    for _ in range(500):
        card.cycle()
        if not card.bit("input", 3):
            break
    assert card.get("input") & 0xFFFF == 0


def test_in_process_only_features_say_so(sim_address):
    address, port = sim_address
    card = lbpkit.Card.open(address, port=port)
    try:
        card.board
    except lbpkit.Error as e:
        assert "in-process" in str(e)
    else:
        raise AssertionError("card.board on a network card must fail")
