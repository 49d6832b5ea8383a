"""Worker processes for the service: a pool for requests, one process per job; both with time limits.

The server's event loop only parses, waits and answers: the work runs in other processes, so a
slow request never blocks ``GET /health``. A request that exceeds its time limit gets its worker
killed (the work cannot be interrupted otherwise) and a fresh worker takes its place. Only text
crosses a process boundary (the request's and the answer's JSON).

Every worker and job process runs under an address-space limit (``RLIMIT_AS``, ``frc serve
--worker-memory``), set once it has loaded the library: a request that needs more fails with a
:class:`MemoryError` in its own process, is answered with a 507 naming the limit, and the worker
ends and is replaced; no request can take the host's memory. A worker found dead when a request
is about to be sent to it (it died while idle) is replaced and the request goes to its successor.

A job whose work starts processes of its own (an atlas: a process pool, or a Dask client) cannot
run in a job process (a daemonic process has no children): a thread of the server's process drives
it instead (:meth:`JobRunner.start_thread`), waiting on its workers, and stops it when cancelled.
"""

from __future__ import annotations

import asyncio
import json
import logging
import multiprocessing
import os
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any

from .work import address_space, execute, keep_reserve, out_of_memory, warm_up

_CONTEXT = multiprocessing.get_context("spawn")  # no fork of a threaded server

log = logging.getLogger(__name__)

DEFAULT_WORKER_MEMORY = 4096
"""[MiB] The address space a worker or job process may add, by default, to what it uses once the
library is loaded (about 500 MiB): its requests' memory (``frc serve --worker-memory``)."""

DEFAULT_MAX_RESULT_BYTES = 256 * 2**20
"""[bytes] The finished jobs' results kept in the server's memory at most, in all (their JSON
text's length); the oldest finished jobs are forgotten first (``frc serve --max-result-bytes``)."""

THREAD_JOB_JOIN_TIMEOUT = 10.0
"""[s] How long the service's shutdown waits for a cancelled thread job to stop its workers."""


class TimeLimitExceeded(Exception):
    """A request ran past its time limit [s]."""

    def __init__(self, limit: float) -> None:
        self.limit = limit
        super().__init__(f"the request exceeded the service's time limit of {limit:g} s "
                         "(frc serve --time-limit); its work was stopped")


class WorkerLost(Exception):
    """A worker process ended while it held a request."""


def limit_memory(mib: int | None) -> None:
    """Let this process's address space grow by at most ``mib`` MiB from now (``RLIMIT_AS``; None: no limit).

    Allocations past it raise :class:`MemoryError` in this process alone.
    """
    if mib is None:
        return
    import resource

    limit = address_space() + int(mib) * 2**20
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


