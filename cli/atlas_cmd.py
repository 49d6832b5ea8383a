"""``frc atlas``: sweep a scene over states, parameters and inputs, here or on a Dask cluster."""

from __future__ import annotations

import signal
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from .common import (
    Interrupted,
    console,
    handle_errors,
    note,
    print_json,
    progress,
    set_quiet,
)
from .model_cmds import SceneArg
from .options import (
    InputOpt,
    JsonOpt,
    QuietOpt,
    SetOpt,
    grammar,
    in_range,
    output_path,
    parse_inputs,
    plot_option,
    scene_overrides,
    usage_error,
)


class What(StrEnum):
    """``--what``'s choices (frcontrol.atlas.WHATS, spelled here so that --help imports no atlas)."""

    solutions = "solutions"
    statics = "statics"
    flip = "flip"
    climb = "climb"


WHATS = tuple(w.value for w in What)


def _parse_axes(texts: list[str]) -> None:
    from frcontrol.atlas.grid import parse_axis

    for text in texts:
        parse_axis(text)


def _check_table_out(path: Path) -> None:
    from frcontrol.atlas.store import check_out

    check_out(path)


def _check_figure_name(figure: str) -> str:
    """``--figure``: an array of some ``--what`` (which one's is checked once --what is known)."""
    from frcontrol.atlas import KIND_COLUMNS

    valid = sorted({"counts", "modes", "stable", "ambiguous"}.union(*KIND_COLUMNS.values()))
    if figure not in valid:
        raise typer.BadParameter(f"expected one of {', '.join(valid)}, got {figure!r}")
    return figure


def check_scheduler_address(address: str | None) -> str | None:
    """``--scheduler``: SCHEME://HOST:PORT (or HOST:PORT, tcp); whether it answers is checked later."""
    from urllib.parse import urlsplit

    if address is None:
        return None
    try:
        parts = urlsplit(address if "://" in address else f"tcp://{address}")
        port = parts.port
    except ValueError:
        port, parts = None, None
    if parts is None or not parts.hostname or port is None or " " in address:
        raise typer.BadParameter(f"expected tcp://HOST:PORT, got {address!r}")
    return address

VaryOpt = Annotated[
    list[str],
    typer.Option("--vary", metavar="PATH=START:STOP:N", callback=grammar(_parse_axes),
                 help="An axis of the grid: numpy.linspace(START, STOP, N) for PATH, a --set path "
                      "(contacts.tip.mu, gravity, model.stiffness, one coordinate state.q.theta or "
                      "state.v.x) or input.NAME (an input's value). Repeatable: the first is the "
                      "outermost axis of every array."),
]
WhatOpt = Annotated[
    What,
    typer.Option("--what",
                 help="What to compute at every point: solutions (count, modes, stability, "
                      "ambiguity), statics (closure, equilibrium), flip or climb (whether a plan "
                      "exists, its margin or largest disturbance scale)."),
]
AtlasOutOpt = Annotated[
    Path | None,
    typer.Option("--out", metavar="FILE", callback=output_path("--out", _check_table_out),
                 help="Write the table, one row per grid point: FILE.parquet (pyarrow) or FILE.npz. "
                      "Finished chunks are kept in FILE.parts as they come; --resume finishes an "
                      "interrupted run."),
]
PlotOpt = plot_option("the count (or --figure) over the first two axes, one colour per value")
FigureOpt = Annotated[
    str,
    typer.Option("--figure", callback=_check_figure_name,
                 help="The array --plot draws: counts, ambiguous, modes, stable, or the "
                 "kind's own (found, margin, max_disturbance_scale, form_closure_margin...)."),
]
WorkersOpt = Annotated[
    int | None,
    typer.Option("--workers", "-w", callback=in_range(low=1),
                 help="Local worker processes (default: every core; 1 runs "
                 "in this process)."),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option("--scheduler", metavar="ADDRESS", callback=check_scheduler_address,
                 help='Run on a Dask distributed cluster at tcp://HOST:PORT (pip install '
                      '"frcontrol[cluster]"; its workers need frcontrol installed).'),
]
ResumeOpt = Annotated[
    bool,
    typer.Option("--resume", help="Finish an interrupted run with the same arguments: compute only "
                 "the chunks missing from FILE.parts (refused if the arguments differ)."),
]
ChunkOpt = Annotated[
    int | None,
    typer.Option("--chunk-size", callback=in_range(low=1),
                 help="Grid points per chunk (default: the grid in about 256 "
                 "chunks, at most 64 points each)."),
]

MaxPointsOpt = Annotated[
    int | None,
    typer.Option("--max-points", callback=in_range(low=1),
                 help="The point budget: a grid of more points is refused at "
                 "once (default: 100000, frcontrol.atlas.MAX_ATLAS_POINTS)."),
]


class _Signalled(KeyboardInterrupt):
    """SIGTERM, raised where the run is, so that it stops as on Ctrl-C."""


def _raise_on_sigterm(signum: int, frame: Any) -> None:
    raise _Signalled()


