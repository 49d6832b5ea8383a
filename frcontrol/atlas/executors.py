"""Where an atlas's chunks run: in this process, in a local process pool, or on a Dask cluster.

Every executor takes the plan, the chunks still to compute and a callback ``done(result)`` called in
this process, in completion order, with each finished chunk (:func:`~.points.evaluate_chunk`'s
dictionary). Every executor runs the same function on the same chunks, so the results are the same
whichever runs them.

- :func:`run_serial`: one chunk after another, here.
- :func:`run_pool`: ``workers`` processes on this machine. Each worker gets one chunk at a time over
  its own pipe, so the pool always knows which chunk each worker holds: a worker that dies
  mid-chunk (killed, out of memory) is replaced and its chunk handed out again, up to
  :data:`MAX_CHUNK_ATTEMPTS` times. Workers ignore SIGINT (a Ctrl-C in a terminal reaches the whole
  process group): this process decides, stops the workers and keeps what is finished.
- :func:`run_dask`: a Dask distributed cluster (``tcp://HOST:PORT``); the workers need frcontrol
  installed. Dask re-runs the chunks of a worker that dies; a lost scheduler ends the run with
  :class:`~frcontrol.errors.AtlasInterrupted` (the chunks finished so far are kept by the caller).
  The deaths are read from the scheduler's event log when the run ends: every worker it removed
  unannounced during the run (killed, crashed, unresponsive; not one retired on purpose), and the
  run's chunks that worker was computing or still held.

Every executor also takes ``stop``, a callable polled while the run waits (every
:data:`STOP_POLL_INTERVAL`): once it returns true, the run ends with
:class:`~frcontrol.errors.AtlasInterrupted`, the pool's workers stopped mid-chunk and Dask's
pending chunks cancelled (a server cancels a job this way). The local pool also takes
``chunk_time_limit`` [s]: a chunk that runs longer has its worker stopped and ends the run, naming
the chunk. Dask cannot stop a running task, so on a cluster only ``stop`` bounds a run.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from ..errors import AtlasInterrupted, ChunkTimeLimitExceeded, InputError
from .grid import AtlasPlan
from .points import evaluate_chunk

ChunkCallback = Callable[[dict[str, Any]], None]
StartCallback = Callable[[], None]
StopCallback = Callable[[], bool]

WORKER_NAME = "frc-atlas-worker"
"""The name of the local pool's worker processes (``multiprocessing.active_children()``)."""

STOP_POLL_INTERVAL = 0.2
"""[s] How often a run with a ``stop`` callable or a chunk time limit checks them while it waits."""

MAX_CHUNK_ATTEMPTS = 3
"""How many times a chunk is handed out before its worker's deaths count as the chunk's fault
(then the run stops with an error naming the chunk)."""

WORKER_START_METHOD = "spawn"
"""How pool workers start: a fresh interpreter each, with this process's ``sys.path``, free of its
threads, on every platform. (A fork server that preloads frcontrol starts faster, but on Python 3.11
it imports with the working directory first on its path: run from a source checkout, it would
load the checkout's frcontrol instead of the installed one.)"""


@dataclass
class RunReport:
    """How a run went.

    Attributes:
        executor: ``"serial"``, ``"pool"`` or ``"dask"``.
        workers: the workers used (the cluster's at the start for Dask).
        computed: the chunks computed in this run.
        worker_deaths: workers that died mid-run: pool workers (each replaced), or Dask workers the
            scheduler removed unannounced (module docstring).
        rerun: the chunks handed out again after their worker died.
    """

    executor: str
    workers: int
    computed: int = 0
    worker_deaths: int = 0
    rerun: list[int] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON values."""
        return {"executor": self.executor, "workers": self.workers, "computed_chunks": self.computed,
                "worker_deaths": self.worker_deaths, "rerun_chunks": sorted(self.rerun)}


def _nothing() -> None:
    return None


def check_stop(stop: StopCallback | None) -> None:
    """Raise :class:`~frcontrol.errors.AtlasInterrupted` once ``stop()`` is true."""
    if stop is not None and stop():
        raise AtlasInterrupted("the run was stopped on request")


def run_serial(plan: AtlasPlan, chunks: Sequence[int], done: ChunkCallback,
               started: StartCallback = _nothing, stop: StopCallback | None = None) -> RunReport:
    """Every chunk in this process, in order (``started()`` first; ``stop`` polled between chunks)."""
    report = RunReport("serial", 1)
    started()
    for chunk in chunks:
        check_stop(stop)
        done(evaluate_chunk(plan, chunk))
        report.computed += 1
    return report


def _worker_main(connection: Any, plan: AtlasPlan) -> None:
    """A pool worker: evaluate the chunks sent over ``connection`` until None (or the pipe closes)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        try:
            chunk = connection.recv()
        except (EOFError, OSError):  # the parent is gone
            return
        if chunk is None:
            return
        connection.send(evaluate_chunk(plan, chunk))


