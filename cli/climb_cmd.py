"""``frc climb``: a short name for ``frc plan`` on the snake's climb, and the climbing gait (``--cycles``)."""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.table import Table

from frcontrol.planning import DEFAULT_CLIMB_MARGIN

from . import common, options
from .common import console
from .options import in_range
from .plan_cmd import render as render_plan
from .plan_cmd import write_run

ClimbSceneArg = options.scene_argument("with [[disturbances]] and the climb as [task] phases")
HtmlOpt = options.html_option("the simulated climb")
ViewOpt = options.view_option("the simulated climb")

PlotOpt = options.plot_option("every coordinate and the contact forces over the climb's run")
MarginOpt = Annotated[
    float | None,
    typer.Option("--margin", callback=in_range(low=0.0),
                 help="Robustness radius [N m or N] in the lifted (u, d) space: every phase's margin "
                      f"(default: the task's; with --cycles {DEFAULT_CLIMB_MARGIN:g})."),
]
DurationOpt = Annotated[
    float | None,
    typer.Option("--duration", "-T", callback=in_range(low=0.0, unit="[s]"),
                 help="Longest simulated time [s] of the climb's run (default: [task] max_time)."),
]
SeedOpt = Annotated[int | None, typer.Option("--seed", callback=in_range(low=0),
                                             help="With --cycles: seed of the gait's sampled disturbances "
                                                  "(>= 0; default 0).")]
ScaleOpt = Annotated[
    float | None,
    typer.Option("--scale", callback=in_range(low=0.0),
                 help="With --cycles: the disturbance scale of the gait's simulation (default 0.02, at most "
                      "the weakest phase's planned scale)."),
]
CyclesOpt = Annotated[
    int | None,
    typer.Option("--cycles", callback=in_range(low=1),
                 help="Climb by this many cycles of the gait (extend, brace the upper body, pull the lower "
                      "body up, re-brace) instead of holding one brace; --duration and --plot are then "
                      "not used."),
]


@common.handle_errors
def climb_command(
    scene: ClimbSceneArg = "snake_climb",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    margin: MarginOpt = None,
    duration: DurationOpt = None,
    seed: SeedOpt = None,
    cycles: CyclesOpt = None,
    scale: ScaleOpt = None,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Run the snake climb, the scene's task (frc plan's run), or climb by the gait (--cycles).

    Without --cycles this is frc plan on the scene's task: the brace held in mode F, unambiguously,
    for every disturbance of the scene's polytope while the head rises, re-planned along a rigid
    run; also the largest disturbance scale with such torques, and the brace's verdict from the
    samples. Its JSON is frc plan's (task, phases, outcome, simulation.samples) with the climb's
    keys (mode, torques, max_disturbance_scale, robust, simulation.brace_held...).

    \b
    Examples:
      frc climb --plot climb.png
      frc climb --margin 0.2 --json
      frc climb snake_climb --cycles 1 --html gait.html
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    for name, value in (("--scale", scale), ("--seed", seed)):
        if cycles is None and value is not None:
            raise options.usage_error(name, "it sets the gait's simulated disturbances: add --cycles N "
                                      "(the climb's run is its task's rigid run)")
    if cycles is not None and plot is not None:
        raise options.usage_error("--plot", "it draws the climb's run; with --cycles use --html "
                                  "(an animation) or --json (the samples)")
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import climb_answer

    what = "the climb (planned and simulated)" if cycles is None else "the gait"
    with common.live_viewer(view, port) as server:
        with common.progress(f"planning {what}", "s") as shown:
            answer = climb_answer(loaded, margin=margin, duration=duration, seed=seed, cycles=cycles,
                                  scale=scale, on_simulation=lambda: shown.stage(f"simulating {what}"),
                                  progress=shown)
        common.answer(answer.document, render_gait if answer.kind == "gait" else render, json=json)
        write_run(loaded, answer, plot=plot, html=html, out=out, json=json, server=server)


def render_gait(payload: dict[str, Any]) -> None:
    """The gait as rich text and tables: heights per cycle, phases' scales, the weakest phase."""
    from frcontrol.modes import mode_heading, mode_key

    sim = payload["simulation"]
    lower, upper = ", ".join(payload["lower_brace"]), ", ".join(payload["upper_brace"])
    console.print(f"gait: {payload['cycles']} cycle(s), lower brace {lower}, upper brace {upper}; "
                  f"disturbances sampled at scale {sim['scale']:.4g}")
    heights = Table(title="base height at the end of each cycle [m]")
    for name in ("cycle", "height", "rise"):
        heights.add_column(name)
    for i, (h, r) in enumerate(zip(payload["heights"], payload["rise_per_cycle"], strict=True)):
        heights.add_row(str(i + 1), f"{h:.4f}", f"{r:.4f}")
    console.print(heights)
    console.print(mode_key(payload["scene_contacts"]))
    rows = [(str(plan["cycle"]), plan["name"], plan.get("scene_mode", "-"),
             f"{plan['max_disturbance_scale']:.4g}", f"{run['max_deficit']:.3g}", f"{run['max_slip']:.3g}")
            for plan, run in zip(payload["certificates"], payload["phase_runs"], strict=False)]
    common.print_table("phases: planned largest disturbance scale, and in the simulation",
                       ("cycle", "phase", mode_heading(payload["scene_contacts"]), "max scale", "max deficit",
                        "max slip [m]"), rows)
    weakest = payload["weakest_phase"]
    console.print(f"weakest phase: {weakest['name']} (cycle {weakest['cycle']}), largest scale "
                  f"{weakest['max_disturbance_scale']:.4g}")
    for check in payload["hand_overs"][:2]:
        console.print(f"hand-over {check['name']}: mode {common.named_mode(check, payload)}, "
                      f"{check['modes_checked']} other modes checked, {len(check['held_modes'])} hold, slip "
                      f"modes: {common.named_modes(check['slip_modes'], check['contacts'], payload)}",
                      highlight=False)
    console.print(f"simulation ({sim['samples']['times'][-1]:.3g} s, rigid, {sim['phases_completed']} of "
                  f"{len(payload['certificates'])} phases): base rise {sim['rise']:.4f} m; brace "
                  f"{'held' if sim['brace_held'] else 'SLIPPED'} (max slip {sim['max_slip']:.3g} m, "
                  f"tolerance {sim['slip_tolerance']:g}); largest robustness deficit "
                  f"{sim['max_deficit']:.3g}")


def render(payload: dict[str, Any]) -> None:
    """The climb: its plan at the start, the largest scale, the brace's verdict, then frc plan's table."""
    if payload["found"]:
        console.print(f"mode {common.named_mode(payload, payload)} at the start; robust: "
                      f"{'yes' if payload['robust'] else 'NO'} ({payload['reason']})")
        common.print_table("joint torques [N m] of the first plan", list(payload["torques"]),
                           [[f"{x:.4f}" for x in payload["torques"].values()]])
    else:
        console.print(f"no climb plan: {payload['reason']}")  # an answer, not an error (exit 0)
    console.print(f"largest disturbance scale: {payload['max_disturbance_scale']:.4g}")
    sim = payload["simulation"]
    if sim["brace_held"] is not None:
        console.print(f"run ({sim['duration']:.3g} s, rigid, re-planned every {sim['replan_every']} steps): "
                      f"brace {'held' if sim['brace_held'] else 'NOT held'}; "
                      f"max slip {sim['max_slip']:.3g} m (tolerance {sim['slip_tolerance']:g}); "
                      f"head rise {sim['upper_rise']:.4g} m")
    render_plan(payload)


__all__ = [
    "climb_command",
    "render",
    "render_gait",
]
