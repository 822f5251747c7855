"""Fixtures for the Python bindings' tests (ctest PythonBindings).

ctest sets PYTHONPATH to the build tree's python/ folder and LBPKIT_BINARY
to the lbpkit tool (for the UDP tests against `lbpkit sim`).
"""

import os
import re
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
    proc = subprocess.Popen(
        [binary, "sim", "--demo", "--bind", "127.0.0.1:0", "--no-api", "--no-realtime",
         "--state", str(tmp_path / "state.bin")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # The banner's first line names the port it bound: "on UDP 127.0.0.1:PORT".
        line = proc.stdout.readline()
        match = re.search(r"on UDP ([0-9.]+):([0-9]+)", line)
        assert match, f"lbpkit sim said {line!r}; stderr: {proc.stderr.read() if proc.poll() is not None else ''}"
        yield match.group(1), int(match.group(2))
    finally:
        proc.kill()
        proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()