class _Pool:
    """Worker processes, each with its own pipe and at most one chunk at a time."""

    def __init__(self, plan: AtlasPlan, workers: int) -> None:
        import multiprocessing as mp

        self.context: Any = mp.get_context(WORKER_START_METHOD)
        self.plan = plan
        self.workers: dict[Any, tuple[Any, Any]] = {}  # process sentinel -> (process, connection)
        self.holding: dict[Any, int] = {}  # sentinel -> the chunk the worker is computing
        self.since: dict[Any, float] = {}  # sentinel -> when it got its chunk (time.monotonic)
        for _ in range(workers):
            self.start_worker()

    def start_worker(self) -> None:
        import threading

        parent, child = self.context.Pipe()
        process = self.context.Process(target=_worker_main, args=(child, self.plan), daemon=True,
                                       name=WORKER_NAME)
        # A worker starts with SIGINT ignored (inherited across exec; Python then leaves it so), so
        # that a Ctrl-C to the process group while it imports frcontrol prints no traceback.
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            process.start()
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)
        child.close()
        self.workers[process.sentinel] = (process, parent)

    def idle(self) -> list[Any]:
        return [s for s in self.workers if s not in self.holding]

    def send(self, sentinel: Any, chunk: int) -> None:
        import time

        self.workers[sentinel][1].send(chunk)
        self.holding[sentinel] = chunk
        self.since[sentinel] = time.monotonic()

    def check_time(self, limit: float | None) -> None:
        """Raise :class:`~frcontrol.errors.ChunkTimeLimitExceeded` for a chunk held past ``limit`` [s]."""
        import time

        if limit is None:
            return
        now = time.monotonic()
        for sentinel, chunk in self.holding.items():
            if now - self.since[sentinel] > limit:
                raise ChunkTimeLimitExceeded(f"chunk {chunk} ran past the time limit of {limit:g} s per "
                                             "chunk (its worker was stopped); a smaller chunk size keeps "
                                             "chunks within it")

    def close(self) -> None:
        for _, connection in self.workers.values():
            try:
                connection.send(None)
            except (BrokenPipeError, OSError):
                pass
        for process, connection in self.workers.values():
            if self.holding and process.is_alive():
                process.terminate()  # mid-chunk after an interruption: its chunk is not finished
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join()
            connection.close()
        self.workers.clear()


def run_pool(plan: AtlasPlan, chunks: Sequence[int], done: ChunkCallback, workers: int,
             started: StartCallback = _nothing, stop: StopCallback | None = None,
             chunk_time_limit: float | None = None) -> RunReport:
    """The chunks on ``workers`` local processes (module docstring); ``started()`` once they are up.

    Raises:
        InputError: ``workers`` < 1.
        AtlasInterrupted: a chunk's worker died :data:`MAX_CHUNK_ATTEMPTS` times, ``stop()`` became
            true, or a chunk ran past ``chunk_time_limit`` [s].
    """
    from multiprocessing.connection import wait

    if workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    todo = list(reversed(chunks))
    report = RunReport("pool", workers)
    attempts: dict[int, int] = {}
    pool = _Pool(plan, min(workers, max(1, len(chunks))))
    timeout = None if stop is None and chunk_time_limit is None else STOP_POLL_INTERVAL
    try:
        started()
        while todo or pool.holding:
            check_stop(stop)
            pool.check_time(chunk_time_limit)
            for sentinel in pool.idle():
                if not todo:
                    break
                chunk = todo.pop()
                attempts[chunk] = attempts.get(chunk, 0) + 1
                pool.send(sentinel, chunk)
            by_connection = {conn: s for s, (_, conn) in pool.workers.items()}
            for ready in wait(list(by_connection) + list(pool.workers), timeout):
                sentinel = by_connection.get(ready, ready)
                if sentinel not in pool.workers:
                    continue
                process, connection = pool.workers[sentinel]
                try:
                    result = connection.recv() if ready is connection or connection.poll() else None
                except (EOFError, OSError):
                    result = None
                if result is not None:
                    pool.holding.pop(sentinel, None)
                    done(result)
                    report.computed += 1
                    continue
                if process.is_alive():
                    continue
                _replace_dead(pool, sentinel, todo, attempts, report)
    finally:
        pool.close()
    return report


def _replace_dead(pool: _Pool, sentinel: Any, todo: list[int], attempts: dict[int, int],
                  report: RunReport) -> None:
    """A worker died: hand its chunk out again and start another worker."""
    process, connection = pool.workers.pop(sentinel)
    connection.close()
    process.join()
    report.worker_deaths += 1
    chunk = pool.holding.pop(sentinel, None)
    if chunk is not None:
        if attempts[chunk] >= MAX_CHUNK_ATTEMPTS:
            raise AtlasInterrupted(f"chunk {chunk} killed its worker {attempts[chunk]} times "
                                   f"(last exit code {process.exitcode})")
        report.rerun.append(chunk)
        todo.append(chunk)
    pool.start_worker()


