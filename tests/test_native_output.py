"""Native output kept off stdout: HiGHS's banner never reaches a program planning through the
Python API."""

from __future__ import annotations

import ctypes
import subprocess
import sys
from pathlib import Path

import pytest

from stlplan.native_output import fd1_redirected
from tests.helpers.paths import MISSIONS, ROOT

API_RUN = """
import sys
from pathlib import Path
from stlplan import api
problem = api.validate(sys.argv[1])
result = api.solve(problem, out=sys.argv[2], animation=False)
api.check(problem, sys.argv[2] + "/trajectory.csv")
_, again = api.plan(problem)
sys.stderr.write(f"{result.status.value} {again.status.value}")
"""


@pytest.mark.heavy
def test_the_python_api_prints_nothing_on_stdout(tmp_path: Path) -> None:
    """A fresh process: HiGHS prints its banner once per process, at the first solver made."""
    mission = str(MISSIONS / "sync-pair.yaml")
    done = subprocess.run(
        [sys.executable, "-c", API_RUN, mission, str(tmp_path / "plan")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == "optimal optimal"
    assert done.stdout == ""


def _printf(text: bytes) -> None:
    libc = ctypes.CDLL(None)
    libc.printf(text)
    libc.fflush(None)


def test_fd1_redirected_sends_native_output_to_stderr_or_nowhere(
    capfd: pytest.CaptureFixture[str],
) -> None:
    with fd1_redirected(discard=False):
        _printf(b"to stderr\n")
    with fd1_redirected(discard=True):
        _printf(b"nowhere\n")
    _printf(b"back on stdout\n")
    out, err = capfd.readouterr()
    assert out == "back on stdout\n"
    assert err == "to stderr\n"