@handle_errors
def atlas_command(
    scene: SceneArg,
    vary: VaryOpt,
    inputs: InputOpt = None,
    sets: SetOpt = None,
    what: WhatOpt = What.solutions,
    json: JsonOpt = False,
    out: AtlasOutOpt = None,
    plot: PlotOpt = None,
    figure: FigureOpt = "counts",
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    resume: ResumeOpt = False,
    chunk_size: ChunkOpt = None,
    max_points: MaxPointsOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Sweep a scene over a grid of states, parameters and inputs: a map of what can happen.

    \b
    Examples:
      frc atlas rod_on_table --vary state.q.theta=0.3:2.8:13 --vary contacts.tip.mu=0:2:9 --workers 1
      frc atlas rod_on_table --vary input.theta=-5:5:21 --set state.v.x=-1 --json --workers 2
      frc atlas box_on_slope --vary contacts.lower.mu=0.1:0.6:6 --what statics --out box.npz --workers 1
      frc atlas rod_on_table --vary state.q.theta=0.3:2.8:13 --vary state.v.x=-2:2:9 --plot rod.png -w 1
    """
    set_quiet(quiet)
    from frcontrol.answers import atlas_answer
    from frcontrol.atlas import MAX_ATLAS_POINTS, AtlasWorkers, build_atlas

    if resume and out is None:
        raise usage_error("--resume", "it needs --out FILE: the finished chunks are kept beside FILE")
    what_name = What(what).value
    _check_figure(figure, what_name)
    plan = build_atlas(scene, vary, what=what_name, inputs=parse_inputs(inputs),
                       overrides=scene_overrides(sets), chunk_size=chunk_size,
                       max_points=MAX_ATLAS_POINTS if max_points is None else max_points)
    previous = signal.signal(signal.SIGTERM, _raise_on_sigterm)
    try:
        with progress(f"atlas of {plan.size} points", "points") as bar:
            answer = atlas_answer(plan, where=AtlasWorkers(workers, scheduler), out=out, resume=resume,
                                  progress=bar)
    except KeyboardInterrupt as err:
        name = "SIGTERM" if isinstance(err, _Signalled) else "SIGINT"
        kept = (f"the finished chunks are kept in {out.name}.parts: run the same command with --resume "
                "to finish" if out is not None else "nothing is kept without --out")
        raise Interrupted(name, kept) from None
    finally:
        signal.signal(signal.SIGTERM, previous)
    _report(answer.document, json=json, out=out, plot=plot, figure=figure)


def _check_figure(figure: str, what: str) -> None:
    from frcontrol.atlas import KIND_COLUMNS

    valid = ("counts", "modes", "stable", "ambiguous", *KIND_COLUMNS[what])
    if figure not in valid:
        raise usage_error("--figure", f"{figure!r} is not an array of --what {what}; valid: "
                          f"{', '.join(valid)}")


def _report(doc: dict[str, Any], *, json: bool, out: Path | None, plot: Path | None, figure: str) -> None:
    if plot is not None:
        from frcontrol.viz.atlas_figure import plot_atlas

        plot_atlas(doc, plot, figure=figure)
    if json:
        print_json(doc)
    else:
        render(doc)
    for written in (out, plot):
        if written is not None:
            note(f"wrote {written}", to_stderr=json)


def render(doc: dict[str, Any]) -> None:
    """The atlas as a summary: the grid, how many points have each count, the errors, the run."""
    from collections import Counter

    def flat(node: Any, depth: int) -> list[Any]:
        return [node] if depth == 0 else [x for item in node for x in flat(item, depth - 1)]

    depth = len(doc["shape"])
    counts = flat(doc["counts"], depth)
    errors = [e for e in flat(doc["errors"], depth) if e is not None]
    ambiguous = Counter(a for a in flat(doc["ambiguous"], depth) if a is not None)
    axes = " x ".join(f"{a['path']} ({len(a['values'])})" for a in doc["axes"])
    console.print(f"{doc['scene']}: {doc['what']} over {axes}: {doc['points']} points")
    table = Table(title="rigid solutions per point")
    for col in ("solutions", "points"):
        table.add_column(col)
    for count, n in sorted(Counter(c for c in counts if c is not None).items()):
        table.add_row(str(count), str(n))
    console.print(table)
    console.print("ambiguous: " + ", ".join(f"{k} {v}" for k, v in sorted(ambiguous.items())))
    if errors:
        first = Counter(errors).most_common(1)[0]
        console.print(f"errors: {len(errors)} points (most common: {first[0]})")
    run, t = doc["run"], doc["timings"]
    console.print(f"time: {t['total']:.2f} s, {run['executor']} on {run['workers']} worker(s), "
                  f"{1e3 * t['per_point']:.2f} ms per point; {run['chunks']} chunks of {run['chunk_size']}"
                  + (f", {run['resumed_chunks']} resumed" if run["resumed_chunks"] else ""))


__all__ = [
    "WHATS",
    "check_scheduler_address",
    "atlas_command",
    "render",
]