def run_dask(plan: AtlasPlan, chunks: Sequence[int], done: ChunkCallback, address: str,
             started: StartCallback = _nothing, stop: StopCallback | None = None) -> RunReport:
    """The chunks on the Dask cluster at ``address`` (``tcp://HOST:PORT``); ``started()`` once connected.

    Raises:
        InputError: Dask is not installed (``pip install "frcontrol[cluster]"``), or no scheduler
            answers at ``address``.
        AtlasInterrupted: the scheduler was lost mid-run, a chunk failed on the cluster, or
            ``stop()`` became true (the pending chunks are cancelled).
    """
    with _dask_client(address) as client:
        from distributed import as_completed

        return _dask_chunks(client, plan, chunks, done, started, as_completed, stop)


def check_scheduler(address: str) -> int:
    """The number of workers of the Dask scheduler at ``address`` (a program checks it at its start).

    Raises:
        InputError: Dask is not installed, or no scheduler answers at ``address``.
    """
    with _dask_client(address) as client:
        return len(client.scheduler_info().get("workers", {}))


@contextmanager
def _dask_client(address: str) -> Iterator[Any]:
    """A Dask client of ``address``, closed at the end; Dask's own log silenced meanwhile."""
    import logging

    try:
        from distributed import Client
    except ImportError as err:
        raise InputError('--scheduler needs Dask distributed: pip install "frcontrol[cluster]" '
                         '(or pip install "dask[distributed]")') from err
    # Dask's own logs (a lost connection, with tracebacks) are not the answer: the error says it.
    silence = logging.Filter("frcontrol")
    handlers = logging.getLogger("distributed").handlers + logging.getLogger().handlers
    for handler in handlers:
        handler.addFilter(silence)
    try:
        try:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError) as err:
            raise InputError(f"--scheduler {address}: no Dask scheduler answers there "
                             f"({_one_line(err)})") from err
        try:
            yield client
        finally:
            client.close(timeout=DASK_CLOSE_TIMEOUT)
    finally:
        for handler in handlers:
            handler.removeFilter(silence)


def _one_line(err: BaseException) -> str:
    return " ".join(f"{type(err).__name__}: {err}".split())


def _dask_chunks(client: Any, plan: AtlasPlan, chunks: Sequence[int], done: ChunkCallback,
                 started: StartCallback, as_completed: Any, stop: StopCallback | None) -> RunReport:
    import threading

    report = RunReport("dask", len(client.scheduler_info().get("workers", {})))
    since = _last_event_time(client)
    started()
    prefix = f"atlas-{plan.fingerprint[:16]}-"
    futures = [client.submit(evaluate_chunk, plan, chunk, key=f"{prefix}{chunk}", pure=False,
                             retries=MAX_CHUNK_ATTEMPTS - 1) for chunk in chunks]
    finished = threading.Event()

    def watch() -> None:  # a stop request cancels the pending chunks, which ends the wait below
        while not finished.wait(STOP_POLL_INTERVAL):
            if stop is not None and stop():
                client.cancel(futures)
                return

    if stop is not None:
        threading.Thread(target=watch, daemon=True, name="frc-atlas-stop").start()
    try:
        for future in as_completed(futures, loop=client.loop):
            check_stop(stop)
            try:
                result = future.result()
            except Exception as err:  # noqa: BLE001 - a lost scheduler, a chunk that kept killing workers
                raise AtlasInterrupted(f"the Dask cluster failed: {_one_line(err)}") from err
            done(result)
            report.computed += 1
            future.release()
    finally:
        finished.set()
    _count_lost_workers(client, since, prefix, report)
    return report


def _last_event_time(client: Any) -> float:
    """The scheduler's time of its latest cluster event (0 if none): later events are this run's."""
    return max((float(stamp) for stamp, _ in client.get_events("all")), default=0.0)


def _count_lost_workers(client: Any, since: float, prefix: str, report: RunReport) -> None:
    """Count in ``report`` the workers the scheduler removed unannounced after ``since``.

    Their chunks (keys ``prefix`` + number) that they were computing or held are the rerun ones.
    """
    for stamp, event in client.get_events("all"):
        if float(stamp) <= since or not isinstance(event, dict) or event.get("action") != "remove-worker":
            continue
        if event.get("expected"):
            continue  # retired on purpose, its chunks moved away: not a death
        report.worker_deaths += 1
        keys = [*event.get("processing-tasks", ()), *event.get("lost-computed-tasks", ())]
        report.rerun += [int(str(key)[len(prefix):]) for key in keys if str(key).startswith(prefix)]


DASK_CONNECT_TIMEOUT = "10s"
"""How long to wait for the scheduler to answer at the start."""

DASK_CLOSE_TIMEOUT = 5
"""[s] How long closing the client may take (a lost scheduler does not answer)."""


def default_workers() -> int:
    """All of this machine's cores available to this process."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


__all__ = [
    "DASK_CLOSE_TIMEOUT",
    "DASK_CONNECT_TIMEOUT",
    "MAX_CHUNK_ATTEMPTS",
    "STOP_POLL_INTERVAL",
    "WORKER_NAME",
    "WORKER_START_METHOD",
    "ChunkCallback",
    "RunReport",
    "StopCallback",
    "check_scheduler",
    "check_stop",
    "default_workers",
    "run_dask",
    "run_pool",
    "run_serial",
]
