"""frc atlas on a real Dask cluster: the same results as serially and on the local pool, a killed
Dask worker's chunks re-run, and a killed scheduler ending the run with the finished chunks kept.

Dask is in the ``test`` extra: CI runs these. Elsewhere they skip when Dask is not installed, and
say so. Every server binds to 127.0.0.1 only.
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

from frcontrol.atlas import AtlasWorkers, build_atlas, run_atlas
from frcontrol.atlas.store import ChunkStore, parts_folder

if os.environ.get("CI") != "true":
    pytest.importorskip("distributed", reason="Dask distributed is not installed (pip install \".[test]\" "
                        "installs it; CI runs these tests)")

from distributed import Client, LocalCluster  # noqa: E402 - after the skip above

AXES = ["contacts.tip.mu=-0.4:2:12", "state.q.theta=0.3:2.8:10"]  # mu < 0: points with an error
SETS = {"state.v.x": -1.0}
CHUNK = 6
WAIT = 120.0
"""[s] The longest a run may take here (a hung run fails instead of blocking the suite)."""


@pytest.fixture(scope="module")
def plan():
    return build_atlas("rod_on_table", AXES, overrides=SETS, chunk_size=CHUNK)


@pytest.fixture(scope="module")
def serial(plan):
    return run_atlas(plan, where=AtlasWorkers(1))


@pytest.fixture(scope="module")
def cluster():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as local:
        with Client(local.scheduler_address, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=WAIT)  # both registered with the scheduler: ready
        yield local


def scheduler_address(file: Path, scheduler: subprocess.Popen) -> str:
    """The address in a scheduler file, once the file parses (Dask creates it, then writes it)."""
    deadline = time.monotonic() + WAIT
    while True:
        assert scheduler.poll() is None, "the scheduler exited"
        assert time.monotonic() < deadline, "the scheduler wrote no address"
        try:
            address = json.loads(file.read_text())["address"]
        except (OSError, ValueError, KeyError, TypeError):  # not there yet, or half written
            time.sleep(0.05)
            continue
        if isinstance(address, str) and address:
            return address
        time.sleep(0.05)


@pytest.mark.slow
def test_serial_pool_and_cluster_give_the_same_atlas(plan, serial, cluster):
    on_dask = AtlasWorkers(scheduler=cluster.scheduler_address)
    pool = run_atlas(plan, where=AtlasWorkers(2))
    dask = run_atlas(plan, where=on_dask)
    assert dask.run["executor"] == "dask" and dask.run["workers"] == 2 and pool.run["executor"] == "pool"
    assert any(serial.rows["error"]) and any(c == 0 for c in serial.rows["count"])
    assert serial.rows == pool.rows == dask.rows
    assert serial.to_dict()["counts"] == dask.to_dict()["counts"]


def test_a_killed_dask_worker_has_its_chunks_rerun(plan, serial, cluster, tmp_path):
    on_dask = AtlasWorkers(scheduler=cluster.scheduler_address)
    with Client(cluster.scheduler_address, set_as_default=False) as client:
        pids = list(client.run(os.getpid).values())
    killed = []

    def kill_one(done, total):  # after the first chunk: both workers are busy with the next ones
        if done > 0 and not killed:
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])

    out = tmp_path / "rod.npz"
    result = run_atlas(plan, where=on_dask, out=out, progress=kill_one)
    assert killed and (not Path(f"/proc/{killed[0]}").exists() or _zombie(killed[0]))
    assert result.rows == serial.rows and out.exists() and not parts_folder(out).exists()
    # the run survived one death: counted, with the chunk the worker was computing handed out again
    assert result.run["worker_deaths"] == 1
    rerun = result.run["rerun_chunks"]
    assert 1 <= len(rerun) and set(rerun) <= set(range(plan.chunk_count))
    again = run_atlas(plan, where=on_dask)  # an earlier run's deaths are not this one's
    assert again.run["worker_deaths"] == 0 and again.run["rerun_chunks"] == []


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def test_a_stopped_run_cancels_its_chunks_on_the_cluster(plan, cluster):
    on_dask = AtlasWorkers(scheduler=cluster.scheduler_address)
    from frcontrol.errors import AtlasInterrupted

    seen = []
    with pytest.raises(AtlasInterrupted, match="stopped on request"):
        run_atlas(plan, where=on_dask, progress=lambda done, total: seen.append(done),
                  stop=lambda: seen[-1] > 0 if seen else False)
    assert seen == [0, CHUNK]  # started, one chunk in, then stopped: the other chunks never came
    with Client(cluster.scheduler_address, set_as_default=False) as client:
        deadline = time.monotonic() + WAIT
        while any(client.processing().values()):  # the cancelled chunks leave the workers
            assert time.monotonic() < deadline
            time.sleep(0.1)


def _dask(*args: str) -> list[str]:
    script = Path(sys.executable).with_name("dask")
    if script.exists():
        return [str(script), *args]
    return [sys.executable, "-m", "distributed.cli.dask_" + args[0], *args[1:]]


def _frc() -> list[str]:
    script = Path(sys.executable).with_name("frc")
    return [str(script)] if script.exists() else [sys.executable, "-m", "frcontrol"]


@pytest.mark.slow
def test_a_killed_scheduler_ends_the_run_with_its_chunks_kept(serial, tmp_path):
    # one point per chunk: 120 chunks, so that the run is far from done when the scheduler dies
    plan = build_atlas("rod_on_table", AXES, overrides=SETS, chunk_size=1)
    started = []
    workers = None
    try:
        file = tmp_path / "scheduler.json"
        scheduler = subprocess.Popen(_dask("scheduler", "--host", "127.0.0.1", "--port", "0",
                                           "--no-dashboard", "--scheduler-file", str(file)),
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        started.append(scheduler)
        address = scheduler_address(file, scheduler)
        assert address.startswith("tcp://127.0.0.1:")
        workers = subprocess.Popen(_dask("worker", address, "--nworkers", "2", "--nthreads", "1",
                                         "--host", "127.0.0.1", "--no-dashboard"),
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                   start_new_session=True)
        with Client(address, set_as_default=False, timeout=f"{WAIT}s") as client:
            client.wait_for_workers(2, timeout=WAIT)  # registered: the run starts on both
        out = tmp_path / "rod.npz"
        args = [*_frc(), "atlas", "rod_on_table", "--set", "state.v.x=-1", "--chunk-size", "1",
                "--out", str(out), "--json"] + [x for axis in AXES for x in ("--vary", axis)]
        run = subprocess.Popen([*args, "--scheduler", address], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
        started.append(run)
        deadline = time.monotonic() + WAIT
        while len(ChunkStore(out, plan).finished()) < 2:  # whole chunks, as --resume reads them
            assert run.poll() is None, run.communicate()
            assert time.monotonic() < deadline, "no chunk came"
            time.sleep(0.02)
        os.killpg(workers.pid, signal.SIGSTOP)  # no chunk finishes from here on, however slow this test
        scheduler.kill()
        stdout, stderr = run.communicate(timeout=WAIT)
        assert run.returncode == 1 and stdout == ""
        errors = [line for line in stderr.splitlines() if not line.startswith("frc: atlas of ")]  # progress
        assert len(errors) == 1 and errors[0].startswith("frc: error: the Dask cluster failed"), stderr
        assert "--resume" in stderr
        kept = len(ChunkStore(out, plan).finished())
        assert kept == len(list(parts_folder(out).glob("chunk-*.json")))  # every file kept is whole
        assert 2 <= kept < plan.chunk_count
        # the chunks do not depend on where they ran: finish on this machine's pool
        resumed = subprocess.run([*args, "--resume", "--workers", "2"], capture_output=True, text=True,
                                 timeout=WAIT)
        assert resumed.returncode == 0, resumed.stderr
        doc = json.loads(resumed.stdout)
        assert doc["run"]["resumed_chunks"] == kept
        assert doc["counts"] == serial.to_dict()["counts"] and doc["errors"] == serial.to_dict()["errors"]
    finally:
        if workers is not None and workers.poll() is None:
            os.killpg(workers.pid, signal.SIGKILL)  # stopped: a SIGTERM would wait for a SIGCONT
            workers.wait(timeout=WAIT)
        for process in reversed(started):
            if process.poll() is None:
                process.terminate()
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
