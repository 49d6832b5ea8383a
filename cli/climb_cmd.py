"""``frc climb``: torques that hold a snake's brace in mode F for every disturbance of a polytope."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from frcontrol.planning import DEFAULT_CLIMB_DURATION as DEFAULT_DURATION
from frcontrol.planning import DEFAULT_CLIMB_MARGIN as DEFAULT_MARGIN
from frcontrol.scene import load_scene

if TYPE_CHECKING:  # the planner loads when the command runs, not for --help
    from frcontrol.planning.climb import ClimbPlan, ClimbResult

from .common import (
    check_output_files,
    console,
    fail,
    handle_errors,
    note,
    print_json,
    progress,
    serve_until_stopped,
    set_quiet,
    tell,
)
from .options import (
    JsonOpt,
    OutOpt,
    PortOpt,
    QuietOpt,
    SetOpt,
    check_out_suffix,
    html_option,
    plot_option,
    scene_overrides,
    view_option,
)

ClimbSceneArg = Annotated[
    str, typer.Argument(help="A scene file with [[disturbances]], or the name of a shipped scene.")
]
HtmlOpt = html_option("the simulated climb")
ViewOpt = view_option("the simulated climb")

PlotOpt = plot_option("per disturbance, its polytope, the largest scale found and the robust "
                      "region at the planned torques")
MarginOpt = Annotated[
    float,
    typer.Option("--margin", min=0.0,
                 help="Required robustness radius [N m or N] in the lifted (u, d) space."),
]
DurationOpt = Annotated[
    float,
    typer.Option("--duration", "-T", min=0.0,
                 help="Simulated time [s] of the check under sampled disturbances."),
]
SeedOpt = Annotated[int, typer.Option("--seed", help="Seed of the sampled disturbances.")]


def climb_payload(plan: ClimbPlan, result: ClimbResult | None) -> dict[str, Any]:
    """The ``frc climb --json`` document: ``ClimbPlan.to_dict(result)``."""
    return plan.to_dict(result)


@handle_errors
def climb_command(
    scene: ClimbSceneArg = "snake_climb",
    json: JsonOpt = False,
    html: HtmlOpt = None,
    out: OutOpt = None,
    view: ViewOpt = False,
    port: PortOpt = None,
    plot: PlotOpt = None,
    margin: MarginOpt = DEFAULT_MARGIN,
    duration: DurationOpt = DEFAULT_DURATION,
    seed: SeedOpt = 0,
    sets: SetOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Plan the snake climb: torques holding the brace in mode F for every disturbance.

    One set of joint torques keeps the brace contacts sticking, unambiguously, for every
    disturbance of the scene's polytope while the head accelerates upward; also the largest
    disturbance scale for which such torques exist, and a simulation under sampled disturbances.

    \b
    Examples:
      frc climb --plot climb.png
      frc climb --margin 0.2 --json
    """
    set_quiet(quiet)
    from frcontrol.planning.climb import plan_climb, simulate_climb

    if port is not None and not view:
        raise fail("--port needs --view")
    check_output_files(plot=plot, html=html, out=out)
    check_out_suffix(out)
    loaded = load_scene(scene, overrides=scene_overrides(sets))
    with progress("planning the climb..."):
        plan = plan_climb(loaded, margin=margin)
    if not plan.found:  # an answer, not an error (exit 0): the JSON says why
        if json:
            print_json(climb_payload(plan, None))
        else:
            console.print(f"no climb plan: {plan.reason}")
        return
    with progress("simulating the climb..."):
        result = simulate_climb(loaded, plan, duration=duration, seed=seed) if duration > 0 else None
    payload = climb_payload(plan, result)
    if json:
        print_json(payload)
    else:
        render(payload)
    if plot is not None:
        from frcontrol.viz.figures import plot_climb

        plot_climb(plan, plot)
        note(f"wrote {plot}", to_stderr=json)
    trajectory = None if result is None else result.trajectory
    if html is not None:
        from frcontrol.viz.meshcat_view import write_html

        note(f"wrote {write_html(loaded, trajectory, html)}", to_stderr=json)
    if out is not None:
        if trajectory is None:
            note("no trajectory (nothing was simulated): --out not written", to_stderr=True)
        else:
            from frcontrol.simulation.export import save_trajectory

            note(f"wrote {save_trajectory(loaded, trajectory, out)}", to_stderr=json)
    if view:
        from frcontrol.viz.meshcat_view import serve

        url = serve(loaded, trajectory, port)
        tell(f"meshcat viewer: {url}", to_stderr=json)
        serve_until_stopped(url)


def render(payload: dict[str, Any]) -> None:
    """The plan as rich text and a table."""
    console.print(f"mode {payload['mode']} at the zero disturbance; robust: "
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
                  + (f", closest {closest['mode']} at {closest['margin']:.4g}" if closest and
                     closest["margin"] is not None else ""))
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
    "climb_payload",
    "render",
]
