"""``frc climb``: torques that hold a snake's brace in mode F for every disturbance of a polytope."""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.table import Table

from frcontrol.planning import DEFAULT_CLIMB_DURATION as DEFAULT_DURATION
from frcontrol.planning import DEFAULT_CLIMB_MARGIN as DEFAULT_MARGIN

from . import common, options
from .common import console
from .options import in_range

ClimbSceneArg = options.scene_argument("with [[disturbances]]")
HtmlOpt = options.html_option("the simulated climb")
ViewOpt = options.view_option("the simulated climb")

PlotOpt = options.plot_option("per disturbance, its polytope, the largest scale found and the "
                              "robust region at the planned torques")
MarginOpt = Annotated[
    float,
    typer.Option("--margin", callback=in_range(low=0.0),
                 help="Required robustness radius [N m or N] in the lifted (u, d) space."),
]
DurationOpt = options.duration_option("Simulated time [s] of the check under sampled disturbances.")
SeedOpt = Annotated[int, typer.Option("--seed", callback=in_range(low=0),
                                      help="Seed of the sampled disturbances (>= 0).")]
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
    margin: MarginOpt = DEFAULT_MARGIN,
    duration: DurationOpt = DEFAULT_DURATION,
    seed: SeedOpt = 0,
    cycles: CyclesOpt = None,
    scale: ScaleOpt = None,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Plan the snake climb: torques holding the brace in mode F for every disturbance.

    One set of joint torques keeps the brace contacts sticking, unambiguously, for every
    disturbance of the scene's polytope while the head accelerates upward; also the largest
    disturbance scale for which such torques exist, and a simulation under sampled disturbances.

    \b
    Examples:
      frc climb --plot climb.png
      frc climb --margin 0.2 --json
      frc climb snake_climb --cycles 1 --html gait.html
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    if cycles is None and scale is not None:
        raise options.usage_error("--scale", "it sets the gait's simulated disturbances: add --cycles N")
    if cycles is not None and plot is not None:
        raise options.usage_error("--plot", "it draws the single brace's figure; with --cycles use --html "
                                  "(an animation) or --json (the samples)")
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import climb_answer

    what = "the climb" if cycles is None else "the gait"
    with common.live_viewer(view, port) as server:
        with common.progress(f"planning {what}", "s" if cycles is None else "phases") as shown:
            answer = climb_answer(loaded, margin=margin, duration=duration, seed=seed, cycles=cycles,
                                  scale=scale, on_simulation=lambda: shown.stage(f"simulating {what}"),
                                  progress=shown)
        if answer.kind == "climb" and not answer.document["found"] and not json:
            console.print(f"no climb plan: {answer.document['reason']}")  # an answer, not an error (exit 0)
            return
        common.answer(answer.document, render_gait if answer.kind == "gait" else render, json=json)
        if plot is not None and answer.document["found"]:
            from frcontrol.viz.figures import plot_climb

            plot_climb(answer.result, plot)
            common.note(f"wrote {plot}", to_stderr=json)
        common.write_motion(loaded, answer.trajectory, html=html, out=out, json=json)
        if server is not None:
            common.show_live(server, loaded, answer.trajectory, json=json)


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
            for plan, run in zip(payload["phases"], payload["phase_runs"], strict=False)]
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
                  f"{len(payload['phases'])} phases): base rise {sim['rise']:.4f} m; brace "
                  f"{'held' if sim['brace_held'] else 'SLIPPED'} (max slip {sim['max_slip']:.3g} m, "
                  f"tolerance {sim['slip_tolerance']:g}); largest robustness deficit "
                  f"{sim['max_deficit']:.3g}")


def render(payload: dict[str, Any]) -> None:
    """The plan as rich text and a table."""
    console.print(f"mode {common.named_mode(payload, payload)} at the zero disturbance; robust: "
                  f"{'yes' if payload['robust'] else 'NO'} ({payload['reason']})")
    table = Table(title=f"joint torques [N m] (scale {payload['scale']:.4g})")
    for name in payload["torques"]:
        table.add_column(name, overflow="fold")
    table.add_row(*[f"{x:.{3}f}" for x in payload["torques"].values()])
    console.print(table)
    console.print(f"largest disturbance scale: {payload['max_disturbance_scale']:.4g} "
                  f"(bracket {payload['scale_bracket'][0]:.4g} .. {payload['scale_bracket'][1]:.4g}, "
                  f"{len(payload['bisection'])} LP step(s))")
    closest = payload["closest_mode"]
    console.print(f"robustness radius {payload['robustness_radius']:.4g} (margin {payload['margin']:g}); "
                  f"other modes excluded: {payload['modes_excluded']}"
                  + (f", closest {common.named_mode(closest, payload)} at {closest['margin']:.4g}"
                     if closest and closest["margin"] is not None else ""))
    console.print(f"head acceleration {payload['head_acceleration']:.4g} m/s^2 up at the zero disturbance, "
                  f">= {payload['worst_head_acceleration']:.4g} over the polytope "
                  f"(required {payload['min_head_acceleration']:g})")
    sim = payload["simulation"]
    if sim is not None:
        console.print(f"simulation ({sim['duration']:g} s, rigid, sampled disturbances): brace "
                      f"{'held' if sim['brace_held'] else 'NOT held'}; max slip {sim['max_slip']:.3g} m; "
                      f"head rise {sim['upper_rise']:.4g} m (max {sim['max_upper_rise']:.4g} m)")
    console.print(f"time: {1e3 * payload['timings']['total']:.1f} ms")


__all__ = [
    "climb_command",
    "render",
    "render_gait",
]