SINGLE_THREADED_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""The environment every worker and job process starts with (unless the server's own environment
sets these): one BLAS thread. A robot's matrices are small, so threads gain nothing; and a
multithreaded OpenBLAS that runs out of address space under ``--worker-memory`` spins instead of
raising MemoryError (the request then ran into its time limit, a 504, instead of a 507)."""


def _single_threaded_blas() -> None:
    """Set :data:`SINGLE_THREADED_BLAS` in the server's environment, which spawned processes inherit.

    The server's own BLAS, already loaded, keeps its threads.
    """
    for name, value in SINGLE_THREADED_BLAS.items():
        os.environ.setdefault(name, value)


def _worker_main(conn: Connection, memory: int | None) -> None:
    """A pool worker: answer ``(number, kind, text)`` with ``(number, answer)`` until the pipe closes.

    It ends after an answer that ran out of memory (:func:`.work.out_of_memory`), to be replaced.
    """
    warm_up()
    limit_memory(memory)
    if memory is not None:
        keep_reserve()
    conn.send("ready")
    while True:
        try:
            number, kind, text = conn.recv()
        except (EOFError, OSError):
            return
        answer = execute(kind, text)
        conn.send((number, answer))
        if out_of_memory(answer):
            return


@dataclass
class _Worker:
    process: BaseProcess
    conn: Connection


def _start_worker(memory: int | None) -> _Worker:
    """A worker process under ``memory`` MiB, returned once it has loaded the library."""
    _single_threaded_blas()
    parent, child = _CONTEXT.Pipe()
    process = _CONTEXT.Process(target=_worker_main, args=(child, memory), daemon=True,
                               name="frc-serve-worker")
    process.start()
    child.close()
    parent.recv()  # "ready"
    return _Worker(process, parent)


def _stop_worker(worker: _Worker) -> None:
    worker.conn.close()
    if worker.process.is_alive():
        worker.process.kill()
    worker.process.join(5)


class WorkerPool:
    """``workers`` processes answering requests, each within ``time_limit`` [s] from its arrival.

    Each worker runs under ``memory`` MiB of address space (None: no limit).
    """

    def __init__(self, workers: int, time_limit: float, memory: int | None = None) -> None:
        self.size = workers
        self.time_limit = time_limit
        self.memory = memory
        self._idle: asyncio.Queue[_Worker] | None = None
        self._all: list[_Worker] = []
        self._sent = 0
        self._healing = False

    async def start(self) -> None:
        """Start the workers (in parallel) and wait until each has loaded the library."""
        self._idle = asyncio.Queue()
        started = await asyncio.gather(*(asyncio.to_thread(_start_worker, self.memory)
                                         for _ in range(self.size)))
        for worker in started:
            self._all.append(worker)
            self._idle.put_nowait(worker)

    def alive(self) -> int:
        """How many workers are alive (a dead one is replaced when found)."""
        return sum(worker.process.is_alive() for worker in self._all)

    async def run(self, kind: str, text: str) -> str:
        """The answer's JSON text for a request (see :func:`frcontrol.service.work.execute`).

        A worker found dead before the request is sent to it is replaced, and the request goes to
        its successor; a worker whose answer ran out of memory is replaced after it.

        Raises:
            TimeLimitExceeded: no answer within the time limit, counted from the call (waiting for
                a free worker included).
            WorkerLost: the worker died during the request (it is replaced).
        """
        if self._idle is None:
            raise RuntimeError("the pool is not started")
        deadline = time.monotonic() + self.time_limit
        try:
            worker = await asyncio.wait_for(self._idle.get(), self.time_limit)
        except TimeoutError:
            raise TimeLimitExceeded(self.time_limit) from None
        self._sent += 1
        number = self._sent
        try:
            worker = await self._send(worker, (number, kind, text))
            while True:  # an answer to an abandoned request (its client went away) is skipped
                ready = await asyncio.to_thread(worker.conn.poll, max(0.0, deadline - time.monotonic()))
                if not ready:
                    raise TimeLimitExceeded(self.time_limit)
                answered, reply = worker.conn.recv()
                if answered == number:
                    break
            if out_of_memory(reply):
                worker = await self._replace(worker)
        except TimeLimitExceeded:
            worker = await self._replace(worker)
            raise
        except (EOFError, OSError) as err:
            worker = await self._replace(worker)
            raise WorkerLost("a worker process ended during the request (it is replaced)") from err
        finally:
            self._idle.put_nowait(worker)
        return str(reply)

    async def _send(self, worker: _Worker, message: tuple[int, str, str]) -> _Worker:
        """Send a request to ``worker``, or to its successor if it is found dead first; the one sent to."""
        for _ in range(2):
            if not worker.process.is_alive():
                log.warning("worker %s was found dead before a request; replacing it", worker.process.pid)
                worker = await self._replace(worker)
            try:
                worker.conn.send(message)
                return worker
            except (BrokenPipeError, ConnectionResetError):  # it died between the check and the send
                continue
        raise WorkerLost("no worker process could take the request (two died before it was sent)")

    async def heal(self) -> None:
        """Replace the idle workers that died while idle (one healing at a time)."""
        if self._idle is None or self._healing:
            return
        self._healing = True
        try:
            idle = [self._idle.get_nowait() for _ in range(self._idle.qsize())]
            dead = [worker for worker in idle if not worker.process.is_alive()]
            for worker in idle:
                if worker not in dead:
                    self._idle.put_nowait(worker)
            for worker in dead:
                self._idle.put_nowait(await self._replace(worker))
        finally:
            self._healing = False

    async def _replace(self, worker: _Worker) -> _Worker:
        """Kill a worker and start its successor."""
        await asyncio.to_thread(_stop_worker, worker)
        fresh = await asyncio.to_thread(_start_worker, self.memory)
        self._all[self._all.index(worker)] = fresh
        return fresh

    def stop(self) -> None:
        """Stop every worker."""
        for worker in self._all:
            _stop_worker(worker)
        self._all.clear()


def _job_main(kind: str, text: str, conn: Connection, memory: int | None) -> None:
    """A job's process (under ``memory`` MiB): progress messages, then the answer."""
    warm_up()
    limit_memory(memory)
    if memory is not None:
        keep_reserve()

    def progress(fraction: float | None, message: str) -> None:
        conn.send(("progress", fraction, message))

    conn.send(("done", execute(kind, text, progress)))
    conn.close()


