"""``frc flip``: hip torques that pitch RHex up from its back, unambiguously; then the closed loop."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from frcontrol.planning import DEFAULT_FLIP_MARGIN as DEFAULT_MARGIN

if TYPE_CHECKING:  # the planner loads when the command runs, not for --help
    from frcontrol.answers import Answer
    from frcontrol.scene import Scene

from . import common, options
from .common import console

FlipSceneArg = options.scene_argument("with a robot on its back")
HtmlOpt = options.html_option("the simulated flip")
ViewOpt = options.view_option("the simulated flip")

PlotOpt = options.plot_option("the input space (every mode's domain, the ambiguous overlaps "
                              "hatched, the plan) and the pitch and contact forces over the simulated time")
MarginOpt = options.margin_option("every phase's plans (the task's phases' margin)")
DurationOpt = options.duration_option("Longest simulated time [s] of the task's run, its max_time (0: the "
                                      "first plan only, no simulation).")
PumpOpt = Annotated[
    bool | None,
    typer.Option("--pump/--no-pump", help="Report the run as the pumping flip (the scene's task with "
                 "the pump's timing: push, fall back onto the legs, recirculate, push again, within the "
                 "hips' DC-motor limits): the JSON's simulation then carries every sample's drives and "
                 "limits, and 'pump' the cycles, phases and energy drawn. Default: on for a scene whose "
                 "inputs all have drives (as POST /plan/flip); --no-pump reports the same run with the "
                 "flip's keys only."),
]
CompliantOpt = Annotated[
    bool,
    typer.Option("--compliant", help="With --pump: replay the run's voltages on the compliant model "
                 "too (k = 1e6 N/m; tens of seconds)."),
]


@common.handle_errors
def flip_command(
    scene: FlipSceneArg = "rhex_flip",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    out: options.OutOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    margin: MarginOpt = DEFAULT_MARGIN,
    duration: DurationOpt = 2.0,
    dt: options.StepOpt = 1e-3,
    replan_every: options.ReplanOpt = 10,
    pump: PumpOpt = None,
    compliant: CompliantOpt = False,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
    max_time: options.MaxTimeAliasOpt = None,
) -> None:
    """Run the scene's flip task (a short name for frc plan): the pitch acceleration maximised, unambiguously.

    The scene's task runs as frc plan runs it: the first phase's torques keep its body contacts
    loaded (F, L or R), lie at least --margin from every input where another contact mode also
    holds, and are checked at their printed values; a rigid simulation re-plans along the motion
    until the body pitches past vertical. The JSON has the flip's keys and frc plan's 'outcome' and
    'phases'. No feasible flip is a result (exit 0, "flipped": false and the reason), not an error.

    \b
    Examples:
      frc flip --html flip.html --plot flip.png
      frc flip --margin 0.5 --json
      frc flip --set contacts.front_corner.mu=0.5 --out flip.csv
      frc flip rhex_flip_drives --duration 3 --plot pump.png
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    max_time = options.duration_given(duration, max_time)
    loaded = options.load_scene_with_overrides(scene, sets)
    from frcontrol.answers import FlipOptions, OptionConflict, flip_answer, pumps

    pumping = pumps(loaded, pump)
    with common.live_viewer(view, port) as server:
        task = "pumping the flip" if pumping else "planning the flip"
        with common.progress(task, "s") as shown:
            try:
                answer = flip_answer(
                    loaded, FlipOptions(margin=margin, max_time=max_time, dt=dt, replan_every=replan_every,
                                        pump=pump, compliant=compliant), progress=shown,
                    on_simulation=lambda: shown.stage(f"simulating the {'pumping ' if pumping else ''}flip "
                                                      f"(up to {max_time:g} s)"))
            except OptionConflict as err:  # an option that needs another: a usage error (exit 2)
                raise options.usage_error(f"--{err.field}", str(err)) from None
        common.answer(answer.document, render_pump if answer.kind == "pump" else render, json=json)
        if plot is not None:
            _plot(loaded, answer, plot, json=json)
        modes = None if answer.modes is None else list(answer.modes)
        common.write_motion(loaded, answer.trajectory, html=html, out=out, json=json, modes=modes)
        if server is not None:
            common.show_live(server, loaded, answer.trajectory, json=json, modes=modes)


def _plot(scene: Scene, answer: Answer, plot: Path, *, json: bool) -> None:
    """``--plot``: the plan's input space and the run (the pumping run's own figure when it pumped)."""
    if answer.kind == "pump":
        if answer.result is None:  # nothing simulated: no pumping figure
            common.note("no pumping run (nothing was simulated): --plot not written", to_stderr=True)
            return
        from frcontrol.viz.pump_figure import plot_pump

        plot_pump(scene, answer.result, plot)
    else:
        from frcontrol.viz.figures import plot_flip

        plot_flip(answer.result, plot)
    common.note(f"wrote {plot}", to_stderr=json)


