"""``python -m benchmarks.profile``: exclusive stage times, the wrappers undone, and real runs.

The timer is checked on a fake clock (no timing in tests); the real workloads run once on the rod
and their stages are checked by what they must contain, not by how long they took.
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # the benchmarks beside the package; the checkout last (see test_peers)
    sys.path.append(str(REPO))

from benchmarks import profile  # noqa: E402
from frcontrol import engine, solvers  # noqa: E402


class FakeClock:
    """perf_counter advancing by 1 per reading."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1.0
        return self.now


def test_nested_stages_keep_their_exclusive_time(monkeypatch):
    clock = FakeClock()
    monkeypatch.setattr(profile.time, "perf_counter", clock)
    timer = profile.StageTimer()
    inner = timer.wrap("inner", lambda: clock())  # reads: start 1, its own 2, end 3 -> 2 inclusive
    outer = timer.wrap("outer", lambda: (clock(), inner(), clock()))
    outer()
    # outer: start 0+1 = 1 ... end: 7; inclusive 6, of which inner's 2
    assert timer.seconds == {"inner": 2.0, "outer": 4.0}
    assert timer.calls == {"inner": 1, "outer": 1}


def test_instrumented_restores_every_function():
    before = (solvers.solve, engine._overlaps, engine.ModeAnalysis.__dict__["domain"],
              engine._ModeEnumerator.grow)
    with profile.instrumented(profile.StageTimer()):
        assert solvers.solve is not before[0]
    after = (solvers.solve, engine._overlaps, engine.ModeAnalysis.__dict__["domain"],
             engine._ModeEnumerator.grow)
    assert after == before


def test_the_profiles_of_the_rod_hold_their_stages():
    analysis = profile.profile(profile.forced_analysis("rod_on_table"), runs=1)
    stages = analysis["stages"]
    assert {"assembly", "mode enumeration", "domains", "overlaps", "LPs", "Python overhead"} <= set(stages)
    assert stages["LPs"]["calls"] > 0 and stages["assembly"]["calls"] == 1
    assert abs(sum(s["share"] for s in stages.values()) - 1.0) < 1e-9
    chunk = profile.profile(profile.atlas_chunk("rod_on_table", 20), runs=1)
    assert chunk["stages"]["solutions"]["calls"] == 20 and chunk["stages"]["stability"]["calls"] > 0
    # (its two scenes, one per friction value, stay in the worker's scene cache after the warm-up)
    assert abs(sum(s["share"] for s in chunk["stages"].values()) - 1.0) < 1e-9


def test_an_unknown_scene_is_one_line_and_exit_1(capsys):
    assert profile.main(["no_such_scene"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("benchmarks.profile: ") and len(err.strip().splitlines()) == 1
