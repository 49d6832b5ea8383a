"""``frc standup``: a short name for ``frc plan`` on a stand-up task, with the stand-up's own keys."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.table import Table

from . import common, options, plan_cmd
from .common import console

StandUpSceneArg = options.scene_argument("whose task is a stand-up (a phase tracking y with feet held F)")
HtmlOpt = options.html_option("the simulated stand-up")
ViewOpt = options.view_option("the simulated stand-up")
PlotOpt = options.plot_option("every coordinate and the contact forces over the simulated time, contact "
                              "events marked")


@common.handle_errors
def standup_command(
    scene: StandUpSceneArg = "solo_standup",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    margin: plan_cmd.MarginOpt = None,
    duration: plan_cmd.DurationOpt = None,
    dt: options.StepOpt = 2e-3,
    replan_every: options.ReplanOpt = 10,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
    max_time: options.MaxTimeAliasOpt = None,
) -> None:
    """Stand up: frc plan on a stand-up task, judged (stood, feet held) from the samples.

    The scene's task tracks the base's height y with the feet allowed only mode F: each plan is
    the input, at least --margin from every input where another mode also holds, closest to the
    track's targets, checked at its printed values; a rigid simulation re-plans along the motion
    (the same run as frc plan). The JSON is frc plan's (phases, outcome) with the stand-up's keys.
    No plan is a result (exit 0, "stood": false and the reason), not an error.

    \b
    Examples:
      frc standup --duration 0.1
      frc standup --json --duration 0
      frc standup --margin 100 --duration 0.01
      frc standup --duration 0.1 --plot standup.png
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    duration = duration if max_time is None else max_time
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import standup_answer

    with common.live_viewer(view, port) as server:
        with common.progress("the stand-up (planned and simulated)", "s") as shown:
            answer = standup_answer(loaded, duration=duration, dt=dt, replan_every=replan_every,
                                    margin=margin, progress=shown)
        common.answer(answer.document, render, json=json)
        trajectory = answer.trajectory
        simulated = answer.document["simulation"]["simulated"]
        if plot is not None:
            _plot(trajectory if simulated else None, plot, json=json)
        modes = None if answer.modes is None else list(answer.modes)
        common.write_motion(loaded, trajectory, html=html, out=out, json=json, modes=modes)
        if server is not None:
            common.show_live(server, loaded, trajectory, json=json, modes=modes)


def _plot(trajectory: Any, plot: Path, *, json: bool) -> None:
    """``--plot``: the simulated coordinates and forces over time (nothing simulated: no figure)."""
    if trajectory is None:
        common.note("no trajectory (nothing was simulated): --plot not written", to_stderr=True)
        return
    from frcontrol.viz.plots import plot_trajectory

    plot_trajectory(trajectory, plot, coordinates=trajectory.coordinates)
    common.note(f"wrote {plot}", to_stderr=json)


def render(payload: dict[str, Any]) -> None:
    """The first plan, the phases and outcome (as ``frc plan`` shows them) and the verdict."""
    sim = payload["simulation"]
    if payload["found"]:
        console.print(f"first plan: mode {common.named_mode(payload, payload)}; unambiguous: yes (one rigid "
                      f"solution at the printed torques); margin {payload['margin']:g} N m")
        table = Table(title="joint torques [N m]")
        for name in payload["torques"]:
            table.add_column(name, overflow="fold")
        table.add_row(*[f"{x:.4f}" for x in payload["torques"].values()])
        console.print(table)
        units = {"x": "m/s^2", "y": "m/s^2", "theta": "rad/s^2"}
        accelerations = ", ".join(f"{k} {v:.4g} {units[k]}" for k, v in payload["accelerations"].items())
        console.print(f"base accelerations: {accelerations}")
    else:
        console.print(f"[bold]no first stand-up plan[/bold]: {payload['reason']}")
    plan_cmd.render(payload)
    if not sim["simulated"]:
        console.print("not simulated (duration 0)")
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
