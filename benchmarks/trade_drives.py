"""Benchmark: what DC-motor drives cost and what they change, the trade benchmark's drive part.

Run from the repository root::

    python -m benchmarks.trade_drives            # about a minute here
    python -m benchmarks.trade_drives --replot   # redraw the figure from the JSON

Writes ``benchmarks/results/trade_drives.json`` and ``benchmarks/results/trade_drives.png``.

The question: "model only what a scene requires", measured. RHex on its back (``rhex_flip``, its
hips ideal torque sources) against ``rhex_flip_drives`` (the same robot with pairs of maxon motors
behind 33:1 gearheads: voltage inputs), and that scene again with the gearhead made elastic (one
torsion spring after the gears, stiffness ``k`` swept, critical damping for the rotor pair's
reflected inertia). Each model runs :data:`DURATION` of the flip's opening push from the scene's
state, on the rigid stepper (:data:`RIGID_DT`) and on the compliant model's linearly implicit
integrator (:data:`COMPLIANT_DT`, the contacts at the scene's defaults):

- **cost**: wall time per step, median of :data:`RUNS` runs (the drives' terms are a few vector
  operations; an elastic stage adds two states per hip and a small solve per step);
- **answer**: the largest distance between the body's pitch in the elastic model and in the rigid
  transmission's over the run, and the final body pitch of each. As ``k`` grows the elastic answer
  must approach the rigid transmission's (a test of the coupling as much as a figure).

The elastic answer approaches the rigid gearhead's as ``1/k`` down to a floor (about 1e-4 rad on
the rigid stepper): with an elastic gearhead the hip's own side of the spring is the massless leg,
which gets the default armature (1e-4 kg m^2, :mod:`frcontrol.simulation.armature`), about 4 % of
the rotor pair's 2.3e-3 kg m^2 that the rigid gearhead puts on the hip.

Inputs: the torque scene gets the drives' stall torque at the push's voltage, ``tau = eta N C_M u /
R`` (:data:`PUSH_VOLTAGE` on both hips), so both start with the same torque; the drives' torque then
falls with the hip speed along the motors' torque-speed line, which is what the drives change.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.drives import joint_torque
from frcontrol.scene import Scene, load_scene
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.rigid import RigidSettings, simulate_rigid

RESULTS = Path(__file__).resolve().parent / "results"

DURATION = 0.2
"""[s] Simulated time per run: the flip's opening push."""

RIGID_DT = 1e-3
"""[s] The rigid stepper's step."""

COMPLIANT_DT = 1e-3
"""[s] The compliant model's (linearly implicit) step."""

PUSH_VOLTAGE = -12.0
"""[V] on both hips (half the motors' 24 V): pushes the toes back, pitching the body up."""

STIFFNESSES = (3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 1e4, 1e5)
"""[N m/rad] The elastic gearhead's torsion stiffness, at the hip's side of the 33:1 gears."""

RUNS = 3
"""Runs per timed point (median)."""

HIPS = ("hip_middle", "hip_rear")


def elastic_overrides(stiffness: float, scene: Scene) -> dict[str, Any]:
    """``--set`` values making each hip's gearhead one elastic stage, critically damped.

    Critical for the motor side's inertia at the spring (the rotor pair's, N^2 J_r): ``d = 2 sqrt(c
    N^2 J_r)`` [N m s/rad] (the hip side, a massless leg, has almost none).
    """
    out: dict[str, Any] = {}
    for hip in HIPS:
        drive = scene.drives[hip]
        inertia = drive.ratio ** 2 * drive.rotor_inertia
        out[f"model.drives.{hip}.stages[0].stiffness"] = stiffness
        out[f"model.drives.{hip}.stages[0].damping"] = 2.0 * math.sqrt(stiffness * inertia)
    return out


def run(scene: Scene, inputs: dict[str, float], model: str) -> Any:
    """One simulation of :data:`DURATION` on ``model`` (``"rigid"`` or ``"compliant"``)."""
    if model == "rigid":
        return simulate_rigid(scene, inputs, DURATION, RIGID_DT,
                              settings=RigidSettings(max_ambiguity_checks=0))
    return simulate_compliant(scene, inputs, DURATION, COMPLIANT_DT,
                              settings=CompliantSettings(integrator="implicit"))


def measure(scene: Scene, inputs: dict[str, float], model: str, runs: int) -> dict[str, Any]:
    """Time per step (median of ``runs``) and the run's pitch, status and state size."""
    times, trajectory = [], None
    for _ in range(runs):
        started = time.perf_counter()
        trajectory = run(scene, inputs, model)
        times.append((time.perf_counter() - started) / max(1, len(trajectory.times) - 1))
    assert trajectory is not None
    pitch = trajectory.q[:, scene.coordinate_names.index("theta")]
    return {"time_per_step": statistics.median(times), "times": times, "status": trajectory.status,
            "pitch": pitch, "final_pitch": float(pitch[-1]), "samples": len(trajectory.times),
            "state_size": int(trajectory.info.get("state_size", 2 * scene.robot.nv))}


