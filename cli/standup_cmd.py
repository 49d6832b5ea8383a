"""``frc standup``: joint torques that lift a robot lying on the ground onto its feet, unambiguously."""

from __future__ import annotations

from typing import Any

from rich.table import Table

from frcontrol.planning import DEFAULT_FLIP_MARGIN as DEFAULT_MARGIN
from frcontrol.planning import DEFAULT_STANDUP_DURATION as DEFAULT_DURATION

from . import common, options
from .common import console

StandUpSceneArg = options.scene_argument("with [task] feet and stand_height")
HtmlOpt = options.html_option("the simulated stand-up")
MarginOpt = options.margin_option("each plan")
DurationOpt = options.max_time_option("the first plan only")


@common.handle_errors
def standup_command(
    scene: StandUpSceneArg = "solo_standup",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    margin: MarginOpt = DEFAULT_MARGIN,
    max_time: DurationOpt = DEFAULT_DURATION,
    dt: options.StepOpt = 2e-3,
    replan_every: options.ReplanOpt = 10,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Stand up: torques lifting the base to [task] stand_height with the feet in mode F.

    Each plan is the input, in the unambiguous set of the mode with the feet fixed and the body
    leaving the ground (at least --margin from every input where another mode also holds), whose
    base accelerations are closest to a critically damped lift; it is checked at its printed
    values. A rigid simulation re-plans along the motion; the verdict (stood, feet held) is read
    from its samples. No plan is a result (exit 0, "stood": false and the reason), not an error.

    \b
    Examples:
      frc standup --max-time 0.1
      frc standup --json --max-time 0
    """
    common.set_quiet(quiet)
    common.check_outputs(html=html, out=out)
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.planning.standup import simulate_standup

    with common.progress("the stand-up (planned and simulated)", "s") as shown:
        result = simulate_standup(
            loaded, duration=max_time, dt=dt, replan_every=replan_every, margin=margin, progress=shown)
    common.answer(result.to_dict(loaded), render, json=json)
    common.write_motion(loaded, result.trajectory, html=html, out=out, json=json)


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
