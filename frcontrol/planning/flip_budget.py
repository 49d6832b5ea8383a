r"""The flip's energy budget, from the model: what the legs must give the body, and where they reach.

A body lying on its back passes vertical only over a barrier: rotated rigidly about the body
contact it ends on (the *pivot*, on flat ground), its centre of mass is highest when it stands
right above that contact. For RHex (``rhex_flip_drives``) that is the front corner, 0.258 m from
the centre of mass (``sqrt(0.25^2 + 0.065^2)``): 7.5 kg x 9.81 m/s^2 x (0.258 - 0.077) m = 13.3 J
above the scene's start (14.2 J above lying flat). A leg can push only while its toe reaches the
ground: with the body pivoting on the front corner, the hip of a leg of length ``l`` rises above
``l`` at some pitch (RHex's 0.17 m legs, hips on the body's mid-plane: 0.462 rad above flat for
the middle hip, 0.238 rad for the rear one), so the body must leave the legs' last stroke
carrying the rest of the barrier as kinetic energy.

:func:`flip_budget` sweeps the pitch from the scene's state to vertical, the body rotated
rigidly (the joints at their angles in the scene) and moved along the ground's normal until its
lowest body contact touches, and reads, at every step of :data:`PITCH_STEP`:

- the potential energy (Pinocchio's), whose largest value above the start is the *barrier*;
- each driven leg's hip height above the ground against the leg's length (a toe lies
  ``|point|`` from its link's frame, which a URDF puts on the link's joint: the hip), which gives
  the highest pitch at which the leg still reaches the ground (*reach*);
- each toe's *hold*: whether the toe can carry the body about the pivot, i.e. reach the ground at
  least as far from the pivot, on the centre of mass's side, as the centre of mass. About the
  pivot, a friction force on the ground has no moment, so the toe's normal force times its
  distance must balance the weight's moment with the pivot's normal force >= 0. A leg whose hip
  lies near the pivot (RHex's front leg, 0.082 m from the front corner, less than its 0.17 m)
  reaches the ground at every pitch but holds the body only from 0.680 rad above flat on, with
  the centre of mass 11.0 J above flat of the barrier's 14.2 J: reaching is not holding.

:func:`body_energy` is the body's mechanical energy along a run, ``1/2 v_b^T M_bb v_b + V(q) -
V(q_0)`` [J], with ``v_b`` the base's velocity (x, y, pitch) and ``M_bb`` its block of the mass
matrix: the kinetic energy of the robot moving with its joints locked (the body's own for
massless legs; the rotors, which spin with the joints, are left out), plus the potential energy
above the start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import SceneError
from ..jsonable import to_jsonable
from ..model import ContactPoint
from ..scene import Scene
from ..simulation.trajectory import Trajectory
from ..urdf import read_urdf
from .flip import flip_task
from .pump_timing import leg_contacts

__all__ = ["NORMAL_TOLERANCE", "PITCH_STEP", "FlipBudget", "body_energy", "energy_shortfall", "flip_budget"]

PITCH_STEP = 2e-3
"""[rad] The pitch sweep's step. The barrier, a smooth maximum, is then found to about
``m g r step^2 / 8`` (1e-5 J for RHex); a reach pitch to within one step."""

NORMAL_TOLERANCE = 1e-9
"""[-] The body's contacts lie on one flat surface when their unit normals differ by at most this
(componentwise)."""


@dataclass(frozen=True)
class FlipBudget:
    """The energy a flip needs and how far up the legs reach (see the module's docstring).

    Attributes:
        pivot: the body contact the body stands on at the barrier.
        start_pitch: [rad] the pitch at the scene's state; vertical: [rad] the pitch to pass.
        tip_pitch: [rad] the pitch at the barrier (the centre of mass right above the pivot).
        barrier_energy: [J] the potential energy at the barrier above the scene's state.
        vertical_energy: [J] the potential energy standing vertical on the pivot, above the state.
        reach_pitch: per driven joint whose leg has a toe, the highest pitch [rad] up to which
            (from the start on) a toe still reaches the ground; None: not even at the start.
        reach_energy: [J] the potential energy above the state at the highest reach pitch.
        hold_pitch: per toe (every contact off the body, driven or not), the pitch intervals
            ``[from, to]`` [rad] of the sweep over which it can hold the body (module docstring).
        pitch_step: [rad] the sweep's step.
    """

    pivot: str
    start_pitch: float
    vertical: float
    tip_pitch: float
    barrier_energy: float
    vertical_energy: float
    reach_pitch: Mapping[str, float | None]
    reach_energy: float
    pitch_step: float
    hold_pitch: Mapping[str, tuple[tuple[float, float], ...]] = field(default_factory=dict)

    @property
    def kinetic_energy_needed(self) -> float:
        """[J] What the body must carry when its last toe leaves the ground: barrier - reach."""
        return self.barrier_energy - self.reach_energy

    def to_dict(self) -> dict[str, Any]:
        """The ``pump.budget`` part of ``frc flip --json``."""
        return to_jsonable({
            "pivot": self.pivot, "start_pitch": self.start_pitch, "vertical": self.vertical,
            "tip_pitch": self.tip_pitch, "barrier_energy": self.barrier_energy,
            "vertical_energy": self.vertical_energy, "reach_pitch": dict(self.reach_pitch),
            "reach_energy": self.reach_energy, "kinetic_energy_needed": self.kinetic_energy_needed,
            "pitch_step": self.pitch_step,
            "hold_pitch": {toe: [list(span) for span in spans] for toe, spans in self.hold_pitch.items()},
        })


def _ground_normal(scene: Scene, body: Sequence[str]) -> np.ndarray:
    """The body contacts' common unit normal [-].

    Raises:
        SceneError: the body's contacts do not lie on one flat surface.
    """
    normals = [c.point.normal_in_world for c in scene.contacts if c.point.name in body]
    for other in normals[1:]:
        if np.max(np.abs(other - normals[0])) > NORMAL_TOLERANCE:
            raise SceneError(str(scene.path), "task.body_contacts",
                             "the flip's energy budget needs the body's contacts on one flat surface "
                             f"(one normal); their normals differ: {normals[0].tolist()} and "
                             f"{other.tolist()}")
    return np.asarray(normals[0], dtype=float)


def _base_translation(scene: Scene) -> tuple[int, int]:
    """The indices of the base's x and y coordinates.

    Raises:
        SceneError: the robot has no planar floating base (coordinates x and y).
    """
    names = scene.coordinate_names
    if "x" not in names or "y" not in names:
        raise SceneError(str(scene.path), "base",
                         f"the flip's energy budget needs a planar floating base (coordinates x and y); "
                         f"the coordinates are {list(names)}")
    return names.index("x"), names.index("y")


def _hip_links(scene: Scene) -> dict[str, str]:
    """Link -> the link whose origin is its hip.

    The link itself or, through prismatic joints (a compliant leg's spring, a toe link sliding
    along the leg), the link the first one hangs from.
    """
    parent = {j.child: (j.parent, j.kind) for j in read_urdf(scene.robot.urdf_path).joints}
    hips = {}
    for link in {c.point.link for c in scene.contacts}:
        hip = link
        while hip in parent and parent[hip][1] == "prismatic":
            hip = parent[hip][0]
        hips[link] = hip
    return hips


def _leg_lengths(scene: Scene, hips: Mapping[str, str]) -> np.ndarray:
    """[m] Each contact's distance from its hip at the scene's state.

    For a toe on its leg's own link, ``|point_in_link|``; below a spring joint, with the spring as
    the scene has it.
    """
    q = np.asarray(scene.q, dtype=float)
    poses, points = scene.robot.link_poses(q), scene.robot.contact_points_in_world(q)
    return np.array([float(np.linalg.norm(points[i] - poses[hips[c.point.link]][0]))
                     for i, c in enumerate(scene.contacts)])


def _driven_toes(scene: Scene, body: Sequence[str]) -> dict[str, list[int]]:
    """Driven joint -> its toes: the contacts (not the body's) on the link it turns."""
    legs = leg_contacts(scene, body)
    return {scene.inputs.coordinates[i]: toes for i, toes in legs.items()}


def flip_budget(scene: Scene, *, pitch_step: float = PITCH_STEP) -> FlipBudget:
    """The flip's energy barrier and the legs' reach, swept over the pitch (module docstring).

    Args:
        scene: a flip scene (``[task] body_contacts``, a planar floating base), body contacts on
            one flat surface.
        pitch_step: [rad] the sweep's step, > 0.

    Raises:
        SceneError: see :func:`~.flip.flip_task`, :func:`_ground_normal`, :func:`_base_translation`.
    """
    task = flip_task(scene)
    normal = _ground_normal(scene, task.body_contacts)
    ix, iy = _base_translation(scene)
    robot = scene.robot
    names = [c.point.name for c in scene.contacts]
    body = [names.index(n) for n in task.body_contacts]
    surface = np.array([c.point.surface_point_in_world for c in scene.contacts])
    toes = _driven_toes(scene, task.body_contacts)
    hips = _hip_links(scene)
    legs = _leg_lengths(scene, hips)
    body_link = scene.contacts[body[0]].point.link
    pitches = np.append(np.arange(task.initial_pitch, task.vertical, pitch_step), task.vertical)
    start = robot.potential_energy(np.asarray(scene.q, dtype=float))
    energy = np.empty(pitches.size)
    lowest = np.empty(pitches.size, dtype=int)
    reaches = {joint: np.empty(pitches.size, dtype=bool) for joint in toes}
    off_body = [i for i, c in enumerate(scene.contacts) if i not in body and c.point.link != body_link]
    holds = np.empty((pitches.size, len(off_body)), dtype=bool)
    for k, pitch in enumerate(pitches):
        q = np.array(scene.q, dtype=float)
        q[task.pitch_index] = pitch
        points = robot.contact_points_in_world(q)
        gaps = (points[body] - surface[body]) @ normal
        lowest[k] = body[int(np.argmin(gaps))]
        q[[ix, iy]] -= float(np.min(gaps)) * normal
        energy[k] = robot.potential_energy(q) - start
        poses = robot.link_poses(q)
        hip = [poses[hips[c.point.link]][0] for c in scene.contacts]
        for joint, feet in toes.items():
            reaches[joint][k] = any(_toe_reaches(scene.contacts[t].point, hip[t], legs[t], surface[t])
                                    for t in feet)
        pivot, com = robot.contact_points_in_world(q)[lowest[k]], robot.center_of_mass(q)
        holds[k] = [_toe_holds(scene.contacts[t].point, hip[t], legs[t], surface[t], pivot, com)
                    for t in off_body]
    tip = int(np.argmax(energy))
    reach_pitch = {joint: _last_contiguous(pitches, ok) for joint, ok in reaches.items()}
    highest = [p for p in reach_pitch.values() if p is not None]
    reach_energy = float(energy[int(np.searchsorted(pitches, max(highest)))]) if highest else 0.0
    return FlipBudget(
        pivot=names[lowest[tip]], start_pitch=task.initial_pitch, vertical=task.vertical,
        tip_pitch=float(pitches[tip]), barrier_energy=float(energy[tip]), vertical_energy=float(energy[-1]),
        reach_pitch=reach_pitch, reach_energy=reach_energy, pitch_step=pitch_step,
        hold_pitch={names[t]: _intervals(pitches, holds[:, j]) for j, t in enumerate(off_body)},
    )


def _toe_reaches(toe: ContactPoint, hip: np.ndarray, leg: float, surface: np.ndarray) -> bool:
    """Whether the toe's hip [m, world] is within the leg's length ``leg`` [m] of the toe's surface."""
    return float((hip - surface) @ toe.normal_in_world) <= leg


def _toe_holds(toe: ContactPoint, hip: np.ndarray, leg: float, surface: np.ndarray, pivot: np.ndarray,
               com: np.ndarray) -> bool:
    """Whether the toe can reach its surface at least as far from ``pivot`` as ``com``, on its side.

    Distances along the surface (the normal turned a quarter turn); the toe lies on the circle of
    the leg's length ``leg`` [m] about its hip ``hip`` [m, world].
    """
    normal = toe.normal_in_world
    tangent = np.array([-normal[1], normal[0]])
    height = float((hip - surface) @ normal)
    if height > leg:
        return False
    side = 1.0 if float((com - pivot) @ tangent) >= 0.0 else -1.0
    farthest = side * float((hip - pivot) @ tangent) + math.sqrt(leg**2 - height**2)
    return farthest >= side * float((com - pivot) @ tangent)


def _intervals(pitches: np.ndarray, ok: np.ndarray) -> tuple[tuple[float, float], ...]:
    """The runs of ``ok`` as ``(first pitch, last pitch)``."""
    edges = np.diff(np.concatenate(([0], ok.astype(int), [0])))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0] - 1
    return tuple((float(pitches[a]), float(pitches[b])) for a, b in zip(starts, ends, strict=True))


def _last_contiguous(pitches: np.ndarray, ok: np.ndarray) -> float | None:
    """The last pitch of the run of ``ok`` that starts at the first pitch (None: it does not)."""
    if not ok[0]:
        return None
    fails = np.nonzero(~ok)[0]
    return float(pitches[fails[0] - 1] if fails.size else pitches[-1])


def body_energy(scene: Scene, trajectory: Trajectory) -> np.ndarray:
    """[J] The body's mechanical energy at every sample, above the scene's state (module docstring)."""
    task = flip_task(scene)
    ix, iy = _base_translation(scene)
    base = [ix, iy, task.pitch_index]
    robot = scene.robot
    start = robot.potential_energy(np.asarray(scene.q, dtype=float))
    out = np.empty(len(trajectory.times))
    for k, (q, v) in enumerate(zip(trajectory.q, trajectory.v, strict=True)):
        block = robot.mass_matrix(q)[np.ix_(base, base)]
        out[k] = 0.5 * float(v[base] @ block @ v[base]) + robot.potential_energy(q) - start
    return out


def energy_shortfall(budget: FlipBudget, energy: np.ndarray) -> str:
    """The reason's energy clause: the body's highest energy against the barrier."""
    if energy.size == 0 or not math.isfinite(float(np.max(energy))):
        return "no energy recorded"
    return (f"the body's mechanical energy peaked at {float(np.max(energy)):.2f} J above the start, "
            f"{budget.barrier_energy:.2f} J brings its centre of mass over {budget.pivot}")
