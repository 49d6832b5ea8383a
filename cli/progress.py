"""Progress of long commands on stderr: a fraction done and an estimate of the time left.

One helper for every command. On a terminal it is a live bar (Rich, cleared when the work ends);
when stderr is a pipe or a file it is plain lines, one every :data:`PLAIN_INTERVAL` seconds at
most, the first once the work has run :data:`SHOW_AFTER` seconds (short work prints nothing); work
that reports no fraction yet (a planner before its simulation) shows its time so far.
Either way stdout is untouched, so ``--json`` output stays one valid document. ``--quiet``
silences it.

A plain line reads::

    frc: simulating 2 s on the compliant model: 0.84 / 2 s (42%), about 9 s left
"""

from __future__ import annotations

import sys
import threading
import time
from typing import IO, Any

SHOW_AFTER = 2.0
"""[s] Work shorter than this shows no progress (a terminal's bar starts after it too)."""

PLAIN_INTERVAL = 3.0
"""[s] Least time between two plain progress lines (stderr not a terminal)."""

HEARTBEAT = 0.5
"""[s] How often the display wakes up by itself, so that work without reports (a planner before
its simulation) still shows its time so far."""


def fraction_text(done: float, total: float | None, unit: str) -> str:
    """``"0.84 / 2 s (42%)"``, or ``"12 points"`` when the total is unknown."""
    suffix = f" {unit}" if unit else ""
    if total is None or total <= 0:
        return f"{done:.4g}{suffix}"
    return f"{done:.4g} / {total:.4g}{suffix} ({100.0 * min(done / total, 1.0):.0f}%)"


def time_left_text(seconds: float | None) -> str:
    """``"about 9 s left"``, ``"about 3 min left"``, or ``"time left unknown"``."""
    if seconds is None:
        return "time left unknown"
    if seconds < 90:
        return f"about {max(seconds, 0.0):.0f} s left"
    if seconds < 5400:
        return f"about {seconds / 60:.0f} min left"
    return f"about {seconds / 3600:.1f} h left"


class Progress:
    """A command's progress display; call it as ``progress(done, total)`` as the work advances.

    ``task`` names the work ("simulating 2 s on the rigid model"); ``unit`` what ``done`` and
    ``total`` count ("s" of simulated time, "modes", "points"). :meth:`stage` renames the work (a
    planner that moves from planning to simulating). The estimate of the time left extrapolates
    the rate since the first report (resumed work is not counted as rate). Used as a context
    manager, it also shows work that reports nothing for a while (its time so far).
    """

    def __init__(self, task: str, unit: str = "", *, quiet: bool = False,
                 stream: IO[str] | None = None) -> None:
        self.task, self.unit, self.quiet = task, unit, quiet
        self.stream = sys.stderr if stream is None else stream
        self.start = time.monotonic()
        self.first: tuple[float, float] | None = None  # (time, done) of the first report
        self.last_line = float("-inf")
        self.bar: Any = None
        self.latest: tuple[float, float | None] | None = None
        self.lock = threading.Lock()
        self.stopped = threading.Event()
        self.beat: threading.Thread | None = None

    def __enter__(self) -> Progress:
        if not self.quiet:
            self.beat = threading.Thread(target=self._heartbeat, name="frc-progress", daemon=True)
            self.beat.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stopped.set()
        if self.beat is not None:
            self.beat.join()
        with self.lock:
            if self.bar is not None:
                self.bar.stop()
                self.bar = None

    def _heartbeat(self) -> None:
        while not self.stopped.wait(HEARTBEAT):
            now = time.monotonic()
            if now - self.start >= SHOW_AFTER:
                with self.lock:
                    self._show(now)

    def stage(self, task: str) -> None:
        """Rename the work (and restart the rate): a new stage of the same command."""
        with self.lock:
            self.task, self.first, self.latest = task, None, None

    def __call__(self, done: float, total: float | None = None) -> None:
        """Report ``done`` of ``total`` (None: unknown); shown when due, never on stdout."""
        if self.quiet:
            return
        now = time.monotonic()
        with self.lock:
            if self.first is None:
                self.first = (now, float(done))
            self.latest = (float(done), None if total is None else float(total))
            if now - self.start >= SHOW_AFTER:
                self._show(now)

    def seconds_left(self, now: float | None = None) -> float | None:
        """The estimated time left [s] from the rate so far, or None (no rate or no total yet)."""
        if self.first is None or self.latest is None or self.latest[1] is None:
            return None
        now = time.monotonic() if now is None else now
        (t0, done0), (done, total) = self.first, self.latest
        if done <= done0 or now <= t0:
            return None
        return (total - done) * (now - t0) / (done - done0)

    def line(self, now: float | None = None) -> str:
        """The progress as one line: the work, the fraction done and the time left."""
        if self.latest is None:
            elapsed = (time.monotonic() if now is None else now) - self.start
            return f"frc: {self.task}: {elapsed:.0f} s so far"
        done, total = self.latest
        amount = fraction_text(done, total, self.unit)
        left = time_left_text(self.seconds_left(now)) if total is not None else "total unknown"
        return f"frc: {self.task}: {amount}, {left}"

    def _show(self, now: float) -> None:
        if self.quiet:
            return
        if not self.stream.isatty():
            if now - self.last_line >= PLAIN_INTERVAL:
                self.last_line = now
                self.stream.write(self.line(now) + "\n")
                self.stream.flush()
            return
        if self.bar is None:
            self._start_bar()
        done, total = self.latest if self.latest is not None else (0.0, None)
        self.bar.update(self.bar_task, description=self.line(now).removeprefix("frc: "),
                        total=total, completed=done)

    def _start_bar(self) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, TextColumn
        from rich.progress import Progress as RichProgress

        self.bar = RichProgress(TextColumn("{task.description}"), BarColumn(),
                                console=Console(file=self.stream), transient=True)
        self.bar_task = self.bar.add_task(self.task, total=None)
        self.bar.start()


__all__ = [
    "HEARTBEAT",
    "PLAIN_INTERVAL",
    "Progress",
    "SHOW_AFTER",
    "fraction_text",
    "time_left_text",
]
