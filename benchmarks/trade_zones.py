"""Benchmark: what contact zones and the impact law cost, and how far they move the answer.

Run from the repository root (about a minute; ``python -m benchmarks.trade --zones`` runs it too)::

    python -m benchmarks.trade_zones            # stiffnesses 1e3 .. 1e6 N/m
    python -m benchmarks.trade_zones --quick    # 1e3 .. 1e5 N/m

Writes ``benchmarks/results/trade_zones.json`` and ``benchmarks/results/trade_zones.png`` and prints
a table. "Model only what a scene requires", measured:

**Zones.** A 1 kg disk (``disk.urdf``, its bottom point under its centre of mass: no rotation)
strikes a surface at 1 m/s, without gravity, through each zone of the compliant model at the same
overall stiffness ``k`` [N/m] (the springs in series): ``compliant`` (Kelvin–Voigt, damping ratio
:data:`DAMPING_RATIO`), ``one_stage`` (a contact mass :data:`ZONE_MASS` on ``k``, damping
``sqrt(k m')``) and ``two_stage`` (masses :data:`ZONE_MASS` on both sides, internal ``k`` and
external ``2 k`` on each side, internal dampers ``sqrt(3 k m')``). Each run lasts
:data:`DURATION`; its *distance from the rigid answer* is ``|y(T) - y_rigid(T)|`` [m], the disk's
height at the end against the rigid model's impact law with the restitution the run showed
(``v_after / v_before``), so that it measures the time the impact takes, not its losses. The impact
duration [s], the restitution, the state size and the wall time [s] are recorded.

**Impact law.** ``rod_drop`` over :data:`ROD_DURATION` on the rigid model with the impact law
(``impact_law=True``) and without it (the steps' LCPs absorb the impacts, inelastically): wall
time, impacts, and the final state's distance between the two.

Timing: wall time of one call (``time.perf_counter``), scene loaded outside; the median of
:data:`RUNS` runs.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from frcontrol.scene import load_scene, shipped_robots_dir
from frcontrol.simulation.compliant import CompliantSettings, simulate_compliant
from frcontrol.simulation.rigid import RigidSettings, simulate_rigid

RESULTS = Path(__file__).resolve().parent / "results"

SPEED = 1.0
"""[m/s] The disk's approach speed."""

DURATION = 0.12
"""[s] Each zone run (the softest impact, k = 1e3 N/m, lasts pi sqrt(m / k) = 0.099 s)."""

ZONE_MASS = 1e-3
"""[kg] The zones' contact masses (a thousandth of the disk's)."""

DAMPING_RATIO = 0.01
"""[-] The Kelvin–Voigt zone's damping ratio on the disk's mass."""

ROD_DURATION = 1.0
"""[s] The rod_drop runs."""

RUNS = 3
"""Runs per timing (median)."""

FULL_STIFFNESSES = (1e3, 1e4, 1e5, 1e6)
QUICK_STIFFNESSES = (1e3, 1e4, 1e5)
KINDS = ("compliant", "one_stage", "two_stage")


def zone_table(kind: str, k: float) -> dict[str, Any]:
    """The ``[model.contacts.bottom]`` table of one zone at overall stiffness ``k`` [N/m]."""
    if kind == "compliant":
        return {"stiffness": k, "damping": 2 * DAMPING_RATIO * math.sqrt(k * 1.0)}
    if kind == "one_stage":
        return {"zone": kind, "mass_robot": ZONE_MASS, "stiffness_internal_robot": k,
                "damping_internal_robot": math.sqrt(k * ZONE_MASS)}
    inner, b = 3 * k, math.sqrt(3 * k * ZONE_MASS)
    return {"zone": kind, "mass_robot": ZONE_MASS, "stiffness_internal_robot": inner,
            "damping_internal_robot": b, "stiffness_external_robot": 2 * inner, "mass_environment": ZONE_MASS,
            "stiffness_internal_environment": inner, "damping_internal_environment": b,
            "stiffness_external_environment": 2 * inner}


def disk_text(model: dict[str, Any]) -> str:
    """The disk 1 mm above the surface, moving down at :data:`SPEED`, with this ``[model]``."""
    contact = {key: value for key, value in model.items() if key != "contact"}
    inline = ", ".join(f"{key} = {json.dumps(value)}" for key, value in contact.items())
    return "\n".join([
        'name = "disk strike"', f'robot = "{shipped_robots_dir() / "disk.urdf"}"', "gravity = 0.0",
        "[state]", "q = [0.0, 0.101, 0.0]", f"v = [0.0, {-SPEED}, 0.0]",
        "[[contacts]]", 'name = "bottom"', 'link = "disk"', "point = [0.0, -0.1]", "normal = [0.0, 1.0]",
        "mu = 0.5", "surface_point = [0.0, 0.0]",
        "[model]", f'contact = "{model["contact"]}"', f"contacts = {{bottom = {{{inline}}}}}", ""])