def render_pump(payload: dict[str, Any]) -> None:
    """The pumping run as rich text: cycles, the outcome, the energy, the limits check."""
    from frcontrol.modes import mode_key

    sim, pump = payload["simulation"], payload.get("pump")
    if pump is None:
        first = common.named_mode(payload, payload) if payload["mode"] else "none"
        console.print(f"first push: mode {first}, torques {payload['torques']}; {sim['reason']}")
        return
    console.print(mode_key(payload["scene_contacts"]))
    rows = [(str(p["cycle"]), p["kind"], f"{p['start']:.3f}", f"{p['end']:.3f}", ", ".join(p["modes"]),
             p["ended_by"].split(" (")[0]) for p in pump["phases"]]
    common.print_table("pumping phases", ("cycle", "phase", "start [s]", "end [s]",
                                          f"modes ({' '.join(payload['scene_contacts'])})", "ended by"), rows)
    stalls = ", ".join(f"{name} {d['stall_torque']:.1f} N m / {d['no_load_speed'] or math.inf:.1f} rad/s"
                       for name, d in pump["drives"].items())
    console.print(f"drives (stall torque / no-load speed): {stalls}")
    console.print(f"cycles: {pump['cycles']}; highest pitch per cycle \\[rad]: "
                  + ", ".join(f"{x:.3f}" for x in pump["cycle_max_pitch"]))
    if sim["flipped"]:
        console.print(f"flipped: yes, vertical at {sim['time_to_vertical']:.4f} s")
    else:
        console.print(f"flipped: no ({sim['reason']})")
    console.print(f"energy drawn: {pump['energy_drawn']:.1f} J; every sample's torque within the motor's "
                  f"limits: {'yes' if sim['torque_within_limits'] else 'NO'}")
    budget = pump.get("budget")
    if budget is not None and pump.get("max_energy") is not None:
        reach = ", ".join(f"{name} {pitch:.3f}" for name, pitch in budget["reach_pitch"].items()
                          if pitch is not None)
        console.print(f"energy budget: the body's highest {pump['max_energy']:.2f} J above the start; over "
                      f"{budget['pivot']} it needs {budget['barrier_energy']:.2f} J; the toes reach the "
                      f"ground up to pitch \\[rad] {reach or 'none'}")
    _render_end_and_audit(pump)
    check = pump["compliant"]
    if check is not None:
        verdict = ("flipped" if check["flipped"]
                   else f"not flipped, highest pitch {check['max_pitch']:.3f} rad")
        console.print(f"compliant check (k = {check['stiffness']:g} N/m): {verdict}")


def _render_end_and_audit(pump: dict[str, Any]) -> None:
    """How the pumping run ended, and its energy audit, one line each."""
    if "final_pitch" in pump:
        console.print(f"end: pitch {pump['final_pitch']:.4f} rad (upright {pump['upright_pitch']:.4f}); "
                      f"right side up: {'yes' if pump['right_side_up'] else 'no'}; at rest: "
                      f"{'yes' if pump['at_rest'] else 'no'}")
    audit = pump.get("energy_audit")
    if audit:
        from frcontrol.simulation.energy_audit import AUDIT_TERMS

        terms = ", ".join(f"{name.replace('_', ' ')} {audit[name]:.1f}" for name in AUDIT_TERMS)
        console.print(f"energy audit \\[J]: {terms}; change {audit['change']:.2f}, residual "
                      f"{audit['residual']:.2f} ({100 * audit['relative_residual']:.2f} % of the largest "
                      "term)")


def render(payload: dict[str, Any]) -> None:
    """The plan and the closed loop as rich text and a table."""
    sim = payload["simulation"]
    if not payload["found"]:
        console.print(f"[bold]no flip plan[/bold]: {payload['reason']}")
        console.print(f"flipped: no ({sim['reason']})")
        return
    check = "yes (one rigid solution at the printed torques)" if payload["unambiguous"] else "NO"
    console.print(f"mode {common.named_mode(payload, payload)}; unambiguous: {check}; margin "
                  f"{payload['margin']:g} N m", highlight=False)
    table = Table(title="hip torques [N m]")
    for name in payload["torques"]:
        table.add_column(name, overflow="fold")
    table.add_row(*[f"{x:.4f}" for x in payload["torques"].values()])
    console.print(table)
    worst = " (worst case over the mode's ambiguity)" if payload["worst_case"] else ""
    console.print(f"pitch acceleration ({payload['pitch']}): {payload['pitch_acceleration']:.6g} "
                  f"rad/s^2{worst}")
    explored = common.named_modes(payload["explored"], payload["contacts"], payload)
    took = payload["timings"].get("total")
    console.print(f"candidates {common.named_modes(payload['candidates'], payload['contacts'], payload)}; "
                  f"explored {explored}" + (f"; {payload['pieces']} piece(s)" if payload["pieces"] else "")
                  + ("" if took is None else f"; plan in {1e3 * took:.1f} ms"))
    if payload["forced_inputs"]:
        console.print("forced by the model: " + ", ".join(f"{k} = {v:g}" for k, v in
                                                         payload["forced_inputs"].items()))
    if not sim["simulated"]:
        console.print(sim["reason"])
        return
    if sim["flipped"]:
        console.print(f"flipped: yes, vertical at {sim['time_to_vertical']:.4f} s")
    else:
        console.print(f"flipped: no ({sim['reason']})")
    kept = "yes" if sim["body_contact_kept"] else (
        f"no ({sim['separation']['contact']} separates at {sim['separation']['time']:.4f} s)")
    console.print(f"body contact kept: {kept}; {sim['steps']} steps, {sim['replans']} re-plans "
                  f"({sim['held']} held), {sim['timings']['total']:.2f} s")
    _render_phases(payload)


def _render_phases(payload: dict[str, Any]) -> None:
    """The task's phases as frc plan ran them, one line."""
    phases = payload.get("phases") or []
    if phases:
        console.print("phases: " + "; ".join(f"{p['name']} {p['start']:.3f}-{p['end']:.3f} s ({p['why']})"
                                             for p in phases), highlight=False)


__all__ = [
    "flip_command",
    "render",
    "render_pump",
]
