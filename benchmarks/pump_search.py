"""How far open-loop hip voltages get RHex's rigid flip within a voltage limit: a cross-entropy search.

Each candidate holds, for each driven hip, one voltage per ``--step`` seconds (``--knots`` of
them, within ``+-volts``), then the last one, in the rigid model (``RigidStepper``, 1 ms steps)
from the scene ``rhex_flip_drives`` (drives at ``--volts``) or, with ``--front``, the same scene
with its front hip unlocked and driven like the others. The search keeps the best quarter of each
population (``--population`` runs) and samples the next one around it. ``--hip-stiffness K`` puts a
torsion spring of K [N m/rad] after each driven hip's gearhead (an elastic stage: the voltage then
reaches the leg only through it). Objectives (``--objective``):

- ``pitch``: the highest pitch [rad] (vertical: 4.712);
- ``energy``: the body's highest mechanical energy above the start [J]
  (:func:`frcontrol.planning.flip_budget.body_energy`);
- ``corner``: the highest energy the body would have if it turned about its front corner from
  that instant on, ``V(q) - V(q0) + L |L| / (2 I_corner)`` [J], with ``L`` its angular momentum
  about the corner (massless legs: the body's own), at the samples where the corner is within
  ``CORNER_GAP`` of the ground (elsewhere the body is not turning about it), to compare with the
  barrier, ``pump.budget``;
- ``back``: how far the body pitches backwards, ``pi - pitch`` [rad] (backwards vertical: 1.571),
  self-righting over the rear corner;
- ``ballistic`` / ``ballistic_back``: the highest clearance [m] of the body's lower end at
  vertical (forwards / backwards) were the body to fly freely from a sample on
  (:func:`ballistic_clearance`): positive means a throw from there passes vertical in the air.

A run stops once the pitch is a quarter turn from flat, either way.

Prints one JSON document: the best candidate's voltages and its highest and lowest pitch, energy,
corner energy and ballistic clearances (forwards, backwards).
Not part of ``benchmarks/ci.py``: a measurement behind the table of docs/rhex-flip.md ("The pumping flip").

    python -m benchmarks.pump_search --front --objective energy --seed 8 --iterations 10
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from frcontrol.planning.flip_budget import body_energy
from frcontrol.scene import Scene, load_scene
from frcontrol.simulation.rigid import RigidSettings, RigidStepper

HIPS = ("hip_front", "hip_middle", "hip_rear")
FRONT_DRIVE = {"kind": "dc_motor", "resistance": 0.665, "torque_constant": 0.0161,
               "back_emf_constant": 0.01806, "rotor_inertia": 1.822e-6,
               "stages": [{"ratio": 33.0625, "efficiency": 0.7}]}
"""The front pair's drive: the same pair of RHex's motors as rhex_flip_drives' other hips (RHexLib's
constants, sources in that scene)."""

CORNER_GAP = 0.02
"""[m] The ``corner`` objective counts the samples where the front corner is at most this high."""


def scene_for(volts: float, front: bool, flat: bool, hip_stiffness: float | None = None,
              hip_damping: float = 0.0) -> Scene:
    """rhex_flip_drives at ``volts`` [V]; ``front``: the front hip driven; ``flat``: lying flat.

    ``hip_stiffness`` [N m/rad]: each driven hip's gearhead ends in a torsion spring of that
    stiffness (and ``hip_damping`` [N m s/rad]), an elastic stage (:mod:`frcontrol.drives`): the
    motor then reaches the leg only through the spring.
    """
    hips = HIPS if front else HIPS[1:]
    sets: dict = {f"model.drives.{h}.voltage_limit": volts for h in HIPS[1:]}
    if not hip_damping >= 0:
        raise SystemExit(f"--hip-damping must be >= 0 N m s/rad, got {hip_damping}")
    if hip_stiffness is not None:
        stage = {"ratio": 33.0, "efficiency": 0.7, "stiffness": hip_stiffness}
        if hip_damping > 0:
            stage["damping"] = hip_damping
        sets.update({f"model.drives.{h}.stages": [stage] for h in HIPS[1:]})
    sets.update({"inputs.lower": [-volts] * len(hips), "inputs.upper": [volts] * len(hips)})
    if front:
        front_drive = {**FRONT_DRIVE, "voltage_limit": volts}
        if hip_stiffness is not None:
            front_drive["stages"] = sets["model.drives.hip_middle.stages"]
        sets.update({"locked_joints": ["spring_front"], "inputs.coordinates": list(hips),
                     "model.drives.hip_front": front_drive})
    if flat:  # both corners down, the toes on the ground behind the hips (0.065 m hips, 0.17 m legs)
        leg = math.acos(0.065 / 0.17) - math.pi
        sets["state.q"] = [0.0, 0.065, math.pi, 0.0, 0.17, leg, 0.17, leg, 0.17]  # legs at rest length
    return load_scene("rhex_flip_drives", overrides=sets)


def run(scene: Scene, schedule: np.ndarray, step: float, duration: float):
    """The rigid run of a schedule (hips x knots, in [-1, 1] of the voltage limit)."""
    limit = np.array(scene.inputs.upper)
    stepper = RigidStepper(scene, RigidSettings(max_ambiguity_checks=0))
    for _ in range(int(round(duration / 1e-3))):
        knot = min(int(stepper.t / step), schedule.shape[1] - 1)
        if not stepper.step(schedule[:, knot] * limit, 1e-3) or abs(stepper.q[2] - math.pi) >= 0.5 * math.pi:
            break
    return stepper.trajectory(1e-3)


def corner_energy(scene: Scene, traj) -> np.ndarray:
    """[J] ``V(q) - V(q0) + L |L| / (2 I_corner)`` per sample, about the front corner."""
    robot, corner = scene.robot, [c.name for c in scene.contacts].index("front_corner")
    mass, start = robot.total_mass, robot.potential_energy(np.asarray(scene.q))
    com = np.array([robot.center_of_mass(q) for q in traj.q])
    com_velocity = np.gradient(com, traj.times, axis=0)
    out = np.empty(len(traj.times))
    for k, (q, v) in enumerate(zip(traj.q, traj.v, strict=True)):
        own = robot.mass_matrix(q)[2, 2] - mass * float(np.sum((com[k] - q[:2]) ** 2))
        point = robot.contact_points_in_world(q)[corner]
        if point[1] > CORNER_GAP:
            out[k] = -math.inf
            continue
        r = com[k] - point
        momentum = own * v[2] + mass * (r[0] * com_velocity[k, 1] - r[1] * com_velocity[k, 0])
        out[k] = robot.potential_energy(q) - start + momentum * abs(momentum) / (2 * (own + mass * r @ r))
    return out


HALF_LENGTH = 0.25
"""[m] From the body's centre to its ends: standing vertical, the lowest end is this far below the centre."""