def timed(call: Any) -> tuple[float, Any]:
    """(median wall time [s] over :data:`RUNS`, the last result)."""
    times, result = [], None
    for _ in range(RUNS):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def zone_point(folder: Path, kind: str, k: float) -> dict[str, Any]:
    """One zone at one stiffness, and its rigid counterpart."""
    path = folder / f"{kind}_{k:g}.toml"
    path.write_text(disk_text({"contact": "compliant", **zone_table(kind, k)}))
    scene = load_scene(path)
    seconds, traj = timed(lambda: simulate_compliant(scene, None, DURATION, 1e-3,
                                                     settings=CompliantSettings(contacts="all")))
    impact = next(e.to_dict() for e in traj.events if e.kind == "impact")
    after = impact.get("normal_velocity_after")
    restitution = float(np.clip((after if after is not None else traj.v[-1, 1]) / SPEED, 0.0, 1.0))
    rigid_path = folder / f"rigid_{kind}_{k:g}.toml"
    rigid_path.write_text(disk_text({"contact": "rigid", "restitution": restitution}))
    rigid_seconds, rigid = timed(lambda: simulate_rigid(load_scene(rigid_path), None, DURATION, 1e-3))
    return {"zone": kind, "stiffness": k, "wall_time_s": seconds, "rigid_wall_time_s": rigid_seconds,
            "state_size": traj.info["state_size"], "steps": traj.info["steps"],
            "impact_duration_s": impact.get("duration"), "peak_force_n": impact.get("peak_force"),
            "restitution": restitution, "distance_from_rigid_m": abs(float(traj.q[-1, 1] - rigid.q[-1, 1]))}


def impact_law_points() -> dict[str, Any]:
    """rod_drop with and without the impact law."""
    scene = load_scene("rod_drop")
    with_law_s, with_law = timed(lambda: simulate_rigid(scene, None, ROD_DURATION, 1e-3))
    without_s, without = timed(lambda: simulate_rigid(scene, None, ROD_DURATION, 1e-3,
                                                      settings=RigidSettings(impact_law=False)))
    return {"scene": "rod_drop", "duration_s": ROD_DURATION,
            "impact_law": {"wall_time_s": with_law_s, "impacts": len(with_law.info["impacts"])},
            "steps_absorb": {"wall_time_s": without_s,
                             "impact_events": sum(e.kind == "impact" for e in without.events)},
            "final_q_distance": float(np.linalg.norm(with_law.q[-1] - without.q[-1])),
            "largest_height_distance_m": float(np.max(np.abs(with_law.q[:, 1] - without.q[:, 1])))}


def plot(points: list[dict[str, Any]], path: Path) -> None:
    """Distance from the rigid answer and wall time against stiffness, one line per zone."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for kind, marker in zip(KINDS, "osD", strict=True):
        mine = [p for p in points if p["zone"] == kind]
        ks = [p["stiffness"] for p in mine]
        left.loglog(ks, [p["distance_from_rigid_m"] for p in mine], marker=marker, label=kind)
        right.loglog(ks, [p["wall_time_s"] for p in mine], marker=marker, label=kind)
    right.loglog([p["stiffness"] for p in points if p["zone"] == KINDS[0]],
                 [p["rigid_wall_time_s"] for p in points if p["zone"] == KINDS[0]], "k--", label="rigid")
    left.set(xlabel="stiffness k [N/m]", ylabel="|y - y_rigid| after the impact [m]",
             title="distance from the rigid impact law")
    right.set(xlabel="stiffness k [N/m]", ylabel="wall time of the run [s]", title="cost")
    left.legend()
    right.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run(quick: bool) -> dict[str, Any]:
    """Every point; writes the JSON and the figure."""
    started = time.perf_counter()
    points = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in QUICK_STIFFNESSES if quick else FULL_STIFFNESSES:
            for kind in KINDS:
                points.append(zone_point(Path(tmp), kind, k))
                print(f"[{time.perf_counter() - started:6.1f} s] {kind} k = {k:g}", flush=True)
    result = {"benchmark": "contact zones and the impact law: cost and distance from the rigid answer",
              "command": "python -m benchmarks.trade_zones" + (" --quick" if quick else ""),
              "speed_m_s": SPEED, "duration_s": DURATION, "zone_mass_kg": ZONE_MASS, "runs": RUNS,
              "zones": points, "impact_law": impact_law_points(),
              "wall_time_s": time.perf_counter() - started}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "trade_zones.json").write_text(json.dumps(result, indent=1) + "\n")
    plot(points, RESULTS / "trade_zones.png")
    return result


def print_table(result: dict[str, Any]) -> None:
    """The points as a text table."""
    print(f"{'zone':10} {'k [N/m]':>9} {'state':>5} {'time [s]':>9} {'rigid [s]':>9} {'impact [s]':>10} "
          f"{'e':>6} {'|y - y_rigid| [m]':>17}")
    for p in result["zones"]:
        duration = p["impact_duration_s"]
        print(f"{p['zone']:10} {p['stiffness']:9.0e} {p['state_size']:5d} {p['wall_time_s']:9.3f} "
              f"{p['rigid_wall_time_s']:9.3f} {duration if duration is not None else float('nan'):10.2e} "
              f"{p['restitution']:6.3f} {p['distance_from_rigid_m']:17.2e}")
    law = result["impact_law"]
    print(f"rod_drop {law['duration_s']:g} s: impact law {law['impact_law']['wall_time_s']:.3f} s "
          f"({law['impact_law']['impacts']} impacts), steps absorbing "
          f"{law['steps_absorb']['wall_time_s']:.3f} s; "
          f"largest height difference {law['largest_height_distance_m']:.3f} m")


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="stiffnesses up to 1e5 N/m only")
    print_table(run(parser.parse_args().quick))


if __name__ == "__main__":
    main()
