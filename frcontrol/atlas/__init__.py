"""Atlases: sweeps of a scene over states, parameters and inputs, here or on a Dask cluster.

The flow: :func:`build_atlas` checks the arguments and builds the plan (the grid and its chunks,
nothing solved; ``grid.py``); :func:`~.points.evaluate_chunk` computes a chunk's points
(``points.py``); an executor runs the chunks (``executors.py``: serially, on a local process pool,
or on Dask); ``store.py`` keeps each finished chunk of an ``--out`` run and writes the table; and
:func:`run_atlas` ties them together into an :class:`AtlasResult`, whose :meth:`AtlasResult.to_dict`
is the ``frc atlas --json`` document.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import AtlasInterrupted, InputError
from ..jsonable import to_jsonable
from .executors import RunReport, default_workers, run_dask, run_pool, run_serial
from .grid import MAX_ATLAS_POINTS, WHATS, AtlasPlan, Axis, build_atlas, parse_axis
from .points import AMBIGUITY, KIND_COLUMNS, columns, evaluate_chunk
from .store import ChunkStore, check_out, read_table


def nest(flat: list[Any], shape: tuple[int, ...]) -> list[Any]:
    """A flat list in C order as nested lists of ``shape`` (the first axis outermost)."""
    if len(shape) <= 1:
        return list(flat)
    step = len(flat) // shape[0]
    return [nest(flat[i * step:(i + 1) * step], shape[1:]) for i in range(shape[0])]


@dataclass(frozen=True)
class AtlasResult:
    """A finished atlas.

    Attributes:
        plan: what was swept.
        rows: ``{column: [value per point]}`` in index order (:data:`~.points.COMMON_COLUMNS` and
            the kind's), plus ``index``.
        run: how the run went (executor, workers, chunks computed and resumed, worker deaths, and
            ``scene_loads``: the scenes the workers loaded from the source; the other points were
            made from a loaded scene, :mod:`frcontrol.scene_numbers`).
        timings: [s] ``total`` (wall time of this run), ``compute`` (the chunks' compute time
            summed over the processes that ran them in this run), ``per_point`` (compute over the
            points computed in this run), ``cpu_per_point`` (the same in CPU time: below
            ``per_point`` when the workers waited for a core).
    """

    plan: AtlasPlan
    rows: Mapping[str, list[Any]]
    run: Mapping[str, Any] = field(default_factory=dict)
    timings: Mapping[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The ``frc atlas --json`` document: every array nested in axis order (the first outermost)."""
        shape = self.plan.shape
        doc: dict[str, Any] = {
            "scene": self.plan.scene, "what": self.plan.what,
            "axes": [{"path": a.path, "values": a.values.tolist()} for a in self.plan.axes],
            "counts": nest(self.rows["count"], shape), "modes": nest(self.rows["modes"], shape),
            "stable": nest(self.rows["stable"], shape), "ambiguous": nest(self.rows["ambiguous"], shape),
            "errors": nest(self.rows["error"], shape),
        }
        for name in KIND_COLUMNS[self.plan.what]:
            doc[name] = nest(self.rows[name], shape)
        doc.update({"shape": list(shape), "points": self.plan.size, "max_points": self.plan.max_points,
                    "inputs": dict(self.plan.inputs),
                    "set": dict(self.plan.overrides), "fingerprint": self.plan.fingerprint,
                    "run": dict(self.run), "timings": dict(self.timings)})
        return to_jsonable(doc)


def _merge(plan: AtlasPlan, chunks: Mapping[int, Mapping[str, Any]]) -> dict[str, list[Any]]:
    rows: dict[str, list[Any]] = {"index": []}
    names = columns(plan.what)
    for name in names:
        rows[name] = []
    for chunk in range(plan.chunk_count):
        data = chunks[chunk]
        rows["index"].extend(data["index"])
        for name in names:
            rows[name].extend(data[name])
    return rows


@dataclass(frozen=True)
class AtlasWorkers:
    """Where and under what limits an atlas's chunks run (:func:`run_atlas`).

    Attributes:
        workers: local worker processes (default: every core); 1 runs in the calling process.
        scheduler: a Dask scheduler's address, ``tcp://HOST:PORT`` (then ``workers`` is ignored).
        chunk_time_limit: [s] on the local pool, a chunk running longer ends the run (its worker
            is stopped); not enforced on Dask, which cannot stop a running task.
        in_process: with one worker or one chunk, run in the calling process (False: always in
            worker processes, as a server does to keep its own process free).
    """

    workers: int | None = None
    scheduler: str | None = None
    chunk_time_limit: float | None = None
    in_process: bool = True


def run_atlas(
    plan: AtlasPlan,
    *,
    where: AtlasWorkers = AtlasWorkers(),
    out: Path | None = None,
    resume: bool = False,
    progress: Callable[[int, int], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> AtlasResult:
    """Run a plan: serially (``workers=1``), on a local pool, or on Dask (``scheduler``).

    Args:
        plan: from :func:`build_atlas`.
        where: the workers or the Dask scheduler, the chunks' time limit, and whether a one-worker
            run stays in this process (:class:`AtlasWorkers`).
        out: a ``.parquet`` or ``.npz`` table; its chunks are kept as they finish (``store.py``).
        resume: compute only the chunks missing from ``out``'s folder of finished chunks.
        progress: called as ``progress(points_done, points_total)`` once the workers are ready
            (with the resumed points), then after each chunk.
        stop: polled while the run waits; once true, the run ends (``AtlasInterrupted``), its
            workers stopped mid-chunk (a server cancels a job this way).

    Raises:
        InputError: a bad ``out`` suffix, ``resume`` without ``out``, stored chunks of other
            arguments, ``workers`` < 1, no scheduler at ``scheduler`` or Dask not installed.
        AtlasInterrupted: the run stopped early (the finished chunks stay in ``out``'s folder):
            ``stop``, a chunk past ``chunk_time_limit``, a chunk killing its workers, a lost
            scheduler.
    """
    start = time.perf_counter()
    store, found = _open_store(plan, out, resume)
    resumed = len(found)
    todo = [c for c in range(plan.chunk_count) if c not in found]
    done_points = sum(len(c["index"]) for c in found.values())
    computed = {"seconds": 0.0, "cpu_seconds": 0.0, "points": 0, "scene_loads": 0}
    def started() -> None:
        if progress is not None:
            progress(done_points, plan.size)

    def done(result: dict[str, Any]) -> None:
        nonlocal done_points
        if store is not None:
            store.add(result)
        found[int(result["chunk"])] = result
        done_points += len(result["index"])
        computed["seconds"] += float(result["seconds"])
        computed["cpu_seconds"] += float(result.get("cpu_seconds", 0.0))
        computed["points"] += len(result["index"])
        computed["scene_loads"] += int(result.get("scene_loads", 0))
        if progress is not None:
            progress(done_points, plan.size)

    try:
        report = _execute(plan, todo, done, started, where, stop)
    except AtlasInterrupted as err:
        kept = (f"{len(found)} of {plan.chunk_count} chunks are kept in {store.folder}: run the same "
                "command with --resume to finish" if store is not None else "nothing is kept without --out")
        raise type(err)(f"{err}; {kept}") from err  # the same kind of interruption
    rows = _merge(plan, found)
    if store is not None:
        store.finish(rows)
    run = {**report.to_dict(), "chunks": plan.chunk_count, "chunk_size": plan.chunk_size,
           "resumed_chunks": resumed, "scene_loads": int(computed["scene_loads"])}
    points = max(1, computed["points"])
    timings = {"total": time.perf_counter() - start, "compute": computed["seconds"],
               "per_point": computed["seconds"] / points, "cpu_per_point": computed["cpu_seconds"] / points}
    return AtlasResult(plan, rows, run, timings)


def _open_store(plan: AtlasPlan, out: Path | None, resume: bool
                ) -> tuple[ChunkStore | None, dict[int, Mapping[str, Any]]]:
    """The store of ``out`` (None without it) and the chunks it already holds (``resume``)."""
    if resume and out is None:
        raise InputError("--resume needs --out FILE: the finished chunks are kept beside FILE")
    if out is None:
        return None, {}
    check_out(out)
    store = ChunkStore(out, plan)
    return store, dict(store.open(resume))


def _execute(plan: AtlasPlan, todo: list[int], done: Callable[[dict[str, Any]], None],
             started: Callable[[], None], where: AtlasWorkers, stop: Callable[[], bool] | None) -> RunReport:
    if where.scheduler is not None:
        return run_dask(plan, todo, done, where.scheduler, started, stop)
    count = default_workers() if where.workers is None else where.workers
    if count < 1:
        raise InputError(f"--workers must be >= 1, got {count}")
    if where.in_process and (count == 1 or len(todo) <= 1):
        return run_serial(plan, todo, done, started, stop)
    return run_pool(plan, todo, done, count, started, stop, where.chunk_time_limit)


__all__ = [
    "AMBIGUITY",
    "KIND_COLUMNS",
    "MAX_ATLAS_POINTS",
    "WHATS",
    "AtlasPlan",
    "AtlasWorkers",
    "AtlasResult",
    "Axis",
    "build_atlas",
    "evaluate_chunk",
    "nest",
    "parse_axis",
    "read_table",
    "run_atlas",
]
