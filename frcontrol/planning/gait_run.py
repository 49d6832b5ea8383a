r"""The climbing gait in the rigid simulation, and its ``frc climb --cycles --json`` document.

See :mod:`frcontrol.planning.gait` (the module's docstring ends with the run).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..jsonable import to_jsonable
from ..modes import add_scene_modes
from ..scene import Inputs
from ..simulation.rigid import RigidSettings, RigidStepper
from .climb_check import BRACE_SLIP_TOLERANCE
from .disturbances import (
    DEFAULT_HOLD,
    HOLD_INDEX_ROUNDOFF,
    PointKinematics,
    sample_disturbances,
)
from .gait import GaitPlan
from .gait_control import (
    ROBUSTNESS_PENALTY,
    TOUCH_GAP,
    TRACKING_DAMPING,
    TRACKING_MARGIN,
    TRACKING_STIFFNESS,
    TrackingRequest,
    tracking_step,
)
from .gait_geometry import PRESS, STANDOFF, STROKE, UPPER_SPAN, Reference, phase_reference
from .gait_handover import PHASE_ROLES

__all__ = [
    "DEFAULT_DT",
    "SIMULATION_SCALE",
    "GaitResult",
    "PhaseRun",
    "gait_payload",
    "simulate_gait",
]

DEFAULT_DT = 1e-3
"""[s] Time step of the gait's rigid simulation."""

SIMULATION_SCALE = 0.02
"""[-] Default disturbance scale of the simulated gait (capped by the plan's scale). The phases'
certificates hold at rest up to their largest scales (about 9 on the snake), but along the motion
the disturbances push the open lower body about (the brace disturbance reaches 40 N at j3, twice the
snake's weight), and a lower contact then closes while still moving along its wall: at scale 0.1
the re-closing j2 contact slides up to 1.4 mm before it sticks (5 cycles, seed 0), at 0.3 the
upper brace slides too. At 0.02 every held contact stays within the slip tolerance."""

# ============================================================================ simulation
@dataclass(frozen=True)
class PhaseRun:
    """One phase of the simulated gait.

    Attributes:
        name: the phase; cycle: its cycle (1-based).
        start, end: [s] its times; start_index, end_index: its samples.
        max_deficit: [N m or N] the tracking LP's largest robustness deficit in the phase.
        max_slip: [m] the largest slide of a held contact while held (``sum |v_T+| h``).
        slips: [m] each held contact's slide.
        max_drift: [m] the largest displacement of a held contact along its wall while held.
        max_tracking_error: [m or rad] the largest |q_ref - q|.
        base_height: [m] the base's height (the tail's y) at the end.
        closed: the closing contacts that touch at the end.
    """

    name: str
    cycle: int
    start: float
    end: float
    start_index: int
    end_index: int
    max_deficit: float
    max_slip: float
    slips: Mapping[str, float]
    max_drift: float
    max_tracking_error: float
    base_height: float
    closed: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """The phase's run as JSON."""
        return {"name": self.name, "cycle": self.cycle, "start": self.start, "end": self.end,
                "start_index": self.start_index, "end_index": self.end_index, "max_deficit": self.max_deficit,
                "max_slip": self.max_slip, "slips": dict(self.slips), "max_drift": self.max_drift,
                "max_tracking_error": self.max_tracking_error,
                "base_height": self.base_height, "closed": list(self.closed)}


@dataclass(frozen=True, eq=False)
class GaitResult:
    """The gait in the rigid simulation.

    Attributes:
        trajectory: the run (its inputs: the generalized forces ``S^T u + J_d^T d`` on every coordinate).
        torques: [N m] the torques of every step, shape (T - 1, m).
        modes: the controller's mode of every step (letters of ``mode_contacts``).
        mode_contacts: the contacts of each step's mode.
        phase_of_step: the index into ``phases`` of every step.
        deficits: [N m or N] the tracking LP's robustness deficit sigma of every step.
        phases: every phase's record.
        heights: [m] the base's height at the end of each cycle; rise: the last minus the start.
        brace_held: no held contact slid by more than ``slip_tolerance`` while held, and the run completed.
        max_slip: [m] the largest such slide (``sum |v_T+| h`` while held, ``v_T+`` each step's
            sliding velocity).
        max_drift: [m] the largest displacement of a held contact along its wall while held.
        max_deficit: [N m or N] the largest robustness deficit of the run.
        scale: the disturbance scale sampled; seed: the sampler's seed.
        disturbance_times: [s] start of each held sample; disturbance_samples: [N] (K, dim).
        slip_tolerance: [m]; dt: [s] the step.
        timings: [s].
    """

    trajectory: Any
    torques: np.ndarray
    modes: tuple[str, ...]
    mode_contacts: tuple[tuple[str, ...], ...]
    phase_of_step: np.ndarray
    deficits: np.ndarray
    phases: tuple[PhaseRun, ...]
    heights: tuple[float, ...]
    rise: float
    brace_held: bool
    max_slip: float
    max_drift: float
    max_deficit: float
    scale: float
    seed: int
    disturbance_times: np.ndarray
    disturbance_samples: np.ndarray
    slip_tolerance: float
    dt: float
    timings: Mapping[str, float] = field(default_factory=dict)