def ballistic_clearance(traj, backwards: bool) -> np.ndarray:
    """[m] Per sample: how high the body's lower end would stand at vertical if it flew freely from there.

    Free flight keeps the pitch rate and drops the centre by gravity: the pitch reaches vertical
    (``pi / 2`` backwards, ``3 pi / 2`` forwards) after ``t = remaining / |rate|``, with the centre
    at ``y + vy t - g t^2 / 2``; minus :data:`HALF_LENGTH`. ``-inf`` where the pitch rate points away.
    """
    target = 0.5 * math.pi if backwards else 1.5 * math.pi
    remaining = target - traj.q[:, 2]
    rate = traj.v[:, 2]
    toward = remaining * rate > 0
    t = np.where(toward, remaining / np.where(toward, rate, 1.0), 0.0)
    height = traj.q[:, 1] + traj.v[:, 1] * t - 0.5 * 9.81 * t**2 - HALF_LENGTH
    return np.where(toward | (remaining * (1 if not backwards else -1) <= 0), height, -math.inf)


def main() -> None:
    """Parse the options, search, print the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volts", type=float, default=42.8)
    parser.add_argument("--front", action="store_true")
    parser.add_argument("--flat", action="store_true")
    parser.add_argument("--hip-stiffness", type=float, default=None,
                        help="[N m/rad] an elastic stage at each driven hip (a spring after the gearhead)")
    parser.add_argument("--hip-damping", type=float, default=0.0, help="[N m s/rad] that spring's damping")
    parser.add_argument("--objective", default="pitch",
                        choices=("pitch", "back", "energy", "corner", "ballistic", "ballistic_back"))
    parser.add_argument("--knots", type=int, default=10)
    parser.add_argument("--step", type=float, default=0.05)
    parser.add_argument("--population", type=int, default=20)
    parser.add_argument("--iterations", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    scene = scene_for(args.volts, args.front, args.flat, args.hip_stiffness, args.hip_damping)
    duration = args.knots * args.step + 0.5
    shape = (scene.inputs.count, args.knots)
    measures = {"pitch": lambda t: t.q[:, 2], "back": lambda t: math.pi - t.q[:, 2],
                "energy": lambda t: body_energy(scene, t), "corner": lambda t: corner_energy(scene, t),
                "ballistic": lambda t: ballistic_clearance(t, False),
                "ballistic_back": lambda t: ballistic_clearance(t, True)}

    def score(x: np.ndarray) -> float:
        return float(np.max(measures[args.objective](run(scene, x.reshape(shape), args.step, duration))))

    rng = np.random.default_rng(args.seed)
    mean = (0.0 if "back" in args.objective else -0.5) * np.ones(math.prod(shape))
    spread = 0.8 * np.ones(math.prod(shape))
    best, best_x = -math.inf, mean
    for _ in range(args.iterations):
        population = np.clip(mean + spread * rng.standard_normal((args.population, mean.size)), -1, 1)
        scores = np.array([score(x) for x in population])
        elite = population[np.argsort(scores)[-max(2, args.population // 4):]]
        mean, spread = elite.mean(axis=0), elite.std(axis=0) + 0.05
        if scores.max() > best:
            best, best_x = float(scores.max()), population[int(np.argmax(scores))]
    traj = run(scene, best_x.reshape(shape), args.step, duration)
    print(json.dumps({
        "options": vars(args), "runs": args.iterations * args.population, "best": best,
        "voltages": (best_x.reshape(shape) * np.array(scene.inputs.upper)[:, None]).round(2).tolist(),
        "max_pitch": float(traj.q[:, 2].max()), "min_pitch": float(traj.q[:, 2].min()),
        "max_energy": float(body_energy(scene, traj).max()),
        "max_corner_energy": float(corner_energy(scene, traj).max()),
        "clearance": [float(ballistic_clearance(traj, backwards).max()) for backwards in (False, True)],
    }, indent=1))


if __name__ == "__main__":
    main()
