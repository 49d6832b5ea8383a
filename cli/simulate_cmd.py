"""``frc simulate``: a trajectory on the rigid or the compliant contact model."""

from __future__ import annotations

import sys
from enum import StrEnum
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from frcontrol.simulation import INTEGRATORS

if TYPE_CHECKING:  # the simulators load when the command runs, not for --help
    from frcontrol.answers import Answer
    from frcontrol.scene import Scene
    from frcontrol.simulation.trajectory import Trajectory

from . import common, options
from .common import console
from .options import in_range

MAX_EVENTS_SHOWN = 40
"""Events listed in the table (all of them are in ``--json``)."""


class ContactModel(StrEnum):
    """The contact models."""

    rigid = "rigid"
    compliant = "compliant"


ModelOpt = Annotated[
    ContactModel | None,
    typer.Option("--model", "-m", help="Contact model (default: the scene's [model] contact, else rigid)."),
]
StiffnessOpt = Annotated[
    float | None,
    typer.Option("--stiffness", "-k", callback=in_range(above=0.0, unit="[N/m]"),
                 help="Compliant contact stiffness k [N/m] for every contact "
                 "(default: the scene's [model], else 1e5)."),
]
DampingOpt = Annotated[
    float | None,
    typer.Option("--damping", callback=in_range(low=0.0, unit="[N s/m]"),
                 help="Compliant contact damping b [N s/m] (default: critical for each "
                 "contact's effective mass)."),
]
DtOpt = Annotated[
    float,
    typer.Option("--dt", callback=in_range(above=0.0, unit="[s]"),
                 help="Rigid: the time step [s]. Compliant: the sample interval and control "
                      "period [s] (the integrator adapts its own steps)."),
]
DurationOpt = options.duration_option("Simulated time [s].")


def _check_integrator(name: str) -> str:
    if name not in INTEGRATORS:
        raise typer.BadParameter(f"expected one of {', '.join(INTEGRATORS)}, got {name!r}")
    return name


IntegratorOpt = Annotated[
    str,
    typer.Option("--integrator", callback=_check_integrator,
                 help=f"Compliant model's integrator: {', '.join(INTEGRATORS)}."),
]
EveryOpt = Annotated[
    int,
    typer.Option("--every", callback=in_range(low=1),
                 help="Keep every N-th sample (and the last) in --json's samples: a document about N "
                      "times smaller; the summary and the events stay the whole run's."),
]
HtmlOpt = options.html_option("the trajectory")
PlotOpt = options.plot_option("every coordinate and the contact forces over time, contact events marked")


@common.handle_errors
def simulate_command(
    scene: options.SceneArg,
    model: ModelOpt = None,
    stiffness: StiffnessOpt = None,
    damping: DampingOpt = None,
    dt: DtOpt = 1e-3,
    duration: DurationOpt = 1.0,
    inputs: options.InputOpt = None,
    integrator: IntegratorOpt = "radau",
    json: options.JsonOpt = False,
    html: HtmlOpt = None,
    plot: PlotOpt = None,
    out: options.OutOpt = None,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
    every: EveryOpt = 1,
) -> None:
    """Simulate a scene: contact events, energy and constraint drift over time.

    Every run is checked against its model's validity (frcontrol.simulation.validity): a NaN or
    an energy blow-up ends it as "diverged" (exit 1, with the time, the reason and a hint); energy
    growth beyond the inputs' work, deep penetration or implausible contact speeds are warnings,
    one line each on stderr and in the JSON's "warnings".

    \b
    Examples:
      frc simulate rod_on_table --duration 0.5
      frc simulate box_on_slope --model compliant --stiffness 1e6 --json --every 10
      frc simulate rhex_flip --input hip_rear=5 -T 0.2 --out run.npz --html run.html
      frc simulate rod_on_table -T 0.3 --plot rod.png
    """
    common.set_quiet(quiet)
    loaded = options.load_scene_with_overrides(scene, sets)
    assignments = options.parse_inputs(inputs)
    answer = _simulate(loaded, model, stiffness, damping, assignments, duration, dt, integrator, every)
    traj: Trajectory = answer.result  # the run, whether or not it completed
    _report_validity(traj)
    if plot is not None:
        from frcontrol.viz.plots import plot_trajectory

        plot_trajectory(traj, plot, coordinates=traj.coordinates)
        common.note(f"wrote {plot}", to_stderr=json)
    common.write_motion(loaded, traj, html=html, out=out, json=json)
    common.answer(answer.document, render, json=json)


