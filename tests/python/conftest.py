# SPDX-License-Identifier: MIT
"""Fixtures for the Python bindings' tests (ctest PythonBindings).

ctest sets PYTHONPATH to the build tree's python/ folder and LBPKIT_BINARY
to the lbpkit tool (for the UDP tests against `lbpkit sim`).
"""

import json
import os
import subprocess

import pytest

import lbpkit


@pytest.fixture
def card():
    """The in-process 7I92 + 7I77, both channels discovered and running."""
    c = lbpkit.Card.sim()
    c.start()
    return c


@pytest.fixture
def mill():
    """The in-process card with the example mill behind its terminals."""
    c = lbpkit.Card.sim(machine="mill")
    c.start()
    return c


@pytest.fixture
def sim_address(tmp_path):
    """`lbpkit sim --demo` on a free UDP port of 127.0.0.1 (outputs 0..15
    wired back to inputs 0..15); (address, port). Killed afterwards."""
    binary = os.environ.get("LBPKIT_BINARY")
    if not binary or not os.access(binary, os.X_OK):
        pytest.skip("LBPKIT_BINARY does not name the lbpkit tool (ctest sets it)")
    # Up when it greets on the pipe given as --ready-fd: one JSON line with
    # the address and port it bound (docs/sim.md).
    ready_read, ready_write = os.pipe()
    proc = subprocess.Popen(
        [binary, "sim", "--demo", "--bind", "127.0.0.1:0", "--no-api", "--no-realtime",
         "--state", str(tmp_path / "state.bin"), "--ready-fd", str(ready_write)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, pass_fds=(ready_write,))
    os.close(ready_write)
    try:
        with os.fdopen(ready_read) as ready:
            line = ready.readline()
        assert line, f"lbpkit sim did not start; stderr: {proc.stderr.read() if proc.poll() is not None else ''}"
        card = json.loads(line)["cards"][0]
        yield card["lbp16"]["address"], card["lbp16"]["port"]
    finally:
        proc.kill()
        proc.wait(timeout=10)
        proc.stderr.close()