def bench(runs: int) -> dict[str, Any]:
    """Every measurement."""
    driven = load_scene("rhex_flip_drives")
    torque = {hip: float(joint_torque(driven.drives[hip], PUSH_VOLTAGE, 0.0)) for hip in HIPS}
    voltage = dict.fromkeys(HIPS, PUSH_VOLTAGE)
    out: dict[str, Any] = {"push_voltage": PUSH_VOLTAGE, "push_torque": torque, "models": {}}
    for model in ("rigid", "compliant"):
        plain = measure(load_scene("rhex_flip"), torque, model, runs)
        rigid_drive = measure(driven, voltage, model, runs)
        elastic = []
        for k in STIFFNESSES:
            scene = load_scene("rhex_flip_drives", overrides=elastic_overrides(k, driven))
            point = measure(scene, voltage, model, runs)
            point["stiffness"] = k
            point["pitch_deviation"] = float(np.max(np.abs(point["pitch"] - rigid_drive["pitch"])))
            elastic.append(point)
        out["models"][model] = {"torque_inputs": plain, "rigid_stages": rigid_drive, "elastic": elastic}
    return out


def plot(result: dict[str, Any], path: Path) -> None:
    """Time per step by model, and the elastic answer's distance from the rigid transmission's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    colors = {"rigid": "tab:blue", "compliant": "tab:orange"}
    for model, entry in result["models"].items():
        ks = [p["stiffness"] for p in entry["elastic"]]
        axes[0].plot(ks, [1e6 * p["time_per_step"] for p in entry["elastic"]], "o-", color=colors[model],
                     label=f"{model}: elastic gearhead")
        for key, style, name in (("torque_inputs", ":", "torque inputs (no drive)"),
                                 ("rigid_stages", "--", "drives, rigid gearhead")):
            axes[0].axhline(1e6 * entry[key]["time_per_step"], color=colors[model], ls=style, lw=1.0,
                            label=f"{model}: {name}")
        axes[1].plot(ks, [max(p["pitch_deviation"], 1e-12) for p in entry["elastic"]], "o-",
                     color=colors[model], label=model)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("gearhead torsion stiffness [N m/rad]")
    axes[0].set_ylabel("wall time per step [us]")
    axes[0].set_title(f"cost per step ({DURATION:g} s of the flip's push)", fontsize=10)
    axes[1].set_xscale("log")
    axes[1].set_yscale("log")
    axes[1].set_xlabel("gearhead torsion stiffness [N m/rad]")
    axes[1].set_ylabel("max |pitch - pitch with a rigid gearhead| [rad]")
    axes[1].set_title("how far an elastic gearhead moves the answer", fontsize=10)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.2)
        ax.legend(fontsize=7)
    fig.suptitle(f"rhex_flip_drives at {result['push_voltage']:g} V on both hips", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def print_table(result: dict[str, Any]) -> None:
    """The figures, one line each."""
    for model, entry in result["models"].items():
        base = entry["torque_inputs"]["time_per_step"]
        print(f"{model}: torque inputs {1e6 * base:.0f} us/step, final pitch "
              f"{entry['torque_inputs']['final_pitch']:.4f} rad; rigid gearhead "
              f"{1e6 * entry['rigid_stages']['time_per_step']:.0f} us/step "
              f"({entry['rigid_stages']['time_per_step'] / base:.2f}x), final pitch "
              f"{entry['rigid_stages']['final_pitch']:.4f} rad")
        for p in entry["elastic"]:
            print(f"  k = {p['stiffness']:8.3g} N m/rad: {1e6 * p['time_per_step']:.0f} us/step "
                  f"({p['time_per_step'] / base:.2f}x), pitch deviation {p['pitch_deviation']:.2e} rad, "
                  f"status {p['status']}")


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=RUNS, help="runs per timed point (median)")
    parser.add_argument("--replot", action="store_true", help="redraw the figure from the JSON only")
    args = parser.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    if args.replot:
        plot(json.loads((RESULTS / "trade_drives.json").read_text()), RESULTS / "trade_drives.png")
        return
    started = time.perf_counter()
    result = bench(args.runs)
    for entry in result["models"].values():  # the pitch series served the deviations; keep them short
        for point in [entry["torque_inputs"], entry["rigid_stages"], *entry["elastic"]]:
            point.pop("pitch")
    payload = {"benchmark": "DC-motor drives: cost per step and the elastic gearhead's effect",
               "command": "python -m benchmarks.trade_drives", "duration": DURATION, "rigid_dt": RIGID_DT,
               "compliant_dt": COMPLIANT_DT, "runs": args.runs, "python": platform.python_version(),
               "machine": platform.machine(), "wall_time_s": time.perf_counter() - started, **result}
    (RESULTS / "trade_drives.json").write_text(json.dumps(payload, indent=1) + "\n")
    plot(result, RESULTS / "trade_drives.png")
    print_table(result)


if __name__ == "__main__":
    main()