class _Run:
    """The closed loop of :func:`simulate_gait`: a stepper, the disturbance samples and the records."""

    def __init__(self, plan: GaitPlan, dt: float, scale: float, seed: int) -> None:
        scene = plan.scene
        n = scene.robot.nv
        every = Inputs(scene.coordinate_names, tuple(range(n)), np.full(n, -np.inf), np.full(n, np.inf))
        self.plan, self.dt, self.scene = plan, dt, scene
        self.stepper = RigidStepper(replace(scene, inputs=every), RigidSettings(max_ambiguity_checks=0))
        self.points = plan.disturbances.robust_points(scale)
        self.kin = PointKinematics(scene, [(d.name, d.link, d.point_in_link)
                                            for d in plan.disturbances.items])
        self.rng = np.random.default_rng(seed)
        self.samples: list[np.ndarray] = []
        self.torque_map = scene.inputs.selection_transpose(n)
        self.torques: list[np.ndarray] = []
        self.modes: list[tuple[str, tuple[str, ...]]] = []
        self.phase_of_step: list[int] = []
        self.deficits: list[float] = []
        self.wall = {c.name: (c.point.normal_in_world, c.point.tangent_in_world) for c in scene.contacts}

    def disturbance(self) -> np.ndarray:
        """The held sample at the stepper's time (drawn as the holds start)."""
        k = int(self.stepper.t / DEFAULT_HOLD + HOLD_INDEX_ROUNDOFF)
        while len(self.samples) <= k:
            self.samples.append(sample_disturbances(self.points, 1, self.rng)[0])
        return self.samples[k]

    def phase(self, index: int, name: str, cycle: int, reference: Reference, roles: tuple) -> PhaseRun | None:
        """Run one phase; None when the stepper failed."""
        held, released, closing = roles
        st = self.stepper
        start, start_index = st.t, len(self.torques)
        anchors: dict[str, np.ndarray] = {}
        slid: dict[str, dict[str, float]] = {}
        worst = {"deficit": 0.0, "slip": 0.0, "drift": 0.0, "error": 0.0}
        steps = max(1, int(round(reference.duration / self.dt)))
        for k in range(steps):
            q_ref, v_ref, a_ref = reference.state(k * self.dt)
            desired = a_ref + TRACKING_STIFFNESS * (q_ref - st.q) + TRACKING_DAMPING * (v_ref - st.v)
            loaded = [name for name, force in zip(st.names, st.last_forces[:, 0], strict=True) if force > 0]
            request = TrackingRequest(st.q, st.v, held + closing, released, desired, self.points,
                                      TRACKING_MARGIN, self.plan.solver, loaded)
            step = tracking_step(self.scene, self.plan.disturbances, request)
            jac, _, _ = self.kin.evaluate(st.q, st.v)
            force = self.torque_map @ step.torques + jac[:self.plan.disturbances.dim].T @ self.disturbance()
            tangent_rows = st.state.jacobian_tangent.copy()
            if not st.step(force, self.dt):
                return None
            self.torques.append(step.torques)
            self.modes.append((step.mode, step.contacts))
            self.deficits.append(step.deficit)
            self.phase_of_step.append(index)
            worst["deficit"] = max(worst["deficit"], step.deficit)
            worst["error"] = max(worst["error"], float(np.max(np.abs(q_ref - st.q))))
            fixed = [c for letter, c in zip(step.mode, step.contacts, strict=True) if letter == "F"]
            slip, drift = self._slip(slid, anchors, fixed, tangent_rows @ st.v)
            worst["slip"], worst["drift"] = max(worst["slip"], slip), max(worst["drift"], drift)
        touching = {c.name for c in self.scene.at(st.q).contacts if c.gap <= TOUCH_GAP}
        return PhaseRun(name, cycle, start, st.t, start_index, len(self.torques), worst["deficit"],
                        worst["slip"], {k: r["slip"] for k, r in slid.items()}, worst["drift"],
                        worst["error"], float(st.q[1]),
                        tuple(c for c in closing if c in touching))

    def _slip(self, record: dict[str, dict[str, float]], anchors: dict[str, np.ndarray],
              held: Sequence[str], sliding: np.ndarray) -> tuple[float, float]:
        """``(slip, drift)`` [m] of the held contacts so far in the phase (the largest of each).

        The slip of a contact sums ``|v_T+| h`` over the steps it touches while held, with ``v_T+ =
        J_T(q) v+`` the step's own sliding velocity (``sliding``, per contact: the velocity the
        time stepper's friction law sets); its drift is its displacement along the wall from where
        it was first held: the slip plus the time stepping's drift (``q+ = q + h v+`` keeps the
        contact still to first order in h only).
        """
        st = self.stepper
        slip, drift = 0.0, 0.0
        for name in held:
            i = st.names.index(name)
            _, tangent = self.wall[name]
            point = st.state.contact_points[i]
            anchor = anchors.setdefault(name, point.copy())
            slid = record.setdefault(name, {"slip": 0.0})
            slid["slip"] += abs(float(sliding[i])) * self.dt
            slip = max(slip, slid["slip"])
            drift = max(drift, abs(float(tangent @ (point - anchor))))
        return slip, drift



