"""The pumping flip's figure.

The phase portrait (pitch against pitch rate), coloured by contact mode, the energy audit's
terms over time, and the pitch and the hips' torques against their motor limits over time, shaded
by phase.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..modes import mode_heading
from ..planning.flip import flip_task
from ..planning.pump import PumpResult, pump_samples
from ..scene import Scene
from .plots import new_figure, save_figure

__all__ = ["plot_pump", "pump_figure"]

PHASE_COLOURS = {"push": "#fde0c5", "recirculate": "#d6e6f5", "land": "#dcefd8"}
"""Background of each phase kind in the time panels."""


def pump_figure(scene: Scene, result: PumpResult) -> Any:
    """The phase portrait and the pitch and torques over time, in one figure.

    Left: the phase portrait, one colour per contact mode (one letter per scene contact, as the
    viewer shows), the phases' starts marked (top), and the energy audit's running terms with the
    measured change of the mechanical energy (bottom). Right: the pitch over time (top) and each
    hip's torque with its torque-speed limits (bottom), the phases shaded.

    Raises:
        VizError: matplotlib is missing.
    """
    task = flip_task(scene)
    traj = result.trajectory
    figure = new_figure(figsize=(13.0, 8.5), layout="constrained")
    grid = figure.add_gridspec(2, 2, width_ratios=(1.1, 1.0))
    portrait = figure.add_subplot(grid[0, 0])
    _draw_portrait(portrait, traj, task.pitch_index, result)
    _draw_audit(figure.add_subplot(grid[1, 0]), result)
    pitch_ax = figure.add_subplot(grid[0, 1])
    torque_ax = figure.add_subplot(grid[1, 1], sharex=pitch_ax)
    for ax in (pitch_ax, torque_ax):
        labelled: set[str] = set()
        for phase in result.phases:
            label = f"a {phase.kind} phase" if ax is pitch_ax and phase.kind not in labelled else None
            labelled.add(phase.kind)
            ax.axvspan(phase.start, phase.end, color=PHASE_COLOURS.get(phase.kind, "#eeeeee"), lw=0,
                       label=label)
    pitch_ax.plot(traj.times, traj.q[:, task.pitch_index], color="black", lw=1.2, label="pitch")
    pitch_ax.axhline(task.vertical, color="tab:red", ls="--", lw=1, label="vertical")
    pitch_ax.set_ylabel(f"{task.pitch} [rad]")
    pitch_ax.legend(loc="upper left", fontsize="x-small")
    outcome = (f"flipped at {result.time_to_vertical:.3f} s" if result.flipped
               else f"not flipped: highest pitch {result.max_pitch:.3f} rad")
    pitch_ax.set_title(f"{result.cycles} cycle(s) (push orange, recirculate blue, land green); {outcome}",
                       fontsize="small")
    _draw_torques(torque_ax, scene, result)
    return figure


def _draw_portrait(ax: Any, traj: Any, pitch_index: int, result: PumpResult) -> None:
    """Pitch rate against pitch, one colour per contact mode, the start of each push a triangle."""
    pitch, rate = traj.q[:, pitch_index], traj.v[:, pitch_index]
    modes = list(traj.modes) if traj.modes is not None else ["?"] * len(pitch)
    palette = [f"C{k}" for k in range(10)]
    seen: dict[str, str] = {}
    for k in range(len(pitch) - 1):
        colour = seen.setdefault(modes[k], palette[len(seen) % len(palette)])
        ax.plot(pitch[k:k + 2], rate[k:k + 2], color=colour, lw=1.5)
    for mode, colour in seen.items():
        ax.plot([], [], color=colour, lw=3, label=mode)
    starts = [np.searchsorted(traj.times, p.start) for p in result.phases if p.kind == "push"]
    ax.plot(pitch[starts], rate[starts], "k^", ms=6, label="a push starts")
    ax.set_xlabel("pitch [rad]")
    ax.set_ylabel("pitch rate [rad/s]")
    ax.set_title("phase portrait, coloured by contact mode", fontsize="small")
    ax.legend(loc="upper left", fontsize="x-small", ncol=2, title=mode_heading(traj.contacts),
              title_fontsize="x-small")



def _draw_audit(ax: Any, result: PumpResult) -> None:
    """The energy audit's running terms [J] and the measured change of the mechanical energy."""
    audit = result.energy_audit
    if audit is None:
        ax.set_axis_off()
        return
    for k, (name, series) in enumerate(audit.cumulative.items()):
        ax.plot(audit.times, series, color=f"C{k}", lw=1.2, label=name.replace("_", " "))
    ax.plot(audit.times, audit.mechanical - audit.mechanical[0], color="black", lw=1.6,
            label="mechanical energy change")
    ax.plot(audit.times, audit.spring_energy, color="black", lw=0.8, ls=":", label="stored in springs")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [J] (symlog)")
    ax.set_title(f"energy audit: residual {audit.residual:+.2f} J of {audit.terms['drawn']:.0f} J drawn",
                 fontsize="small")
    ax.legend(loc="lower left", fontsize="x-small", ncol=2)


def _draw_torques(ax: Any, scene: Scene, result: PumpResult) -> None:
    """Each hip's torque and its torque-speed limits at the sample's joint speed (the samples')."""
    samples = pump_samples(scene, result.trajectory)
    for j, (name, table) in enumerate(samples.get("drives", {}).items()):
        ax.plot(samples["times"], table["torque"], color=f"C{j}", lw=1.2, label=f"{name} torque")
        ax.plot(samples["times"], table["torque_lower"], color=f"C{j}", lw=0.6, ls=":")
        ax.plot(samples["times"], table["torque_upper"], color=f"C{j}", lw=0.6, ls=":",
                label=f"{name} limits at its speed")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("hip torque [N m]")
    ax.legend(loc="lower left", fontsize="x-small", ncol=2)


def plot_pump(scene: Scene, result: PumpResult, path: str | Path) -> Path:
    """Write :func:`pump_figure` to ``path``.

    Raises:
        VizError: matplotlib is missing. OutputFileError: the file cannot be written.
    """
    return save_figure(pump_figure(scene, result), path)