def _simulate(scene: Scene, model: ContactModel | None, stiffness: float | None, damping: float | None,
              inputs: dict[str, float], duration: float, dt: float, integrator: str, every: int) -> Answer:
    """The run on the chosen contact model (default: the scene's [model] contact).

    Raises:
        typer.BadParameter: --stiffness or --damping with the rigid model (a usage error, exit 2).
    """
    from frcontrol.answers import SimulationOptions, simulate_answer
    from frcontrol.simulation.model_table import model_options

    chosen = model.value if model is not None else model_options(scene).contact
    if chosen == "rigid" and (stiffness is not None or damping is not None):
        raise typer.BadParameter("--stiffness and --damping belong to the compliant model: "
                                 "add --model compliant")
    with common.progress(f"simulating on the {chosen} model", "s") as shown:
        options = SimulationOptions(model=chosen, stiffness=stiffness, damping=damping, duration=duration,
                                    dt=dt, integrator=integrator)
        return simulate_answer(scene, inputs, options, every=every, progress=shown)


def _report_validity(traj: Trajectory) -> None:
    """Each validity warning as one line on stderr; a run that failed or diverged exits 1, saying why.

    Raises:
        typer.Exit: the run did not complete.
    """
    from frcontrol.answers import simulation_failure

    for warning in traj.warnings:
        sys.stderr.write(f"frc: warning: t = {warning.time:.6g} s: {warning.kind}: {warning.detail}\n")
    failure = simulation_failure(traj)
    if failure is not None:
        raise common.fail(failure)


def render(payload: dict[str, Any]) -> None:
    """The summary as text and tables."""
    s = payload["summary"]
    console.print(f"[bold]{s['scene']}[/bold]: {s['model']} model, {s['duration']:.6g} s in {s['steps']} "
                  f"steps ({s['wall_time']:.2f} s), status {s['status']}")
    if s["armature"]["coordinates"]:
        massless = ", ".join(s["armature"]["coordinates"])
        console.print(f"armature {s['armature']['value']:g} on massless {massless}")
    final = Table(title="final state")
    for col in ("coordinate", "q", "v"):
        final.add_column(col, overflow="fold")
    for i, name in enumerate(s["coordinates"]):
        final.add_row(name, f"{s['final_q'][i]:.6g}", f"{s['final_v'][i]:.6g}")
    console.print(final)
    e = s["energy"]
    console.print(f"energy: {e['initial']:.6g} J -> {e['final']:.6g} J (largest step increase "
                  f"{e['largest_increase']:.3g} J); max penetration {s['max_penetration']:.3g} m")
    if s["events"]:
        events = Table(title=f"contact events ({len(s['events'])})")
        for col in ("time [s]", "contact", "kind", "detail"):
            events.add_column(col, overflow="fold")
        for ev in s["events"][:MAX_EVENTS_SHOWN]:
            events.add_row(f"{ev['time']:.4f}", ev["contact"], ev["kind"], ev["detail"])
        console.print(events)
        if len(s["events"]) > MAX_EVENTS_SHOWN:
            console.print(f"... {len(s['events']) - MAX_EVENTS_SHOWN} more (see --json)")
    else:
        console.print("no contact events")


__all__ = [
    "ContactModel",
    "MAX_EVENTS_SHOWN",
    "render",
    "simulate_command",
]