@dataclass
class Job:
    """A job's record (its public part is :class:`frcontrol.service.models.JobState`)."""

    id: str
    kind: str
    started: float
    state: str = "running"
    progress: float | None = None
    message: str = "started"
    reply: dict[str, Any] | None = None
    ended: float | None = None
    points_done: int | None = None
    points_total: int | None = None
    result_bytes: int = 0
    process: BaseProcess | None = field(default=None, repr=False)
    thread: threading.Thread | None = field(default=None, repr=False)

    def public(self) -> dict[str, Any]:
        """``GET /jobs/{id}``: state, progress, and the result (done) or the error (failed)."""
        end = self.ended if self.ended is not None else time.monotonic()
        out: dict[str, Any] = {"id": self.id, "kind": self.kind, "state": self.state,
                               "progress": self.progress, "points_done": self.points_done,
                               "points_total": self.points_total, "message": self.message,
                               "elapsed": end - self.started, "result": None, "error": None}
        if self.reply is not None:
            if self.reply["status"] == 200:
                out["result"] = self.reply["answer"]
            else:
                out["error"] = {key: value for key, value in self.reply.items() if key != "status"}
        return out


JobWork = Callable[[Job, Callable[[], bool]], dict[str, Any]]
"""A job driven by a thread: ``work(job, stopped)`` updates the job's progress, polls ``stopped()``
(true once cancelled or past the time limit: then it stops its workers and returns) and returns its
reply, ``{"status": 200, "answer": ...}`` or an error document (:func:`.work.error_document`)."""


