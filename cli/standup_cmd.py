"""``frc standup``: joint torques that lift a robot lying on the ground onto its feet, unambiguously."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.table import Table

from frcontrol.planning import DEFAULT_FLIP_MARGIN as DEFAULT_MARGIN
from frcontrol.planning import DEFAULT_STANDUP_DURATION as DEFAULT_DURATION

from . import common, options
from .common import console

StandUpSceneArg = options.scene_argument("with [task] feet and stand_height")
HtmlOpt = options.html_option("the simulated stand-up")
ViewOpt = options.view_option("the simulated stand-up")
PlotOpt = options.plot_option("every coordinate and the contact forces over the simulated time, contact "
                              "events marked")
MarginOpt = options.margin_option("each plan")
DurationOpt = options.duration_option("Longest simulated time [s] of the closed loop (0: the first plan "
                                      "only, no simulation).")


@common.handle_errors
def standup_command(
    scene: StandUpSceneArg = "solo_standup",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    margin: MarginOpt = DEFAULT_MARGIN,
    duration: DurationOpt = DEFAULT_DURATION,
    dt: options.StepOpt = 2e-3,
    replan_every: options.ReplanOpt = 10,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
    max_time: options.MaxTimeAliasOpt = None,
) -> None:
    """Stand up: torques lifting the base to [task] stand_height with the feet in mode F.

    Each plan is the input, in the unambiguous set of the mode with the feet fixed and the body
    leaving the ground (at least --margin from every input where another mode also holds), whose
    base accelerations are closest to a critically damped lift; it is checked at its printed
    values. A rigid simulation re-plans along the motion; the verdict (stood, feet held) is read
    from its samples. No plan is a result (exit 0, "stood": false and the reason), not an error.

    \b
    Examples:
      frc standup --duration 0.1
      frc standup --json --duration 0
      frc standup --duration 0.1 --plot standup.png
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    duration = options.duration_given(duration, max_time)
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import standup_answer

    with common.live_viewer(view, port) as server:
        with common.progress("the stand-up (planned and simulated)", "s") as shown:
            answer = standup_answer(loaded, duration=duration, dt=dt, replan_every=replan_every,
                                    margin=margin, progress=shown)
        common.answer(answer.document, render, json=json)
        if plot is not None:
            _plot(answer.trajectory, plot, json=json)
        common.write_motion(loaded, answer.trajectory, html=html, out=out, json=json)
        if server is not None:
            common.show_live(server, loaded, answer.trajectory, json=json)


def _plot(trajectory: Any, plot: Path, *, json: bool) -> None:
    """``--plot``: the simulated coordinates and forces over time (nothing simulated: no figure)."""
    if trajectory is None:
        common.note("no trajectory (nothing was simulated): --plot not written", to_stderr=True)
        return
    from frcontrol.viz.plots import plot_trajectory

    plot_trajectory(trajectory, plot, coordinates=trajectory.coordinates)
    common.note(f"wrote {plot}", to_stderr=json)


def render(payload: dict[str, Any]) -> None:
    """The first plan and the closed loop's verdict as rich text and a table."""
    sim = payload["simulation"]
    if not payload["found"]:
        console.print(f"[bold]no stand-up plan[/bold]: {payload['reason']}")
        return
    console.print(f"mode {common.named_mode(payload, payload)}; "
                  f"unambiguous: yes (one rigid solution at the printed torques); margin "
                  f"{payload['margin']:g} N m")
    table = Table(title="joint torques [N m]")
    for name in payload["torques"]:
        table.add_column(name, overflow="fold")
    table.add_row(*[f"{x:.4f}" for x in payload["torques"].values()])
    console.print(table)
    units = {"x": "m/s^2", "y": "m/s^2", "theta": "rad/s^2"}
    accelerations = ", ".join(f"{k} {v:.4g} {units[k]}" for k, v in payload["accelerations"].items())
    console.print(f"base accelerations: {accelerations}")
    if not sim["simulated"]:
        console.print(sim["reason"])
        return
    base = sim["final_base"]
    if sim["stood"]:
        console.print(f"stood: yes, within {payload['tolerances']['stand']:g} m of "
                      f"{payload['task']['stand_height']:g} m from {sim['time_to_stand']:.3f} s")
    else:
        console.print(f"stood: no ({sim['reason']})")
    travel = max(sim["foot_travel"].values())
    console.print(f"feet held: {'yes' if sim['feet_held'] else 'no'} (largest travel {travel:.2e} m); base "
                  f"ends at x {base['x']:.4f} m, y {base['y']:.4f} m, theta {base['theta']:.4f} rad; "
                  f"{sim['replans']} re-plans ({sim['held']} held), {sim['timings']['total']:.2f} s")


__all__ = ["render", "standup_command"]