def simulate_gait(
    plan: GaitPlan,
    *,
    dt: float = DEFAULT_DT,
    seed: int = 0,
    scale: float | None = None,
    slip_tolerance: float = BRACE_SLIP_TOLERANCE,
    progress: Callable[[int, int], None] | None = None,
) -> GaitResult:
    """Run the planned gait in the rigid simulation under sampled disturbances (module docstring).

    Args:
        plan: the planned gait.
        dt: [s] the time step (the tracking LP is solved every step).
        seed: the disturbance sampler's seed.
        scale: the disturbance scale (default: :data:`SIMULATION_SCALE`, at most the plan's).
        slip_tolerance: [m] see :data:`~frcontrol.planning.climb_check.BRACE_SLIP_TOLERANCE`.
        progress: called with (phases done, phases) after each phase.

    Raises:
        InputError: a bad step, scale or tolerance.
    """
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0 < dt <= 0.01):
        raise InputError(f"dt must be a number in (0, 0.01] [s], got {dt!r}")
    s = min(plan.scale, SIMULATION_SCALE) if scale is None else scale
    if not (isinstance(s, (int, float)) and math.isfinite(s) and s >= 0):
        raise InputError(f"scale must be a finite number >= 0, got {scale!r}")
    if not (isinstance(slip_tolerance, (int, float)) and slip_tolerance > 0):
        raise InputError(f"slip_tolerance must be > 0 [m], got {slip_tolerance!r}")
    start = time.perf_counter()
    run = _Run(plan, float(dt), float(s), seed)
    braces = {"lower": plan.lower, "upper": plan.upper, "": ()}
    records: list[PhaseRun] = []
    for index, phase in enumerate(plan.phases):
        first = index == 0
        reference = phase_reference(phase.name, plan.geometry, plan.geometry.measure(run.stepper.q),
                                    plan.scene.q if first else None)
        roles = tuple(braces[r] for r in PHASE_ROLES[phase.name])
        record = run.phase(index, phase.name, phase.cycle, reference, roles)
        if progress is not None:
            progress(index + 1, len(plan.phases))
        if record is None:
            break
        records.append(record)
    trajectory = run.stepper.trajectory(float(dt))
    heights = tuple(r.base_height for r in records if r.name == "lower_brace")
    max_slip = max((r.max_slip for r in records), default=0.0)
    complete = trajectory.completed and len(records) == len(plan.phases)
    return GaitResult(
        trajectory=trajectory, torques=np.array(run.torques).reshape(-1, plan.scene.inputs.count),
        modes=tuple(m for m, _ in run.modes), mode_contacts=tuple(c for _, c in run.modes),
        phase_of_step=np.array(run.phase_of_step, dtype=int), deficits=np.array(run.deficits),
        phases=tuple(records), heights=heights, rise=float(trajectory.q[-1, 1] - trajectory.q[0, 1]),
        brace_held=bool(complete and max_slip <= slip_tolerance), max_slip=max_slip,
        max_drift=max((r.max_drift for r in records), default=0.0),
        max_deficit=max((r.max_deficit for r in records), default=0.0), scale=float(s), seed=seed,
        disturbance_times=DEFAULT_HOLD * np.arange(len(run.samples)),
        disturbance_samples=np.array(run.samples).reshape(-1, plan.disturbances.dim),
        slip_tolerance=float(slip_tolerance), dt=float(dt),
        timings={"simulation": time.perf_counter() - start})


