"""Ctrl-C while a command works: exit 130, one last line, no traceback, finished work kept.

Each command runs as a real `frc` process with stderr on a pseudo-terminal, so its progress
display draws as in a terminal; SIGINT is sent once that display shows the command at its work
(a simulation's model named, a planner's simulated time past zero, an atlas's first chunk file
whole on disk), never at the first sign of life. SIGINT goes to the `frc` process alone, as
`kill -INT` sends it; tests/test_atlas_processes.py sends it to a whole process group.
"""

from __future__ import annotations

import json
import os
import pty
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

WAIT = 120.0
"""[s] The longest a run may take to reach its work or to stop (a hung run fails, never blocks)."""

ESCAPES = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]|\r")
"""The terminal's cursor and colour codes, removed before stderr is read as text."""


FRC = [sys.executable, "-c", "from frcontrol.cli import main, progress; progress.SHOW_AFTER = 0.0; main()"]
"""How the runs start frc: as ``python -m frcontrol`` does (the interpreter ends by the code the
command line raised, which must survive what the signal hit; the ``frc`` script ends by the code it
was given), with the progress display due at once: what the tests wait for shows as soon
as the work reaches it, however fast the work (the display otherwise waits ``SHOW_AFTER`` seconds,
which work that got faster may never reach)."""


def as_from_a_terminal() -> None:
    """In the child before exec: SIGINT at its default, as a shell starts a command."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class Run:
    """A real `frc` process: stdout a pipe, stderr a pseudo-terminal read as it comes."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        self.master, slave = pty.openpty()
        env = {**os.environ, "COLUMNS": "200", "TERM": "xterm"}
        self.process = subprocess.Popen([*FRC, *args], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                        stderr=slave, cwd=cwd, env=env, preexec_fn=as_from_a_terminal)
        os.close(slave)
        self.raw = b""

    def read(self, timeout: float) -> bool:
        """Read what stderr has within ``timeout`` seconds; False once it is closed."""
        ready, _, _ = select.select([self.master], [], [], timeout)
        if not ready:
            return True
        try:
            chunk = os.read(self.master, 65536)
        except OSError:  # the terminal's other end closed: the process ended
            return False
        self.raw += chunk
        return bool(chunk)

    @property
    def stderr(self) -> str:
        return ESCAPES.sub("", self.raw.decode("utf-8", errors="replace"))

    def wait_for(self, working: Callable[[str], bool]) -> None:
        """Until ``working(stderr so far)`` holds; fails if the process ends first or takes too long."""
        deadline = time.monotonic() + WAIT
        while not working(self.stderr):
            if self.process.poll() is not None:
                while self.read(0.2):  # what it wrote before it ended, for the message
                    pass
                pytest.fail(f"ended (exit {self.process.returncode}) before the test saw it working: "
                            f"{self.stderr[-500:]}")
            assert time.monotonic() < deadline, f"not working within {WAIT} s: {self.stderr[-500:]}"
            self.read(0.2)

    def interrupt(self) -> tuple[int, str, str]:
        """Send SIGINT; the exit code, stdout and stderr once the process has ended."""
        self.process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + WAIT
        while self.read(0.2):
            if self.process.poll() is not None and not self.read(0.2):
                break
            assert time.monotonic() < deadline, f"still running {WAIT} s after SIGINT: {self.stderr[-500:]}"
        assert self.process.stdout is not None
        out = self.process.stdout.read().decode()
        code = self.process.wait(timeout=WAIT)
        return code, out, self.stderr

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        if self.process.stdout is not None:
            self.process.stdout.close()
        os.close(self.master)


