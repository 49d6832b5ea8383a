"""``frc plan``: run any scene's task given as ``[[task.phases]]``, re-planning along a rigid run."""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.table import Table

from . import common, options
from .common import console

PlanSceneArg = options.scene_argument("with [task] phases")
HtmlOpt = options.html_option("the planned run")
ViewOpt = options.view_option("the planned run")
PlotOpt = options.plot_option("every coordinate and the contact forces over the planned run")
DurationOpt = Annotated[
    float | None,
    typer.Option("--duration", "-T", callback=options.in_range(low=0.0, unit="[s]"),
                 help="Longest simulated time [s] (default: [task] max_time)."),
]
MarginOpt = Annotated[
    float | None,
    typer.Option(
        "--margin",
        callback=options.in_range(low=0.0, unit="[input units]"),
        help="Distance [input units] kept between every plan and every input "
        "where another contact mode also holds, for every phase (default: each phase's margin).",
    ),
]
CompliantOpt = Annotated[
    bool,
    typer.Option(
        "--compliant",
        help="Replay the run's inputs on the compliant model too (its samples "
        "under 'compliant' in the JSON).",
    ),
]

CyclesOpt = Annotated[
    int | None,
    typer.Option("--cycles", callback=options.in_range(low=1),
                 help="Run the scene's gait ([task.gait], e.g. snake_climb's) this many cycles, or its "
                      "task's phases this many times (repeat); default: the task as given."),
]


@common.handle_errors
def plan_command(
    scene: PlanSceneArg = "box_slide",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    margin: MarginOpt = None,
    duration: DurationOpt = None,
    dt: options.StepOpt = 1e-3,
    replan_every: options.ReplanOpt = 10,
    compliant: CompliantOpt = False,
    cycles: CyclesOpt = None,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
    max_time: options.MaxTimeAliasOpt = None,
) -> None:
    """Run the scene's task: each phase planned in its allowed modes' unambiguous set, re-planned along a run.

    Each plan is the input, at least the phase's margin from every input where another mode also
    holds, that best serves the phase's objective (maximize, minimize or track), checked at its
    printed values; a rigid simulation re-plans every --replan-every steps and moves to the next
    phase when 'until' holds. An unachieved task is a result (exit 0, outcome.achieved false with
    the reason), not an error.

    \b
    Examples:
      frc plan box_slide
      frc plan rod_pivot --json
      frc plan solo_shift --plot shift.png --html shift.html
      frc plan snake_climb --cycles 5 --html gait.html
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import plan_answer

    with common.live_viewer(view, port) as server:
        with common.progress("the task (planned and simulated)", "s") as shown:
            answer = plan_answer(loaded, dt=dt, replan_every=replan_every,
                                 max_time=duration if max_time is None else max_time, margin=margin,
                                 compliant=compliant, cycles=cycles, progress=shown)
        common.answer(answer.document, render, json=json)
        write_run(loaded, answer, plot=plot, html=html, out=out, json=json, server=server)


def write_run(loaded: Any, answer: Any, *, plot: Any, html: Any, out: Any, json: bool, server: Any) -> None:
    """A task run's figure (``--plot``: every coordinate and the contact forces), page, export and view."""
    trajectory = answer.trajectory
    if plot is not None:
        from frcontrol.viz.plots import plot_trajectory

        common.note(f"wrote {plot_trajectory(trajectory, plot, coordinates=trajectory.coordinates)}",
                    to_stderr=json)
    modes = None if answer.modes is None else list(answer.modes)
    common.write_motion(loaded, trajectory, html=html, out=out, json=json, modes=modes)
    if server is not None:
        common.show_live(server, loaded, trajectory, json=json, modes=modes)


def render(payload: dict[str, Any]) -> None:
    """The phases, their plans and the outcome as rich text and a table."""
    from frcontrol.modes import mode_heading

    table = Table(title="phases")
    planned = f"planned {mode_heading(payload['scene_contacts'])}"
    for column in ("phase", "start [s]", "end [s]", "plans", "held", planned, "ended by"):
        table.add_column(column, overflow="fold")
    for phase in payload["phases"]:
        plans = phase["plans"]
        modes = sorted({p["scene_mode"] for p in plans if p["found"]})
        table.add_row(
            phase["name"],
            f"{phase['start']:.3f}",
            f"{phase['end']:.3f}",
            str(len(plans)),
            str(sum(not p["found"] for p in plans)),
            ", ".join(modes) or "-",
            phase["why"] or "-",
        )
    console.print(table)
    for phase in payload["phases"]:
        scale = phase.get("largest_scale")
        if scale is not None:
            console.print(
                f"phase {phase['name']!r}: largest disturbance scale {scale['scale']:.4g} "
                + (f"(mode {scale['scene_mode']})" if scale["found"] else f"({scale['reason']})")
            )
    outcome = payload["outcome"]
    console.print("achieved: yes" if outcome["achieved"] else f"achieved: no ({outcome['reason']})")
    infeasible = outcome.get("infeasible")
    if infeasible is not None:
        closest = infeasible["closest_margin"]
        console.print(
            f"no plan in phase {infeasible['phase']!r} at {infeasible['time']:.3f} s: "
            f"{infeasible['reason']}"
            + (
                ""
                if closest is None
                else f"; closest margin {closest:.4g} (mode {infeasible['closest_mode']})"
            )
        )


__all__ = ["plan_command", "render", "write_run"]
