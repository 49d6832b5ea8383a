"""frc atlas as a user runs it: real processes, real signals, real kills.

One grid of the rod (sliding, so that some points have no rigid solution) is computed serially in
this process as the reference. Then ``frc atlas`` runs as a subprocess on a local pool of two
workers and is interrupted by Ctrl-C (SIGINT to its whole process group, as a terminal sends it),
by SIGTERM (to it alone), or has one of its pool workers killed (SIGKILL) mid-chunk. Every
interruption keeps the finished chunks; ``--resume`` then finishes, and every result equals the
reference. Linux only (the process tree is read from /proc).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from frcontrol.atlas import AtlasWorkers, build_atlas, read_table, run_atlas
from frcontrol.atlas.store import ChunkStore, parts_folder

pytestmark = pytest.mark.slow  # real process pools stopped by signals and kills: seconds each

AXES = ["state.q.theta=0.2:2.9:40", "contacts.tip.mu=0:2:25"]
SETS = {"state.v.x": -1.0}
CHUNK = 25
WHAT = "statics"
"""A statics atlas: most of a millisecond per point, so a worker spends its time in its chunk (a
solutions point takes some 15 us: a chunk's work would be shorter than its handing over, and a
signal or a kill would land between chunks, or after the run)."""
WAIT = 120.0
"""[s] The longest any run may take here (a hung run fails instead of blocking the suite)."""


def frc() -> list[str]:
    script = Path(sys.executable).with_name("frc")
    return [str(script)] if script.exists() else [sys.executable, "-m", "frcontrol"]


def atlas_args(out: Path, *extra: str) -> list[str]:
    args = [*frc(), "atlas", "rod_on_table", "--set", "state.v.x=-1", "--what", WHAT, "--chunk-size",
            str(CHUNK), "--workers", "2", "--out", str(out), "--json"]
    for axis in AXES:
        args += ["--vary", axis]
    return args + list(extra)


@pytest.fixture(scope="module")
def reference():
    plan = build_atlas("rod_on_table", AXES, overrides=SETS, chunk_size=CHUNK, what=WHAT)
    return plan, run_atlas(plan, where=AtlasWorkers(1))


def comparable(doc: dict) -> dict:
    return {k: v for k, v in doc.items() if k not in ("run", "timings")}


def children(pid: int) -> list[int]:
    """The process's children: from /proc/PID/task/*/children (instant), else a scan of /proc.

    The scan of every process can take longer than the rest of a run on a loaded machine, and a
    run that finishes before the test's signal reaches it would fail the test for the wrong reason.
    """
    listed = list(Path(f"/proc/{pid}/task").glob("*/children"))
    if listed:
        found: list[int] = []
        for path in listed:
            try:
                found += [int(p) for p in path.read_text().split()]
            except OSError:
                continue
        return found
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def pool_workers(pid: int) -> list[int]:
    """The frc process's pool workers: its children started by multiprocessing's spawn."""
    out = []
    for child in children(pid):
        try:
            cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
        except OSError:
            continue
        if b"spawn_main" in cmdline:
            out.append(child)
    return out


def as_from_a_terminal() -> None:
    """In the child before exec: SIGINT at its default, as a shell starts a command.

    A child inherits an ignored SIGINT across exec, and Python then leaves it ignored: if anything
    in this test process ignores SIGINT when the run starts, Ctrl-C would never reach the run.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def wait_for_chunks(out: Path, plan, count: int, process: subprocess.Popen) -> None:
    """Until ``count`` chunks of ``plan`` are whole in ``out``'s folder (parsed, as --resume reads them)."""
    deadline = time.monotonic() + WAIT
    while len(ChunkStore(out, plan).finished()) < count:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "no chunk came"
        time.sleep(0.02)


def gone(pids: list[int]) -> bool:
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        if not any(Path(f"/proc/{p}").exists() and "Z" not in _state(p) for p in pids):
            return True
        time.sleep(0.05)
    return False


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "Z"


def check_same_table(out: Path, reference_result) -> None:
    table = read_table(out)
    for name in ("count", "modes", "stable", "error"):
        assert table[name] == reference_result.rows[name], name


@pytest.mark.parametrize("how", ["SIGINT", "SIGTERM"])
def test_a_signal_keeps_the_finished_chunks_and_resume_finishes_identically(how, reference, tmp_path):
    plan, whole = reference
    out = tmp_path / "rod.npz"
    run = subprocess.Popen(atlas_args(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           cwd=tmp_path, start_new_session=True, preexec_fn=as_from_a_terminal)
    wait_for_chunks(out, plan, 1, run)
    workers = pool_workers(run.pid)  # before the third chunk: the signal must find the run going
    wait_for_chunks(out, plan, 3, run)
    if how == "SIGINT":
        os.killpg(run.pid, signal.SIGINT)  # Ctrl-C in a terminal reaches the whole process group
    else:
        os.kill(run.pid, signal.SIGTERM)
    stdout, stderr = run.communicate(timeout=WAIT)
    assert run.returncode == 128 + getattr(signal, how) and stdout == "", (
        f"exit {run.returncode}, SIGINT here {signal.getsignal(signal.SIGINT)!r}, stderr: {stderr[-300:]!r}")
    last = stderr.splitlines()[-1]
    assert last.startswith(f"frc: error: interrupted by {how}; the finished chunks are kept in rod.npz.parts")
    assert "Traceback" not in stderr
    assert workers and gone(workers), "the pool's workers outlived the run"
    kept = len(ChunkStore(out, plan).finished())
    assert kept == len(list(parts_folder(out).glob("chunk-*.json")))  # every file kept is whole
    assert 3 <= kept < plan.chunk_count and not out.exists()

    resumed = subprocess.run(atlas_args(out, "--resume"), capture_output=True, text=True, cwd=tmp_path,
                             timeout=WAIT)
    assert resumed.returncode == 0, resumed.stderr
    doc = json.loads(resumed.stdout)
    assert doc["run"]["resumed_chunks"] == kept and doc["run"]["computed_chunks"] == plan.chunk_count - kept
    assert comparable(doc) == comparable(whole.to_dict())
    check_same_table(out, whole)
    assert not parts_folder(out).exists()


def test_a_killed_pool_worker_has_its_chunk_rerun(reference, tmp_path):
    plan, whole = reference
    out = tmp_path / "rod.parquet"
    run = subprocess.Popen(atlas_args(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           cwd=tmp_path)
    wait_for_chunks(out, plan, 1, run)
    victim = pool_workers(run.pid)[0]
    os.kill(victim, signal.SIGKILL)
    stdout, stderr = run.communicate(timeout=WAIT)
    assert run.returncode == 0, stderr
    doc = json.loads(stdout)
    assert doc["run"]["worker_deaths"] == 1 and len(doc["run"]["rerun_chunks"]) == 1
    assert doc["run"]["workers"] == 2 and doc["run"]["executor"] == "pool"
    assert comparable(doc) == comparable(whole.to_dict())
    check_same_table(out, whole)