def interrupted(args: list[str], working: Callable[[str], bool], cwd: Path) -> tuple[str, str]:
    """Run ``frc ARGS``, interrupt it once ``working`` holds: check the one-line end; stdout, stderr."""
    run = Run(args, cwd)
    try:
        run.wait_for(working)
        code, out, err = run.interrupt()
    finally:
        run.close()
    assert code == 130, (code, err[-500:])
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines[-1].startswith("frc: error: interrupted by SIGINT"), err[-500:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    return out, err


def test_ctrl_c_stops_a_compliant_simulation(tmp_path):
    """A stiff compliant run (tens of seconds): stopped as soon as its model is being integrated."""
    out, err = interrupted(["simulate", "box_on_slope", "--model", "compliant", "--stiffness", "1e6",
                            "--duration", "5", "--json"],
                           lambda text: re.search(r"simulating .*on the compliant model", text) is not None,
                           tmp_path)
    assert err.splitlines()[-1] == "frc: error: interrupted by SIGINT" and out == ""


def _gait_past_its_first_phase(text: str) -> bool:
    """The gait's run is past its first phase (1 s): its display counts simulated seconds."""
    return any(float(done) > 1.0 for done in re.findall(r"the gait[^\n]*?(\d+(?:\.\d+)?) ?/ ?\d", text))


def test_ctrl_c_stops_a_planner_in_its_work(tmp_path):
    # the climbing gait (seconds of planning, then a simulation phase by phase; its text answer is
    # short, so stdout never fills while the test waits): interrupted once its first phase of 40 is
    # done, with 39 phases (tens of seconds) still to simulate, so it cannot finish first
    out, err = interrupted(["climb", "snake_climb", "--cycles", "10", "--html", "gait.html"],
                           _gait_past_its_first_phase, tmp_path)
    assert err.splitlines()[-1] == "frc: error: interrupted by SIGINT" and out == ""
    assert list(tmp_path.iterdir()) == []  # nothing half-written


def _chunks(out: Path) -> list[Path]:
    """The atlas's finished chunk files that parse whole (as --resume reads them)."""
    whole = []
    for path in sorted(Path(f"{out}.parts").glob("chunk-*.json")):
        try:
            json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        whole.append(path)
    return whole


@pytest.mark.slow
def test_ctrl_c_stops_an_atlas_and_keeps_its_finished_chunks(tmp_path):
    # a statics atlas (most of a millisecond per point: seconds for the 80 chunks, where a solutions
    # atlas of these 4,000 points takes a tenth of a second and may finish before the signal lands)
    out = tmp_path / "rod.npz"
    args = ["atlas", "rod_on_table", "--what", "statics", "--vary", "state.q.theta=0.2:2.9:80", "--vary",
            "contacts.tip.mu=0:2:50", "--chunk-size", "50", "--workers", "1", "--out", out.name, "--json"]
    stdout, err = interrupted(args, lambda _: bool(_chunks(out)), tmp_path)
    last = err.splitlines()[-1]
    assert last.startswith("frc: error: interrupted by SIGINT; the finished chunks are kept in "
                           "rod.npz.parts"), last
    assert stdout == "" and not out.exists()
    kept = _chunks(out)
    assert 1 <= len(kept) < 80 and len(kept) == len(list(Path(f"{out}.parts").glob("chunk-*.json")))


INTERRUPT_AT_IMPORT = """
import os, signal, sys
from importlib.abc import MetaPathFinder

class InterruptOnImport(MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "typer":  # the command line's first heavy import: SIGINT arrives while it loads
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, InterruptOnImport())
from frcontrol.cli import main
main()
"""
"""A child that sends itself SIGINT the moment the command line starts to import Typer: the
interruption lands deterministically while the entry point is still loading, not during a command."""


@pytest.mark.parametrize("args", [["--help"], ["analyze", "rod_on_table"]])
def test_ctrl_c_while_the_command_line_loads_is_one_line_and_exit_130(args, tmp_path):
    # run from an empty folder: `python -c` puts the working folder first on sys.path, and the
    # checkout's source tree is not the installed package (it has no frcontrol.cli)
    done = subprocess.run([sys.executable, "-c", INTERRUPT_AT_IMPORT, *args], capture_output=True, text=True,
                          timeout=WAIT, preexec_fn=as_from_a_terminal, cwd=tmp_path)
    assert (done.returncode, done.stdout) == (130, "")
    assert done.stderr == "frc: error: interrupted by SIGINT\n", done.stderr
