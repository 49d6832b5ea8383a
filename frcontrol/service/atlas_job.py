"""``POST /atlas``: an atlas sweep run as a job, the same run as ``frc atlas``.

The request is checked first in a request worker, within the request's time limit (``"atlas"``
in :func:`.work.execute`: the plan is built and nothing computed), so that a bad request is a 422
with the CLI's message and field path, and a scene that crashes a worker never reaches the
server's process. The job then runs :func:`frcontrol.atlas.run_atlas` on that plan from a thread of
the server's process (:meth:`.pool.JobRunner.start_thread`), so that the atlas's own executors do
the work: a local process pool of ``--workers`` processes started for the job (``frc atlas
--workers N``; always processes, never the server's own), or the Dask cluster of ``--scheduler``.
The thread only waits on them: ``GET /health`` and every other request go on meanwhile.

The scene travels to the workers as text (:class:`~frcontrol.scene_source.SceneSource`): a shipped
scene's name, or the content and URDF texts sent, rebuilt by every worker; never a path.

Limits: the job's total run is limited by ``--job-time-limit``, not by the request's
``--time-limit``; on the local pool each chunk must finish within ``--time-limit`` (a longer one
has its worker stopped and fails the job, naming the chunk: a smaller ``chunk_size`` fits). Dask
cannot stop a running task, so on a cluster only the job's limit applies. ``DELETE /jobs/{id}``
stops the run within :data:`~frcontrol.atlas.executors.STOP_POLL_INTERVAL`: the pool's workers
are stopped mid-chunk, Dask's pending chunks cancelled.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from frcontrol.errors import AtlasInterrupted, ChunkTimeLimitExceeded, FrcontrolError

from .pool import Job, JobWork

if TYPE_CHECKING:
    from frcontrol.scene_source import SceneSource


def atlas_work(plan: Mapping[str, Any], source: SceneSource, *, workers: int, scheduler: str | None,
               chunk_time_limit: float) -> JobWork:
    """The job's work: run the checked plan (its ``to_dict()``, from a request worker) on ``source``.

    Args:
        plan: :meth:`frcontrol.atlas.AtlasPlan.to_dict` of the plan the request worker built.
        source: the request's scene.
        workers: local worker processes for the chunks.
        scheduler: a Dask scheduler's address (then ``workers`` is not used).
        chunk_time_limit: [s] each chunk's limit on the local pool.
    """

    def work(job: Job, stopped: Callable[[], bool]) -> dict[str, Any]:
        from frcontrol.answers import atlas_answer
        from frcontrol.atlas import AtlasPlan, AtlasWorkers

        checked = AtlasPlan.from_dict(plan, source)
        job.points_done, job.points_total = 0, checked.size
        job.message = f"starting {workers} worker process(es)" if scheduler is None else "connecting to Dask"

        def progress(done: int, total: int) -> None:
            if job.state != "running":  # cancelled: the job shows where it stopped
                return
            job.points_done, job.points_total = done, total
            job.progress = done / total if total else None
            job.message = f"{done} of {total} points"

        try:
            where = AtlasWorkers(workers, scheduler, chunk_time_limit, in_process=False)
            answer = atlas_answer(checked, where=where, progress=progress, stop=stopped)
        except FrcontrolError as err:
            return _failure(err)
        return {"status": 200, "answer": answer.document}

    return work


def _failure(err: FrcontrolError) -> dict[str, Any]:
    """A run that failed, as an error document (without ``frc atlas``'s words about ``--out``)."""
    cause = err.__cause__ if isinstance(err, AtlasInterrupted) else None
    message = str(cause) if isinstance(cause, AtlasInterrupted) else str(err)
    loc = ["body"]
    if isinstance(err, ChunkTimeLimitExceeded):
        loc.append("chunk_size")
        message += " (each chunk has the service's time limit, frc serve --time-limit)"
    return {"status": 422, "detail": [{"loc": loc, "msg": message, "type": type(err).__name__}]}


__all__ = [
    "atlas_work",
]