class JobRunner:
    """Jobs: each in its own process (so that it can be cancelled), at most ``max_running`` at once.

    Finished jobs are kept for ``GET /jobs/{id}``: at most ``keep`` of them, and at most
    ``max_result_bytes`` of results (their JSON text) in all, the oldest finished forgotten first;
    a result larger than ``max_result_bytes`` alone fails its job (a 507 in its ``error``). Job
    processes run under ``memory`` MiB of address space (None: no limit).
    """

    def __init__(self, max_running: int, time_limit: float, keep: int = 100,
                 max_result_bytes: int = DEFAULT_MAX_RESULT_BYTES, memory: int | None = None) -> None:
        self.max_running = max_running
        self.time_limit = time_limit
        self.keep = keep
        self.max_result_bytes = max_result_bytes
        self.memory = memory
        self.jobs: dict[str, Job] = {}
        self._lock = threading.Lock()

    def running(self) -> int:
        """How many jobs are running."""
        with self._lock:
            return sum(job.state == "running" for job in self.jobs.values())

    def start(self, kind: str, text: str) -> Job | None:
        """Start a job; None when ``max_running`` jobs already run."""
        if self.running() >= self.max_running:
            return None
        parent, child = _CONTEXT.Pipe(duplex=False)
        job = Job(id=uuid.uuid4().hex, kind=kind, started=time.monotonic())
        _single_threaded_blas()
        job.process = _CONTEXT.Process(target=_job_main, args=(kind, text, child, self.memory), daemon=True,
                                       name=f"frc-serve-job-{job.id[:8]}")
        with self._lock:
            self._forget_old()
            self.jobs[job.id] = job
        job.process.start()
        child.close()
        threading.Thread(target=self._follow, args=(job, parent), daemon=True).start()
        return job

    def start_thread(self, kind: str, work: JobWork) -> Job | None:
        """Start a job driven by a thread of this process (:data:`JobWork`); None when at the cap."""
        if self.running() >= self.max_running:
            return None
        job = Job(id=uuid.uuid4().hex, kind=kind, started=time.monotonic())
        job.thread = threading.Thread(target=self._drive, args=(job, work), daemon=True,
                                      name=f"frc-serve-job-{job.id[:8]}")
        with self._lock:
            self._forget_old()
            self.jobs[job.id] = job
        job.thread.start()
        return job

    def _drive(self, job: Job, work: JobWork) -> None:
        deadline = job.started + self.time_limit

        def stopped() -> bool:
            if job.state == "running" and time.monotonic() >= deadline:
                self._end(job, "failed", self._past_limit())
            return job.state != "running"

        try:
            reply = work(job, stopped)
        except Exception as err:  # a bug: the client gets its type, the server's log the traceback
            log.exception("job %s (%s) failed", job.id, job.kind)
            reply = {"status": 500, "detail": f"internal error ({type(err).__name__}); see the server's log"}
        ok = reply["status"] == 200
        self._end(job, "done" if ok else "failed", "done" if ok else "refused", reply,
                  len(json.dumps(reply)))

    def _past_limit(self) -> str:
        return (f"the job exceeded the service's time limit of {self.time_limit:g} s "
                "(frc serve --job-time-limit); it was stopped")

    def _follow(self, job: Job, conn: Connection) -> None:
        """Read a job's messages until it ends, is cancelled or runs out of time."""
        deadline = job.started + self.time_limit
        try:
            while job.state == "running":
                if not conn.poll(min(0.2, max(0.0, deadline - time.monotonic()))):
                    if time.monotonic() >= deadline:
                        self._end(job, "failed", self._past_limit())
                    continue
                message = conn.recv()
                if message[0] == "progress":
                    job.progress, job.message = message[1], message[2]
                    continue
                reply = json.loads(message[1])
                ok = reply["status"] == 200
                self._end(job, "done" if ok else "failed", "done" if ok else "refused", reply,
                          len(message[1]))
        except (EOFError, OSError):
            if job.state == "running":
                self._end(job, "failed", "the job's process ended without an answer")
        finally:
            conn.close()

    def _end(self, job: Job, state: str, message: str, reply: dict[str, Any] | None = None,
             size: int = 0) -> None:
        """End a running job (an ended one stays as it was) with its reply, if any, of ``size`` bytes."""
        if size > self.max_result_bytes:
            state, message, reply = "failed", "result too large", {"status": 507, "detail": (
                f"the job's result is {size} bytes, more than the service keeps ({self.max_result_bytes} "
                "bytes, frc serve --max-result-bytes): ask for less (a shorter run, fewer points)")}
            size = len(json.dumps(reply))
        with self._lock:
            if job.state != "running":
                return
            job.state, job.message, job.ended = state, message, time.monotonic()
            if reply is not None:
                job.reply, job.result_bytes = reply, size
                if state == "done":
                    job.progress = 1.0
            self._forget_old()
        if job.process is not None and job.process.is_alive():
            job.process.kill()
        if job.process is not None:
            job.process.join(5)

    def cancel(self, job_id: str) -> Job | None:
        """Cancel a job (a finished one stays as it was); None when there is no such job."""
        job = self.jobs.get(job_id)
        if job is not None:
            self._end(job, "cancelled", "cancelled by DELETE /jobs/{id}")
        return job

    def _forget_old(self) -> None:
        """Keep at most ``keep`` finished jobs and ``max_result_bytes`` of results (oldest go first)."""
        finished = sorted((j for j in self.jobs.values() if j.state != "running"),
                          key=lambda j: j.ended if j.ended is not None else j.started)
        count, total = len(finished), sum(j.result_bytes for j in finished)
        for job in finished:
            if count <= self.keep and total <= self.max_result_bytes:
                break
            del self.jobs[job.id]
            count, total = count - 1, total - job.result_bytes

    def stop(self) -> None:
        """Cancel every running job; wait (a little) for the threads' jobs to stop their workers."""
        for job in list(self.jobs.values()):
            self._end(job, "cancelled", "the service stopped")
        for job in list(self.jobs.values()):
            if job.thread is not None:
                job.thread.join(THREAD_JOB_JOIN_TIMEOUT)


__all__ = [
    "DEFAULT_MAX_RESULT_BYTES",
    "DEFAULT_WORKER_MEMORY",
    "THREAD_JOB_JOIN_TIMEOUT",
    "Job",
    "JobRunner",
    "JobWork",
    "TimeLimitExceeded",
    "WorkerLost",
    "WorkerPool",
    "limit_memory",
]