def gait_payload(plan: GaitPlan, result: GaitResult | None) -> dict[str, Any]:
    """The ``frc climb --cycles N --json`` document.

    ``cycles``, ``heights`` (the base's height at the end of each cycle [m]), ``phases`` (each
    with its ``max_disturbance_scale``), ``weakest_phase``, ``hand_overs`` and ``simulation``
    (``samples`` as ``frc simulate --json``'s: ``times``, ``q``, ``v``...; plus each step's
    ``torques``, ``phase``, ``mode`` and ``mode_contacts``) are the contract; the rest reports how.
    """
    scene = plan.scene
    weakest = plan.weakest
    payload: dict[str, Any] = {
        "found": True,
        "cycles": plan.cycles,
        "lower_brace": list(plan.lower),
        "upper_brace": list(plan.upper),
        "scale": plan.scale,
        "margin": plan.margin,
        "weakest_phase": {"name": weakest.name, "cycle": weakest.cycle,
                          "max_disturbance_scale": weakest.scale},
        "phases": [p.to_dict() for p in plan.phases],
        "hand_overs": [h.to_dict(scene.inputs.coordinates) for h in plan.hand_overs],
        "unambiguous_hand_overs": plan.unambiguous,
        "limits": {"inputs": list(scene.inputs.coordinates), "lower": scene.inputs.lower,
                   "upper": scene.inputs.upper},
        "geometry": {"link_length": plan.geometry.link_length, "walls": [plan.geometry.left_wall,
                     plan.geometry.right_wall], "stroke": list(STROKE), "upper_span": UPPER_SPAN,
                     "standoff": STANDOFF, "press": PRESS},
        "disturbances": [{"name": d.name, "link": d.link, "point": d.point_in_link, "vertices": d.vertices}
                         for d in plan.disturbances.items],
        "tolerances": {"margin": plan.margin, "touch_gap": TOUCH_GAP, "slip": BRACE_SLIP_TOLERANCE,
                       "robustness_penalty": ROBUSTNESS_PENALTY},
        "solver": plan.solver,
        "heights": [],
        "simulation": None,
        "timings": dict(plan.timings),
    }
    if result is not None:
        payload.update(_result_payload(plan, result))
    return add_scene_modes(to_jsonable(payload), [c.name for c in scene.contacts])


def _result_payload(plan: GaitPlan, result: GaitResult) -> dict[str, Any]:
    """The simulation's part of :func:`gait_payload`."""
    trajectory = result.trajectory
    samples = trajectory.to_dict(plan.scene)["samples"]
    samples.update({"torques": result.torques, "phase": result.phase_of_step,
                    "controller_mode": list(result.modes),
                    "mode_contacts": [list(c) for c in result.mode_contacts], "deficit": result.deficits})
    start = float(trajectory.q[0, 1])
    heights = [h - start for h in result.heights]
    return {
        "heights": heights,
        "rise_per_cycle": np.diff(np.concatenate([[0.0], heights])).tolist(),
        "phase_runs": [r.to_dict() for r in result.phases],
        "simulation": {
            "samples": samples, "rise": result.rise, "brace_held": result.brace_held,
            "max_slip": result.max_slip, "max_drift": result.max_drift,
            "max_deficit": result.max_deficit, "scale": result.scale, "seed": result.seed, "dt": result.dt,
            "status": trajectory.status, "slip_tolerance": result.slip_tolerance,
            "phases_completed": len(result.phases),
            "disturbance_times": result.disturbance_times, "disturbance_samples": result.disturbance_samples,
            "events": [e.to_dict() for e in trajectory.events],
            "timings": dict(result.timings),
        },
    }

