"""Benchmark: frcontrol against MuJoCo and Drake on the same problems.

Run from the repository root::

    pip install ".[peers]" && python -m benchmarks.peers   # the full run (2-3 minutes here)
    python -m benchmarks.peers --quick                     # a smoke run (seconds), to a temporary folder
    python -m benchmarks.peers --readme                    # the benchmarks page's tables, from peers.json
    python -m benchmarks.peers --replot                    # redraw the figures from peers.json

Writes ``benchmarks/results/peers.json`` and one figure per problem,
``benchmarks/results/peers_<problem>.png`` (force error against compute time, log-log, one marker per
simulator and setting). MuJoCo and Drake are imported inside the functions that use them, so this
module imports with frcontrol alone (the tests use its helpers).

The problems
------------
Two shipped scenes, at their file's state (``v = 0``) and zero input:

================  ====  ===============================================================
problem           mode  what
================  ====  ===============================================================
rod_on_table      F     a 1 m, 1 kg rod, its lower tip on a table (mu 1.4): it pivots about
                        the sticking tip, so the answer is a motion, not a rest
box_on_slope      FF    a 1 x 0.5 m, 1 kg box on two corners on a 20 deg slope (mu 0.5):
                        it sticks; the tangential split between the corners is indeterminate
================  ====  ===============================================================

**Same physics.** The peers' models are built here, in code, from the loaded scene
(:func:`peer_body`): the mass, the centre of mass and the central inertia come from frcontrol's own
mass matrix at the state (so they are the URDF's), the coordinates are frcontrol's ``x, y, theta``
(MuJoCo: slide x, slide z and a hinge about -y, the plane x-y mapped onto MuJoCo's x-z with gravity
along -z; Drake: a ``PlanarJoint`` with gravity along -y), and every active contact is a sphere of
radius :data:`SPHERE_RADIUS` fixed on the body, placed so that its lowest point is the contact point,
:data:`INITIAL_PENETRATION` into the surface (both peers report no contact at an exact zero
distance), against a plane (MuJoCo) or half-space (Drake) through the scene's surface line, with
the contact's mu. MuJoCo: elliptic friction cone, ``condim = 3``. Drake: point contact.

**Reference** (:func:`benchmarks.trade.build_reference`): frcontrol's exact rigid answer,
``frcontrol.solutions_at(scene, u = 0)`` (HiGHS): one motion, in the mode above.

**Force error** of an answer ``f = (lam_N, lam_T)`` over the contacts
(:func:`benchmarks.trade.force_error`): ``min_w |f - f_ref - N w| / |f_ref|``, modulo the internal
forces ``N w`` of a statically indeterminate mode (the box). The peers' forces are read per contact
sphere in the world and projected on the surface's normal ``n`` and tangent ``t = (n_y, -n_x)``.

What each point is
------------------
- **MuJoCo**: one ``mj_step`` from the state (its contact forces are those of the step's forward
  pass, at the state). Settings: the time step, ``solref`` (time constant), ``solimp`` (the
  impedance ``d``, which sets the force error of one step: about ``1 - d``), ``impratio``; the
  defaults are MuJoCo's (2 ms, ``solref 0.02 1``, ``solimp 0.9 0.95 0.001``), with the elliptic cone
  (MuJoCo's default cone, pyramidal, is one more point).
- **Drake**: one discrete step of the ``MultibodyPlant`` from the state
  (``CalcForcedDiscreteVariableUpdate`` and its contact results; ``use_sampled_output_ports`` off, so
  the results are those of that step). Settings: the discrete contact approximation (``tamsi``,
  ``sap``, ``lagged``), the time step, the point stiffness (both geometries get ``2 k``: Drake
  combines them in series) and, for the SAP family, ``sap_near_rigid_threshold`` 0 besides its
  default 1 (at 1, SAP saturates a stiffness beyond its near-rigid limit: a softer contact,
  which Drake's documentation suggests lifting with 0). The defaults are
  ``MultibodyPlantConfig()``'s (1 ms, ``lagged``, stiffness from the 1 mm penetration allowance,
  stiction tolerance 1e-4 m/s) with point contact.
- **frcontrol rigid**: ``solutions_at(scene, {})`` from scratch, and on an existing ``analyze``
  result (the analysis not timed): one input, and per point of a batch of :data:`BATCH_POINTS`
  inputs (``solutions_at(analysis, U)``, the same input repeated).
- **frcontrol compliant**: ``frcontrol.simulate`` on the scene loaded with
  ``overrides={"model.contact": "compliant", "model.stiffness": k}`` (critical damping), from relaxed
  springs, read after a settling window ``N_r / omega_min`` as in :mod:`benchmarks.trade`. Settings:
  ``k``, the integrator, its accuracy and the window. Defaults: the scene's ``[model]`` defaults
  (k = 1e5 N/m, Radau, rtol 1e-6) read after one default sample interval (1 ms).

**Time to 1e-3**: per simulator, the median compute time (``--runs`` runs after
:data:`WARM_UP_CALLS` untimed ones, each from a fresh state: MuJoCo's data reset, so no warm start,
Drake's state set; frcontrol's rigid queries as many after as many) of the cheapest setting whose force error
is at most :data:`TARGET_FORCE_ERROR`. frcontrol's compliant settings run once each (after one
warm-up run), as in :mod:`benchmarks.trade`, and the cheapest one reaching the target, and the
defaults, are re-timed as medians. The runs after :data:`CREEP_DURATION` are timed once.
**Error at defaults**: of one step (each at its own default step); for the box, which rests, also
after :data:`CREEP_DURATION` of simulation. Every time is also given as a ratio to frcontrol's
rigid ``solutions_at`` from scratch measured in the same process.

**Creep**: the box on the slope with ``mu = 1`` on both corners (it must stick: ``tan 20 deg <
1``), simulated for :data:`CREEP_DURATION` from rest; the box's speed along the slope at the end
(its centre of mass, [m/s]). MuJoCo and Drake: every setting; frcontrol: rigid (``simulate_rigid``,
1 ms steps), compliant at its defaults and at the setting that reached 1e-3 cheapest on the box.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import inspect
import json
import logging
import math
import os
import platform
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.trade import (
    ATOL_FLOOR,
    ERROR_FLOOR,
    MAX_EULER_STEPS,
    SCENARIOS,
    TARGET_FORCE_ERROR,
    Reference,
    _jsonable,
    build_reference,
    euler_limit,
    force_error,
    median_time,
)
from frcontrol.engine import analyze, solutions_at
from frcontrol.errors import FrcontrolError
from frcontrol.scene import Scene, load_scene
from frcontrol.simulation import CompliantSettings, simulate, simulate_rigid

RESULTS = Path(__file__).resolve().parent / "results"
README = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
"""The manual's page that holds the generated tables."""
PEER_MODULES = {"mujoco": "mujoco", "drake": "pydrake"}
"""The module each peer is imported as."""

PROBLEMS = ("rod_on_table", "box_on_slope")
"""The shipped scenes compared (their mode and input: :data:`benchmarks.trade.SCENARIOS`)."""

SPHERE_RADIUS = 1e-3
"""[m] Radius of the peers' contact spheres (the contact point is the sphere's lowest point)."""

INITIAL_PENETRATION = 1e-12
"""[m] Depth of the peers' spheres in their surface at the start: at an exact zero distance
neither MuJoCo nor Drake reports the contact. What it adds to a step's force: in Drake, about
``min(k, m / h^2) * 1e-12 m`` (a stiff contact removes a penetration within the step), below 1e-6 N
for every stiffness swept at m = 1 kg, h >= 1e-3 s, against reference forces of 3-9 N; in MuJoCo, a
reference acceleration of solref's stiffness (<= 1e6 /s^2 at the smallest time constant swept) times
1e-12 m, below 1e-5 m/s^2."""

DEFAULT_SAMPLE = inspect.signature(simulate).parameters["dt"].default
"""[s] ``frcontrol.simulate``'s default sample interval: the compliant defaults are read after it."""

CREEP_DURATION = 1.0
"""[s] Simulated time of the creep runs and of the box's "after 1 s" force errors."""

CREEP_MU = 1.0
"""[-] Friction coefficient of both box corners in the creep runs."""

RIGID_CREEP_STEP = 1e-3
"""[s] Time step of frcontrol's rigid creep run (``simulate_rigid``'s default)."""

MAX_CREEP_STEPS = 20_000
"""A fixed-step compliant creep run predicted to need more steps is skipped (recorded as such)."""

DEFAULT_RUNS = 7
"""Runs per timed point (median)."""

REST_ACCELERATION = 1e-9
"""[m/s^2, rad/s^2] A reference whose accelerations are all below this is at rest (the box): its
forces hold for as long as it stays, so a peer's force after the creep duration is compared too."""

NOSLIP_ITERATIONS = 10
"""MuJoCo's noslip iterations in the creep runs that add them (MuJoCo's remedy for creep)."""


# ------------------------------------------------------------------------------------ settings
@dataclass(frozen=True)
class MujocoSetting:
    """The MuJoCo knobs of one point (the defaults are MuJoCo's, cone aside)."""

    label: str
    timestep: float = 0.002             # [s]
    timeconst: float = 0.02             # [s] solref[0]
    dampratio: float = 1.0              # [-] solref[1]
    solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    impratio: float = 1.0
    cone: str = "elliptic"
    noslip_iterations: int = 0


@dataclass(frozen=True)
class DrakeSetting:
    """The Drake knobs of one point (the defaults are ``MultibodyPlantConfig()``'s)."""

    label: str
    approximation: str = "lagged"
    time_step: float = 1e-3             # [s]
    stiffness: float | None = None      # [N/m] effective point stiffness; None: from the allowance
    near_rigid_threshold: float = 1.0   # SAP's sap_near_rigid_threshold (0: the stiffness as given)


@dataclass(frozen=True)
class CompliantSetting:
    """frcontrol's compliant knobs of one point."""

    label: str
    stiffness: float | None = None      # [N/m]; None: the scene's [model] default
    integrator: str = "radau"
    rtol: float | None = None           # None: simulate's default (and its default atol)
    euler_fraction: float | None = None  # the euler step as a fraction of the stability limit
    window: float | None = None         # N_r; None: read after one default sample (1 ms)
    steps: int | None = None            # implicit: the window in this many fixed steps


@dataclass(frozen=True)
class Grid:
    """The settings of one run of the benchmark."""

    mujoco: tuple[MujocoSetting, ...]
    drake: tuple[DrakeSetting, ...]
    compliant: tuple[CompliantSetting, ...]
    runs: int
    creep_duration: float = CREEP_DURATION


MUJOCO_DEFAULTS = MujocoSetting("defaults")
DRAKE_DEFAULTS = DrakeSetting("defaults")
COMPLIANT_DEFAULTS = CompliantSetting("defaults")


def mujoco_grid(steps: tuple[float, ...], impedances: tuple[float, ...],
                impratios: tuple[float, ...]) -> tuple[MujocoSetting, ...]:
    """The defaults, the pyramidal defaults, then timeconst 2 dt with every step, d and impratio."""
    out = [MUJOCO_DEFAULTS, MujocoSetting("defaults, pyramidal cone", cone="pyramidal")]
    for h in steps:
        for d in impedances:
            for ratio in impratios:
                out.append(MujocoSetting(f"dt {h:g}, solref {2 * h:g}, d {d:g}, impratio {ratio:g}",
                                         timestep=h, timeconst=2 * h, solimp=(d, d, 0.001),
                                         impratio=ratio))
    return tuple(out)


def drake_grid(approximations: tuple[str, ...], steps: tuple[float, ...],
               stiffnesses: tuple[float | None, ...]) -> tuple[DrakeSetting, ...]:
    """Every approximation, step and stiffness (the defaults are among them); the SAP family
    (``sap``, ``lagged``) also without its near-rigid regime at every given stiffness."""
    out = []
    for a in approximations:
        for h in steps:
            for k in stiffnesses:
                thresholds = (1.0, 0.0) if a != "tamsi" and k is not None else (1.0,)
                for threshold in thresholds:
                    label = f"{a}, h {h:g}, k {'default' if k is None else f'{k:.0e}'}"
                    label += ", near-rigid 0" if threshold == 0.0 else ""
                    setting = DrakeSetting(label, a, h, k, threshold)
                    out.append(DRAKE_DEFAULTS if setting == DrakeSetting(setting.label) else setting)
    return tuple(out)


def compliant_grid(stiffnesses: tuple[float, ...], integrators: tuple[str, ...],
                   rtols: tuple[float, ...], windows: tuple[float, ...],
                   euler_fraction: float = 0.3) -> tuple[CompliantSetting, ...]:
    """The defaults, then every stiffness, window, integrator and accuracy."""
    out = [COMPLIANT_DEFAULTS]
    for k in stiffnesses:
        for window in windows:
            for integrator in integrators:
                if integrator == "euler":
                    out.append(CompliantSetting(f"k {k:.0e}, euler {euler_fraction:g}x limit, window "
                                                f"{window:g}", k, "euler", None, euler_fraction, window))
                    continue
                for rtol in rtols:
                    out.append(CompliantSetting(f"k {k:.0e}, {integrator} rtol {rtol:g}, window {window:g}",
                                                k, integrator, rtol, None, window))
    return tuple(out)


def implicit_grid(stiffnesses: tuple[float, ...], step_omegas: tuple[float, ...], steps: int
                  ) -> tuple[CompliantSetting, ...]:
    """The linearly implicit integrator: ``steps`` fixed steps of ``step_omega / omega_min`` each."""
    return tuple(CompliantSetting(f"k {k:.0e}, implicit, {steps} steps of {w:g}/omega", k, "implicit",
                                  None, None, steps * w, steps)
                 for k in stiffnesses for w in step_omegas)


FULL = Grid(
    mujoco=mujoco_grid((0.002, 0.001, 0.0005), (0.99, 0.999, 0.9999), (1.0, 10.0)),
    drake=drake_grid(("tamsi", "sap", "lagged"), (1e-3, 1e-2), (None, 1e6, 1e8, 1e10)),
    compliant=compliant_grid((1e5, 1e6, 1e7), ("radau", "lsoda", "euler"), (1e-3, 1e-6), (12.0, 40.0))
    + implicit_grid((1e8, 1e10, 1e12), (30.0, 100.0), 3),
    runs=DEFAULT_RUNS,
)
QUICK = Grid(
    mujoco=mujoco_grid((0.002,), (0.9999,), (1.0,)),
    drake=drake_grid(("tamsi", "lagged"), (1e-3, 1e-2), (None, 1e8)),
    compliant=compliant_grid((1e5,), ("radau",), (1e-3,), (12.0,)),
    runs=3,
    creep_duration=0.1,
)


# ------------------------------------------------------------------------------------ the body
@dataclass(frozen=True)
class PeerContact:
    """A contact as the peers model it.

    Attributes:
        name: the scene's contact name.
        point_in_world: the contact point [m] at the state, projected onto the surface line.
        normal: the surface's unit normal [-] in the plane, pointing at the body.
        mu: Coulomb coefficient [-].
        sphere_centre_in_link: the contact sphere's centre [m] in the link frame.
    """

    name: str
    point_in_world: np.ndarray
    normal: np.ndarray
    mu: float
    sphere_centre_in_link: np.ndarray

    @property
    def tangent(self) -> np.ndarray:
        """``t = (n_y, -n_x)`` [-], frcontrol's tangent."""
        return np.array([self.normal[1], -self.normal[0]])


@dataclass(frozen=True)
class PeerBody:
    """One rigid body on a planar base with point contacts: what the peers' models are built from.

    Attributes:
        scene: the scene's name.
        mass: [kg].
        com_in_link: the centre of mass [m] in the link frame.
        inertia: the central moment of inertia about the plane's normal [kg m^2].
        q: the state (x [m], y [m], theta [rad]).
        gravity: [m/s^2] along -y.
        contacts: the active contacts, in the scene's order.
    """

    scene: str
    mass: float
    com_in_link: np.ndarray
    inertia: float
    q: np.ndarray
    gravity: float
    contacts: tuple[PeerContact, ...] = field(default_factory=tuple)

    def world_from_link(self, point: np.ndarray) -> np.ndarray:
        """A link-frame point [m] in the world at the state."""
        c, s = math.cos(self.q[2]), math.sin(self.q[2])
        return self.q[:2] + np.array([[c, -s], [s, c]]) @ point


def peer_body(scene: Scene, radius: float = SPHERE_RADIUS,
              penetration: float = INITIAL_PENETRATION) -> PeerBody:
    """The scene's body, mass properties read from frcontrol's mass matrix at the state.

    With a planar base ``(x, y, theta)`` and the centre of mass at ``c`` (world, from the base
    origin), ``M = [[m, 0, -m c_y], [0, m, m c_x], [-m c_y, m c_x, I + m |c|^2]]``.

    Raises:
        ValueError: the scene is not one body on a planar base.
    """
    if scene.coordinate_names != ("x", "y", "theta"):
        raise ValueError(f"{scene.name}: the peers' models need one body on a planar base; "
                         f"coordinates {scene.coordinate_names}")
    q = np.asarray(scene.q, dtype=float)
    M = scene.robot.mass_matrix(q)
    mass = float(M[0, 0])
    com_world = np.array([M[1, 2], -M[0, 2]]) / mass
    inertia = float(M[2, 2] - mass * com_world @ com_world)
    c, s = math.cos(q[2]), math.sin(q[2])
    link_from_world = np.array([[c, s], [-s, c]])
    state = scene.state()
    contacts = []
    for contact, point in zip(scene.active_contacts, state.contact_points, strict=True):
        p = contact.point
        n = np.asarray(p.normal_in_world, dtype=float)
        on_surface = point - float(n @ (point - p.surface_point_in_world)) * n
        centre = on_surface + (radius - penetration) * n
        contacts.append(PeerContact(p.name, on_surface, n, float(p.mu),
                                    link_from_world @ (centre - q[:2])))
    return PeerBody(scene.name, mass, link_from_world @ com_world, inertia, q,
                    float(scene.robot.gravity), tuple(contacts))


def surface_planes(body: PeerBody) -> list[tuple[np.ndarray, np.ndarray]]:
    """The distinct surface lines (normal, point) of the body's contacts."""
    planes: list[tuple[np.ndarray, np.ndarray]] = []
    for contact in body.contacts:
        n, p = contact.normal, contact.point_in_world
        if not any(np.allclose(n, m) and abs(float(n @ (p - o))) < 1e-12 for m, o in planes):
            planes.append((n, p))
    return planes


def contact_forces_from_world(body: PeerBody, forces: dict[int, np.ndarray]) -> np.ndarray:
    """``(lam_N, lam_T)`` over the body's contacts from world forces on the body [N] per contact."""
    zero = np.zeros(2)
    lam_n = [float(forces.get(i, zero) @ c.normal) for i, c in enumerate(body.contacts)]
    lam_t = [float(forces.get(i, zero) @ c.tangent) for i, c in enumerate(body.contacts)]
    return np.array(lam_n + lam_t)


def tangential_speed(body: PeerBody, velocity: np.ndarray) -> float:
    """|centre-of-mass velocity along the first contact's tangent| [m/s] from ``(vx, vy, omega)``."""
    c, s = math.cos(body.q[2]), math.sin(body.q[2])
    com = np.array([[c, -s], [s, c]]) @ body.com_in_link
    v_com = velocity[:2] + velocity[2] * np.array([-com[1], com[0]])
    return abs(float(v_com @ body.contacts[0].tangent))


# ------------------------------------------------------------------------------------ timing
WARM_UP_CALLS = 10
"""Untimed calls before a simulator's step or frcontrol's query is timed: a process's first calls of
a function run on cold caches (frcontrol's rod from scratch: 7.6 us over its first ten calls, 5.6 us
after), and every simulator is timed warm, as a loop that steps or queries runs."""


def warmed(call: Callable[[], Any], prepare: Callable[[], Any] | None = None) -> Callable[[], Any]:
    """``call`` after :data:`WARM_UP_CALLS` untimed calls (each after ``prepare``)."""
    for _ in range(WARM_UP_CALLS):
        if prepare is not None:
            prepare()
        call()
    return call


def median_prepared(prepare: Callable[[], Any], call: Callable[[], Any], runs: int) -> tuple[float, int]:
    """Median wall time [s] of ``call`` over ``runs`` runs, each after an untimed ``prepare``, once warm
    (:func:`warmed`)."""
    warmed(call, prepare)
    times = []
    for _ in range(max(1, runs)):
        prepare()
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times), len(times)


# ------------------------------------------------------------------------------------ MuJoCo
def mujoco_xml(body: PeerBody, setting: MujocoSetting, radius: float = SPHERE_RADIUS) -> str:
    """The MJCF model: the plane (x, y) is MuJoCo's (x, z); the body's link x, y, z are its x, z, -y."""
    a, b, w = setting.solimp

    def num(x: float) -> str:
        return repr(float(x))

    planes = "".join(
        f'    <geom name="surface{j}" type="plane" size="0 0 1" pos="{num(p[0])} 0 {num(p[1])}" '
        f'zaxis="{num(n[0])} 0 {num(n[1])}" friction="0 0 0"/>\n'
        for j, (n, p) in enumerate(surface_planes(body)))
    spheres = "".join(
        f'      <geom name="contact{i}" type="sphere" size="{num(radius)}" '
        f'pos="{num(c.sphere_centre_in_link[0])} 0 {num(c.sphere_centre_in_link[1])}" '
        f'friction="{num(c.mu)} 0 0"/>\n'
        for i, c in enumerate(body.contacts))
    inertia = f"{num(body.inertia)} {num(body.inertia)} {num(body.inertia)}"  # only the hinge's axis moves
    return (
        f'<mujoco model="{body.scene}">\n'
        f'  <option timestep="{num(setting.timestep)}" gravity="0 0 {num(-body.gravity)}" '
        f'cone="{setting.cone}" '
        f'impratio="{num(setting.impratio)}" noslip_iterations="{setting.noslip_iterations}"/>\n'
        f'  <default><geom condim="3" solref="{num(setting.timeconst)} {num(setting.dampratio)}" '
        f'solimp="{num(a)} {num(b)} {num(w)}"/></default>\n'
        f"  <worldbody>\n{planes}"
        f'    <body name="body">\n'
        f'      <joint name="x" type="slide" axis="1 0 0"/>\n'
        f'      <joint name="y" type="slide" axis="0 0 1"/>\n'
        f'      <joint name="theta" type="hinge" axis="0 -1 0"/>\n'
        f'      <inertial pos="{num(body.com_in_link[0])} 0 {num(body.com_in_link[1])}" '
        f'mass="{num(body.mass)}" '
        f'diaginertia="{inertia}"/>\n{spheres}'
        f"    </body>\n  </worldbody>\n</mujoco>\n"
    )


class MujocoRun:
    """A MuJoCo model and data of one setting, reset to the body's state on demand."""

    def __init__(self, body: PeerBody, setting: MujocoSetting) -> None:
        import mujoco

        self.mujoco, self.body, self.setting = mujoco, body, setting
        self.model = mujoco.MjModel.from_xml_string(mujoco_xml(body, setting))
        self.data = mujoco.MjData(self.model)
        self.spheres = {self.model.geom(f"contact{i}").id: i for i in range(len(body.contacts))}

    def reset(self) -> None:
        """The body's state, zero velocity, no warm start."""
        self.mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = self.body.q

    def step(self) -> None:
        """One ``mj_step``."""
        self.mujoco.mj_step(self.model, self.data)

    def forces(self) -> np.ndarray:
        """``(lam_N, lam_T)`` of the last forward pass's contacts."""
        world: dict[int, np.ndarray] = {}
        wrench = np.zeros(6)
        for k in range(self.data.ncon):
            contact = self.data.contact[k]
            if contact.efc_address < 0:
                continue
            g1, g2 = int(contact.geom1), int(contact.geom2)
            on_body = g2 if g2 in self.spheres else g1
            self.mujoco.mj_contactForce(self.model, self.data, k, wrench)
            f = contact.frame.reshape(3, 3).T @ wrench[:3]  # on geom2, in the world
            f_plane = np.array([f[0], f[2]]) * (1.0 if on_body == g2 else -1.0)
            i = self.spheres[on_body]
            world[i] = world.get(i, np.zeros(2)) + f_plane
        return contact_forces_from_world(self.body, world)

    def velocity(self) -> np.ndarray:
        """``(vx, vy, omega)``."""
        return np.array(self.data.qvel[:3])


def mujoco_points(ref: Reference, body: PeerBody, grid: Grid, rest: bool) -> list[dict]:
    """One step of every MuJoCo setting; at rest (the box) also the force after the creep duration."""
    points = []
    for setting in grid.mujoco:
        run = MujocoRun(body, setting)
        seconds, runs = median_prepared(run.reset, run.step, grid.runs)
        forces = run.forces()
        points.append(point("MuJoCo", setting.label, asdict(setting), "one step", seconds, runs,
                            ref, forces))
        if rest:
            run.reset()
            steps = round(grid.creep_duration / setting.timestep)
            start = time.perf_counter()
            for _ in range(steps):
                run.step()
            seconds = time.perf_counter() - start
            run.mujoco.mj_forward(run.model, run.data)
            points.append(point("MuJoCo", setting.label, asdict(setting), f"after {grid.creep_duration:g} s",
                                seconds, 1, ref, run.forces()))
    return points


# ------------------------------------------------------------------------------------ Drake
class DrakeRun:
    """A Drake diagram (plant and scene graph) of one setting."""

    def __init__(self, body: PeerBody, setting: DrakeSetting, radius: float = SPHERE_RADIUS) -> None:
        from pydrake.geometry import AddContactMaterial, HalfSpace, ProximityProperties, Sphere
        from pydrake.math import RigidTransform
        from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
        from pydrake.multibody.tree import PlanarJoint, RotationalInertia, SpatialInertia
        from pydrake.systems.framework import DiagramBuilder

        # Drake logs TAMSI's deprecation notice and a note on half-spaces and deformables for every plant
        logging.getLogger("drake").setLevel(logging.ERROR)
        self.body, self.setting = body, setting
        builder = DiagramBuilder()
        config = MultibodyPlantConfig(time_step=setting.time_step, contact_model="point",
                                      discrete_contact_approximation=setting.approximation,
                                      use_sampled_output_ports=False,
                                      sap_near_rigid_threshold=setting.near_rigid_threshold)
        plant, _ = AddMultibodyPlant(config, builder)
        com = np.array([body.com_in_link[0], body.com_in_link[1], 0.0])
        link = plant.AddRigidBody("body", SpatialInertia.MakeFromCentralInertia(
            body.mass, com, RotationalInertia(body.inertia, body.inertia, body.inertia)))
        plant.AddJoint(PlanarJoint("planar", plant.world_frame(), link.body_frame(), np.zeros(3)))

        def material(mu: float) -> ProximityProperties:
            properties = ProximityProperties()
            k = None if setting.stiffness is None else 2.0 * setting.stiffness  # two in series
            AddContactMaterial(point_stiffness=k, friction=CoulombFriction(mu, mu), properties=properties)
            return properties

        top_mu = max(c.mu for c in body.contacts)
        for j, (n, p) in enumerate(surface_planes(body)):
            plant.RegisterCollisionGeometry(
                plant.world_body(),
                HalfSpace.MakePose(np.array([n[0], n[1], 0.0]), np.array([p[0], p[1], 0.0])),
                HalfSpace(), f"surface{j}", material(top_mu))
        self.spheres = {}
        for i, c in enumerate(body.contacts):
            # Drake combines friction as 2 mu1 mu2 / (mu1 + mu2): the sphere gets the mu that gives c.mu
            mu = c.mu * top_mu / (2 * top_mu - c.mu)
            gid = plant.RegisterCollisionGeometry(
                link, RigidTransform(np.array([c.sphere_centre_in_link[0], c.sphere_centre_in_link[1], 0.0])),
                Sphere(radius), f"contact{i}", material(mu))
            self.spheres[gid] = i
        plant.mutable_gravity_field().set_gravity_vector([0.0, -body.gravity, 0.0])
        plant.Finalize()
        self.plant, self.link = plant, link
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.discrete = self.diagram.AllocateDiscreteVariables()
        self.results_port = plant.get_contact_results_output_port()

    def reset(self) -> None:
        """The body's state, zero velocity, time 0."""
        self.context.SetTime(0.0)
        self.plant.SetPositions(self.plant_context, self.body.q)
        self.plant.SetVelocities(self.plant_context, np.zeros(3))

    def step(self) -> None:
        """One discrete step (not applied to the context) and its contact results."""
        self.diagram.CalcForcedDiscreteVariableUpdate(self.context, self.discrete)
        self.results_port.Eval(self.plant_context)

    def forces(self) -> np.ndarray:
        """``(lam_N, lam_T)`` of the step from the context's state."""
        results = self.results_port.Eval(self.plant_context)
        world: dict[int, np.ndarray] = {}
        for k in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(k)
            pair = info.point_pair()
            on_b = info.bodyB_index() == self.link.index()
            gid = pair.id_B if on_b else pair.id_A
            f = np.asarray(info.contact_force())[:2] * (1.0 if on_b else -1.0)
            i = self.spheres[gid]
            world[i] = world.get(i, np.zeros(2)) + f
        return contact_forces_from_world(self.body, world)

    def advance(self, duration: float) -> None:
        """Simulate from the body's state for ``duration`` [s]."""
        from pydrake.systems.analysis import Simulator

        self.reset()
        simulator = Simulator(self.diagram, self.context)
        simulator.Initialize()
        simulator.AdvanceTo(duration)

    def velocity(self) -> np.ndarray:
        """``(vx, vy, omega)``."""
        return np.asarray(self.plant.GetVelocities(self.plant_context))


def drake_name(setting: DrakeSetting) -> str:
    """The simulator's name in the figures: Drake and its discrete contact approximation."""
    return {"tamsi": "Drake TAMSI", "sap": "Drake SAP", "lagged": "Drake lagged"}.get(
        setting.approximation, f"Drake {setting.approximation}")


def drake_points(ref: Reference, body: PeerBody, grid: Grid, rest: bool) -> list[dict]:
    """One step of every Drake setting; at rest (the box) also the force after the creep duration."""
    points = []
    for setting in grid.drake:
        run = DrakeRun(body, setting)
        seconds, runs = median_prepared(run.reset, run.step, grid.runs)
        run.reset()
        points.append(point(drake_name(setting), setting.label, asdict(setting), "one step", seconds, runs,
                            ref, run.forces()))
        if rest:
            start = time.perf_counter()
            run.advance(grid.creep_duration)
            seconds = time.perf_counter() - start
            points.append(point(drake_name(setting), setting.label, asdict(setting),
                                f"after {grid.creep_duration:g} s", seconds, 1, ref, run.forces()))
    return points


# ------------------------------------------------------------------------------------ frcontrol
def compliant_scene(name: str, stiffness: float | None = None, mu: float | None = None) -> Scene:
    """The scene with the compliant model (and a stiffness, and every contact's mu) set by overrides."""
    overrides: dict[str, Any] = {"model.contact": "compliant"}
    if stiffness is not None:
        overrides["model.stiffness"] = stiffness
    if mu is not None:
        overrides.update({f"contacts[{i}].mu": mu for i in range(len(load_scene(name).contacts))})
    return load_scene(name, overrides=overrides)


def compliant_call(ref: Reference, setting: CompliantSetting, scene: Scene, duration: float | None = None
                   ) -> tuple[Callable[[], Any], str | None]:
    """The ``simulate`` call of a setting (duration: its window, or the given one), or why not."""
    options: dict[str, Any] = {"integrator": setting.integrator}
    if setting.window is None:
        window, dt = DEFAULT_SAMPLE, DEFAULT_SAMPLE
    else:
        k = setting.stiffness if setting.stiffness is not None else scene.model.defaults.stiffness
        window = setting.window / math.sqrt(k * ref.slowest_eigenvalue)
        dt = window
        options["max_step"] = window
    duration = window if duration is None else duration
    if setting.rtol is not None:
        delta = float(np.max(np.abs(ref.forces[: len(ref.active)]))) / scene.model.defaults.stiffness
        options.update(rtol=setting.rtol, atol=max(setting.rtol * delta, ATOL_FLOOR))
    if setting.integrator == "euler":
        step = (setting.euler_fraction or 1.0) * euler_limit(ref, scene.model.defaults.stiffness)
        steps = math.ceil(duration / step)
        limit = MAX_EULER_STEPS if duration == window else MAX_CREEP_STEPS
        if steps > limit:
            return (lambda: None), f"skipped: {steps} fixed steps predicted"
        dt = duration / steps
    elif setting.integrator == "implicit" and setting.steps:
        dt = window / setting.steps
        if duration / dt > MAX_CREEP_STEPS:
            return (lambda: None), f"skipped: {duration / dt:.0f} fixed steps predicted"
    else:
        dt = min(dt, duration)

    def call() -> Any:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # SciPy's num_jac overflow warnings
            return simulate(scene, {}, duration, dt, settings=CompliantSettings(**options))

    return call, None


def readout(ref: Reference, trajectory: Any) -> np.ndarray:
    """(lam_N, lam_T) of the active contacts at the last sample."""
    last = trajectory.contact_forces[-1][ref.active]
    return np.concatenate([last[:, 0], last[:, 1]])


def compliant_point(ref: Reference, setting: CompliantSetting, runs: int) -> dict:
    """One compliant setting: its readout's error and time."""
    scene = compliant_scene(ref.scenario.name, setting.stiffness)
    call, skipped = compliant_call(ref, setting, scene)
    kind = (f"one sample ({1e3 * DEFAULT_SAMPLE:g} ms)" if setting.window is None
            else f"window {setting.window:g}/omega_min")
    base = {"simulator": "frcontrol compliant", "setting": setting.label, "settings": asdict(setting),
            "kind": kind}
    if skipped:
        return {**base, "valid": False, "reason": skipped}
    try:
        seconds, times, trajectory = median_time(call, runs)
    except (FrcontrolError, ValueError, np.linalg.LinAlgError) as err:
        return {**base, "valid": False, "reason": f"raised {type(err).__name__}: {str(err)[:160]}"}
    if trajectory.status != "completed":
        return {**base, "valid": False, "reason": f"{trajectory.status}"}
    return point("frcontrol compliant", setting.label, asdict(setting), kind, seconds, len(times), ref,
                 readout(ref, trajectory))


BATCH_POINTS = 100_000
"""Inputs of frcontrol's batch query (``solutions_at(analysis, U)``), timed per point."""


def frcontrol_points(ref: Reference, grid: Grid, rest: bool) -> list[dict]:
    """Rigid from scratch and on an analysis; every compliant setting (the cheapest at 1e-3 re-timed);
    at rest (the box) also the compliant defaults after the creep duration."""
    scene = ref.scene

    def rigid_forces(solutions: list) -> np.ndarray:
        chosen = [s for s in solutions if s.mode == ref.mode]
        if not chosen:
            return np.full(ref.forces.shape, np.nan)
        return np.concatenate([chosen[0].lambda_n, chosen[0].lambda_t])

    seconds, times, solutions = median_time(warmed(lambda: solutions_at(scene, {})), max(grid.runs, 9))
    points = [point("frcontrol rigid", "solutions_at from scratch", {}, "exact", seconds, len(times), ref,
                    rigid_forces(solutions))]
    analysis = analyze(scene)
    seconds, times, solutions = median_time(warmed(lambda: solutions_at(analysis, {})), max(grid.runs, 9))
    points.append(point("frcontrol rigid", "solutions_at on an analysis", {}, "exact", seconds, len(times),
                        ref, rigid_forces(solutions)))
    U = np.zeros((BATCH_POINTS, analysis.problem.m))  # the problem's input, N times over
    seconds, times, batch = median_time(lambda: solutions_at(analysis, U), max(3, grid.runs // 3))
    modes, forces = batch.modes_at(0), np.full(ref.forces.shape, np.nan)
    if ref.mode in modes:
        row = batch.rows(0).start + modes.index(ref.mode)
        forces = np.concatenate([batch.lambda_n[row], batch.lambda_t[row]])
    points.append(point("frcontrol rigid", f"solutions_at on an analysis, per point of {BATCH_POINTS:,}", {},
                        "exact", seconds / BATCH_POINTS, len(times), ref, forces))
    compliant_point(ref, COMPLIANT_DEFAULTS, 1)  # warm-up: the first simulation loads SciPy's integrators
    compliant = [compliant_point(ref, setting, grid.runs if setting == COMPLIANT_DEFAULTS else 1)
                 for setting in grid.compliant]
    reached = [p for p in compliant if p.get("valid") and p["error"] <= TARGET_FORCE_ERROR]
    for p in [min(reached, key=lambda p: p["time"])] if reached else []:
        setting = CompliantSetting(**p["settings"])
        again = compliant_point(ref, setting, grid.runs)
        compliant[compliant.index(p)] = again if again.get("valid") else p
    if rest:
        scene = compliant_scene(ref.scenario.name)
        call, _ = compliant_call(ref, COMPLIANT_DEFAULTS, scene, grid.creep_duration)
        start = time.perf_counter()
        trajectory = call()
        compliant.append(point("frcontrol compliant", COMPLIANT_DEFAULTS.label, asdict(COMPLIANT_DEFAULTS),
                               f"after {grid.creep_duration:g} s", time.perf_counter() - start, 1, ref,
                               readout(ref, trajectory)))
    return points + compliant


# ------------------------------------------------------------------------------------ points
def point(simulator: str, label: str, settings: dict, kind: str, seconds: float, runs: int,
          ref: Reference, forces: np.ndarray) -> dict:
    """A measured point: valid when the forces are finite."""
    valid = bool(np.all(np.isfinite(forces)))
    out = {"simulator": simulator, "setting": label, "settings": settings, "kind": kind, "valid": valid,
           "time": seconds, "runs": runs, "forces": forces}
    if valid:
        out["error"] = force_error(ref, forces)
    else:
        out["reason"] = "no finite forces (the reference's mode not found)"
    return out


def summary(points: list[dict], reference_time: float) -> dict[str, dict]:
    """Per simulator: the cheapest setting reaching the target, and the error at its defaults."""
    out: dict[str, dict] = {}
    for p in points:
        entry = out.setdefault(p["simulator"], {"time_to_target": None})
        if not p.get("valid"):
            continue
        if p["error"] <= TARGET_FORCE_ERROR and (entry["time_to_target"] is None
                                                 or p["time"] < entry["time_to_target"]):
            entry.update(time_to_target=p["time"], setting=p["setting"], kind=p["kind"], error=p["error"],
                         ratio=p["time"] / reference_time)
        if p["setting"] == "defaults":
            key = "defaults_after" if p["kind"].startswith("after") else "defaults_one_step"
            entry[key] = {"error": p["error"], "time": p["time"], "kind": p["kind"],
                          "ratio": p["time"] / reference_time}
    for p in points:  # the best error reached by a simulator that never reached the target
        entry = out[p["simulator"]]
        if entry["time_to_target"] is None and p.get("valid") and (
                "best_error" not in entry or p["error"] < entry["best_error"]):
            entry.update(best_error=p["error"], best_setting=p["setting"])
    return out


def bench_problem(name: str, grid: Grid, peers: tuple[str, ...],
                  progress: Callable[[str], None]) -> dict:
    """Every point of one problem."""
    scenario = next(s for s in SCENARIOS if s.name == name)
    ref = build_reference(scenario, load_scene(name))
    body = peer_body(ref.scene)
    rest = bool(np.max(np.abs(ref.dv)) < REST_ACCELERATION)
    points = frcontrol_points(ref, grid, rest)
    reference_time = points[0]["time"]
    progress(f"{name}: frcontrol rigid {1e6 * reference_time:.0f} us; compliant done")
    if "mujoco" in peers:
        points += mujoco_points(ref, body, grid, rest)
        progress(f"{name}: MuJoCo done")
    if "drake" in peers:
        points += drake_points(ref, body, grid, rest)
        progress(f"{name}: Drake done")
    for p in points:
        if p.get("valid"):
            p["ratio"] = p["time"] / reference_time
    return {"problem": name, "mode": ref.mode, "at_rest": rest, "reference_forces": ref.forces,
            "reference_norm": float(np.linalg.norm(ref.forces)),
            "internal_force_modes": int(ref.internal.shape[1]), "body": asdict(body),
            "reference_time": reference_time,
            "reference_time_is": "frcontrol rigid solutions_at from scratch, median, this process",
            "points": points, "summary": summary(points, reference_time)}


# ------------------------------------------------------------------------------------ creep
def creep(grid: Grid, peers: tuple[str, ...], tuned: dict[str, str], progress: Callable[[str], None]) -> dict:
    """The box at mu = CREEP_MU, from rest, for the creep duration: its speed along the slope.

    ``tuned``: per simulator, the label of its setting that reached the target error cheapest on the
    box (frcontrol compliant runs it and its defaults; MuJoCo adds noslip iterations to both).
    """
    name = "box_on_slope"
    overrides = {f"contacts[{i}].mu": CREEP_MU for i in range(len(load_scene(name).contacts))}
    scene = load_scene(name, overrides=overrides)
    body = peer_body(scene)
    duration = grid.creep_duration
    points: list[dict] = []

    def add(simulator: str, setting: str, speed: float, seconds: float, **extra: Any) -> None:
        points.append({"simulator": simulator, "setting": setting, "speed": speed, "wall_time": seconds,
                       **extra})

    start = time.perf_counter()
    trajectory = simulate_rigid(scene, {}, duration, RIGID_CREEP_STEP)
    add("frcontrol rigid", f"simulate_rigid, dt {RIGID_CREEP_STEP:g}",
        tangential_speed(body, trajectory.v[-1]),
        time.perf_counter() - start, status=trajectory.status)
    scenario = next(s for s in SCENARIOS if s.name == name)
    compliant_tuned = [s for s in grid.compliant if s.label == tuned.get("frcontrol compliant")]
    for setting in [COMPLIANT_DEFAULTS] + compliant_tuned:
        compliant = compliant_scene(name, setting.stiffness, CREEP_MU)
        ref = build_reference(scenario, compliant)
        call, skipped = compliant_call(ref, setting, compliant, duration)
        if skipped:
            points.append({"simulator": "frcontrol compliant", "setting": setting.label, "reason": skipped})
            continue
        start = time.perf_counter()
        trajectory = call()
        add("frcontrol compliant", setting.label, tangential_speed(body, trajectory.v[-1]),
            time.perf_counter() - start, status=trajectory.status)
    progress("creep: frcontrol done")
    if "mujoco" in peers:
        noslip = [MujocoSetting(**{**asdict(ms), "label": f"{ms.label}, noslip {NOSLIP_ITERATIONS}",
                                   "noslip_iterations": NOSLIP_ITERATIONS})
                  for ms in grid.mujoco if ms.label in ("defaults", tuned.get("MuJoCo"))]
        for setting in grid.mujoco + tuple(noslip):
            run = MujocoRun(body, setting)
            run.reset()
            start = time.perf_counter()
            for _ in range(round(duration / setting.timestep)):
                run.step()
            add("MuJoCo", setting.label, tangential_speed(body, run.velocity()), time.perf_counter() - start)
        progress("creep: MuJoCo done")
    if "drake" in peers:
        for ds in grid.drake:
            run = DrakeRun(body, ds)
            start = time.perf_counter()
            run.advance(duration)
            add(drake_name(ds), ds.label, tangential_speed(body, run.velocity()), time.perf_counter() - start)
        progress("creep: Drake done")
    return {"problem": name, "mu": CREEP_MU, "duration": duration,
            "speed_is": "centre of mass along the slope",
            "points": points}


# ------------------------------------------------------------------------------------ figures
STYLE = {
    "frcontrol rigid": ("k", "*", 160),
    "frcontrol compliant": ("tab:blue", "o", 30),
    "MuJoCo": ("tab:orange", "s", 30),
    "Drake TAMSI": ("tab:green", "^", 36),
    "Drake SAP": ("tab:purple", "v", 36),
    "Drake lagged": ("tab:brown", "D", 28),
}


def plot_problem(result: dict, path: Path) -> None:
    """Force error against compute time, one marker per simulator and setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12.5, 7.6))
    points = [p for p in result["points"] if p.get("valid")]
    for simulator, (color, marker, size) in STYLE.items():
        if simulator == "frcontrol rigid":
            continue
        for after in (False, True):
            chosen = [p for p in points
                      if p["simulator"] == simulator and p["kind"].startswith("after") == after]
            if chosen:
                ax.scatter([p["time"] for p in chosen], [max(p["error"], ERROR_FLOOR) for p in chosen],
                           s=size, marker=marker, alpha=0.8, zorder=3, edgecolors=color,
                           facecolors="none" if after else color,
                           label=simulator + (f" ({chosen[0]['kind']}, a longer run)" if after else ""))
    notes = []
    for p in points:
        if p["simulator"] == "frcontrol rigid":
            shade = "k" if "scratch" in p["setting"] else "0.55"
            ax.scatter([p["time"]], [max(p["error"], ERROR_FLOOR)], marker="*", s=220, zorder=4, color=shade,
                       label=f"frcontrol rigid, {p['setting']}")
            notes.append((p["time"], max(p["error"], ERROR_FLOOR),
                          f"frcontrol rigid, {p['setting']} (exact)"))
    for simulator, entry in result["summary"].items():
        if simulator == "frcontrol rigid":
            continue
        if entry.get("time_to_target") is not None:
            kind = "" if entry["kind"] == "one step" or entry["kind"].startswith("window") \
                else f" ({entry['kind']})"
            notes.append((entry["time_to_target"], entry["error"],
                          f"{simulator}, cheapest to {TARGET_FORCE_ERROR:g}: {entry['setting']}{kind}"))
        if "defaults_one_step" in entry:
            d = entry["defaults_one_step"]
            notes.append((d["time"], d["error"], f"{simulator} defaults ({d['kind']})"))
    notes.sort(key=lambda n: (-n[1], n[0]))
    offsets_y = np.linspace(0.95, 0.05, max(len(notes), 2))
    for (x, y, text), oy in zip(notes, offsets_y, strict=False):
        ax.annotate(text, (x, max(y, ERROR_FLOOR)), xytext=(1.02, oy), textcoords="axes fraction", fontsize=7,
                    va="center", arrowprops={"arrowstyle": "-", "color": "0.6", "lw": 0.5})
    ax.axhline(TARGET_FORCE_ERROR, color="r", ls="--", lw=0.9,
               label=f"{TARGET_FORCE_ERROR:g} relative force error")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("compute time per answer [s] (median; one step, one simulation window or one call)")
    ax.set_ylabel("relative contact-force error [-]")
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3)
    ax.set_title(f"{result['problem']}: force error against compute time (errors below {ERROR_FLOOR:g} drawn "
                 f"at {ERROR_FLOOR:g}; frcontrol rigid is exact)", fontsize=9)
    fig.tight_layout()
    fig.subplots_adjust(right=0.6, bottom=0.24)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------ the benchmarks page (docs/benchmarks.md)
def fmt_time(seconds: float | None) -> str:
    """A time [s] in us or ms."""
    if seconds is None:
        return "-"
    if seconds < 1e-5:
        return f"{1e6 * seconds:.1f} us"
    return f"{1e6 * seconds:.0f} us" if seconds < 1e-3 else f"{1e3 * seconds:.1f} ms"


def readme_tables(payload: dict) -> str:
    """The benchmarks page's markdown tables from a peers.json payload."""
    problems = payload["problems"]
    simulators = list(dict.fromkeys(name for r in problems for name in r["summary"]))
    head = ["simulator"] + [f"{r['problem']}: time to 1e-3 (x frcontrol rigid)" for r in problems] + [
        f"{r['problem']}: error at defaults, one step" for r in problems]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for name in simulators:
        cells = [name]
        for r in problems:
            e = r["summary"].get(name, {})
            if name == "frcontrol rigid":
                rigid = [p for p in r["points"] if p["simulator"] == name and p.get("valid")]
                cells.append("; ".join(f"{fmt_time(p['time'])} ({p['setting'].replace('solutions_at ', '')}, "
                                       f"x{p['ratio']:.2g})" for p in rigid))
            elif e.get("time_to_target") is not None:
                kind = "" if e["kind"] in ("one step", "exact") or e["kind"].startswith("window") \
                    else f", {e['kind']}"
                cells.append(f"{fmt_time(e['time_to_target'])} (x{e['ratio']:.2g}): {e['setting']}{kind}")
            else:
                cells.append(f"not reached (best {e.get('best_error', float('nan')):.1e})")
        for r in problems:
            e = r["summary"].get(name, {})
            d = e.get("defaults_one_step")
            if name == "frcontrol rigid":
                errors = [p["error"] for p in r["points"] if p["simulator"] == name and p.get("valid")]
                cells.append(f"{max(errors):.0e} (exact)" if errors else "-")
            elif d:
                after = e.get("defaults_after")
                extra = f"; {after['error']:.1e} {after['kind']}" if after else ""
                cells.append(f"{d['error']:.1e} ({fmt_time(d['time'])}){extra}")
            else:
                cells.append("-")
        lines.append("| " + " | ".join(cells) + " |")
    creep_data = payload.get("creep")
    if creep_data:
        box = next((r for r in problems if r["problem"] == creep_data["problem"]), None)
        tuned = {name: e.get("setting") for name, e in (box["summary"] if box else {}).items()}
        lines += ["", f"Creep: the box on the slope at mu = {creep_data['mu']:g}, speed along the slope "
                  f"after {creep_data['duration']:g} s from rest (each simulator at its defaults and at its "
                  f"cheapest setting reaching {payload['target_force_error']:g} on the box):", "",
                  "| simulator | setting | speed [m/s] |", "| --- | --- | --- |"]
        for p in creep_data["points"]:
            best = tuned.get(p["simulator"])
            shown = (p["simulator"].startswith("frcontrol") or p["setting"].startswith("defaults")
                     or p["setting"] in (best, f"{best}, noslip {NOSLIP_ITERATIONS}"))
            if "speed" in p and shown:
                lines.append(f"| {p['simulator']} | {p['setting']} | {p['speed']:.1e} |")
    versions = payload["versions"]
    lines += ["", "x: the time over frcontrol's rigid `solutions_at` from scratch in the same run. "
              "Defaults: each simulator's own, one step of its default size (frcontrol compliant: its "
              f"first {1e3 * DEFAULT_SAMPLE:g} ms sample); a row without defaults is not its simulator's "
              "default (Drake's is `lagged`).", "", *conclusions(payload), "",
              f"MuJoCo {versions.get('mujoco')}, Drake {versions.get('drake')}, "
              f"{payload['cpu_count']} cores (shared with other work), medians of {payload['grid']['runs']} "
              f"runs, the whole run {payload['wall_time_s']:.0f} s; `{payload['command']}`."]
    return "\n".join(lines)


def _against(ours: float, theirs: float, where: str = "on an analysis") -> str:
    """frcontrol's time (``where``) against a peer's, in words: which is faster, by how much."""
    if ours <= theirs:
        return f"{where} frcontrol's answer is {theirs / ours:.1f}x faster than it"
    return f"it is {ours / theirs:.1f}x faster than frcontrol's answer {where}"


def conclusions(payload: dict) -> list[str]:
    """The comparison in words: how much slower frcontrol is than the fastest peers, and the creep."""
    lines = []
    for r in payload["problems"]:
        rigid = {p["setting"]: p["time"] for p in r["points"]
                 if p["simulator"] == "frcontrol rigid" and p.get("valid")}
        scratch = rigid.get("solutions_at from scratch")
        on_analysis = rigid.get("solutions_at on an analysis")
        reached = {name: e for name, e in r["summary"].items()
                   if not name.startswith("frcontrol") and e.get("time_to_target") is not None}
        if scratch is None or on_analysis is None or not reached:
            continue
        text = (f"- {r['problem']}: frcontrol's exact answer takes {fmt_time(scratch)} from scratch, "
                f"{fmt_time(on_analysis)} on an analysis.")
        for family in ("MuJoCo", "Drake"):
            found = {n: e for n, e in reached.items() if n.startswith(family)}
            if found:
                name, e = min(found.items(), key=lambda item: item[1]["time_to_target"])
                t = e["time_to_target"]
                text += (f" The fastest {family} answer within {payload['target_force_error']:g} "
                         f"({name}: {e['setting']}, {fmt_time(t)}): {_against(scratch, t, 'from scratch')}; "
                         f"{_against(on_analysis, t)}.")
        compliant = r["summary"].get("frcontrol compliant", {}).get("time_to_target")
        if compliant is not None:
            fastest = min(e["time_to_target"] for e in reached.values())
            text += (f" frcontrol's compliant model needs {fmt_time(compliant)}, "
                     f"{compliant / fastest:.0f}x the fastest peer.")
        lines.append(text)
    creep_data = payload.get("creep")
    if creep_data:
        speeds: dict[str, list[float]] = {}
        for p in creep_data["points"]:
            if "speed" in p and not p["setting"].endswith(f"noslip {NOSLIP_ITERATIONS}"):
                speeds.setdefault(p["simulator"].split(" ")[0] if p["simulator"].startswith("Drake")
                                  else p["simulator"], []).append(p["speed"])
        parts = [f"{name} {min(v):.0e}" + (f"-{max(v):.0e}" if max(v) > 2 * min(v) else "") + " m/s"
                 for name, v in speeds.items()]
        lines.append(f"- Creep after {creep_data['duration']:g} s at mu = {creep_data['mu']:g} over every "
                     f"setting run: {', '.join(parts)} (MuJoCo's noslip iterations excluded).")
    return lines


README_BEGIN = ("<!-- generated by `python -m benchmarks.peers --readme` from benchmarks/results/peers.json; "
                "`python -m benchmarks.peers --write-readme` re-runs and rewrites it -->")
README_END = "<!-- end of the generated peers tables -->"


def write_readme(payload: dict, readme: Path) -> None:
    """Replace the generated block of the benchmarks page (between its markers) by the tables of ``payload``.

    Raises:
        ValueError: the page has not exactly one pair of markers.
    """
    text = readme.read_text()
    if text.count(README_BEGIN) != 1 or text.count(README_END) != 1:
        raise ValueError(f"{readme}: expected one '{README_BEGIN}' and one '{README_END}'")
    head, rest = text.split(README_BEGIN)
    _, tail = rest.split(README_END)
    readme.write_text(f"{head}{README_BEGIN}\n{readme_tables(payload)}\n{README_END}{tail}")


# ------------------------------------------------------------------------------------ driver
def versions(peers: tuple[str, ...]) -> dict[str, str | None]:
    """The versions of the peers, frcontrol and frcontrol's dependencies."""
    import re

    def version(name: str) -> str | None:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return None

    out: dict[str, str | None] = {"python": platform.python_version(), "frcontrol": version("frcontrol")}
    for peer in peers:
        out[peer] = version(peer)
    for requirement in importlib.metadata.requires("frcontrol") or []:
        if "extra ==" in requirement:
            continue
        name = re.split(r"[<>=!~\[ ;]", requirement, maxsplit=1)[0]
        out[name] = version(name)
    return out


def main() -> None:
    """Run the benchmark and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run, written to a temporary folder")
    parser.add_argument("--runs", type=int, default=None, help="runs per timed point (median)")
    parser.add_argument("--out", type=Path, default=None, help="the results folder")
    parser.add_argument("--readme", action="store_true",
                        help="print the benchmarks page's tables from peers.json")
    parser.add_argument("--replot", action="store_true", help="redraw the figures from peers.json")
    parser.add_argument("--write-readme", action="store_true",
                        help="rewrite docs/benchmarks.md's generated tables from the results (after the run, "
                             "or from peers.json with --readme)")
    parser.add_argument("--peers", nargs="*", default=["mujoco", "drake"], choices=["mujoco", "drake"])
    args = parser.parse_args()
    out = args.out or (Path(tempfile.mkdtemp(prefix="peers-")) if args.quick else RESULTS)
    if args.readme or args.replot:
        payload = json.loads((out / "peers.json").read_text())
        if args.readme:
            print(readme_tables(payload))
            if args.write_readme:
                write_readme(payload, README)
        if args.replot:
            for result in payload["problems"]:
                plot_problem(result, out / f"peers_{result['problem']}.png")
        return
    missing = [peer for peer in args.peers if importlib.util.find_spec(PEER_MODULES[peer]) is None]
    if missing:
        parser.error(f"{' and '.join(missing)} not installed: pip install \".[peers]\" "
                     f"(or leave them out with --peers)")
    grid = QUICK if args.quick else FULL
    if args.runs is not None:
        grid = Grid(**{**grid.__dict__, "runs": args.runs})
    peers = tuple(args.peers)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    def progress(message: str) -> None:
        print(f"[{time.perf_counter() - started:6.1f} s] {message}", flush=True)

    results = [bench_problem(name, grid, peers, progress) for name in PROBLEMS]
    box = next(r for r in results if r["problem"] == "box_on_slope")
    tuned = {name: entry["setting"] for name, entry in box["summary"].items() if entry.get("setting")}
    creep_result = creep(grid, peers, tuned, progress)
    payload = {
        "benchmark": "frcontrol against MuJoCo and Drake on the same problems",
        "command": "python -m benchmarks.peers" + (" --quick" if args.quick else ""),
        "target_force_error": TARGET_FORCE_ERROR,
        "constants": {"sphere_radius": SPHERE_RADIUS, "initial_penetration": INITIAL_PENETRATION,
                      "creep_mu": CREEP_MU, "rigid_creep_step": RIGID_CREEP_STEP},
        "grid": {"runs": grid.runs, "creep_duration": grid.creep_duration,
                 "mujoco": [asdict(s) for s in grid.mujoco], "drake": [asdict(s) for s in grid.drake],
                 "compliant": [asdict(s) for s in grid.compliant]},
        "versions": versions(peers),
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "note": "a machine shared with other work: absolute times are noisy; the ratios to frcontrol's "
                "rigid solutions_at are measured in the same process",
        "problems": results,
        "creep": creep_result,
        "wall_time_s": time.perf_counter() - started,
    }
    (out / "peers.json").write_text(json.dumps(payload, indent=1, default=_jsonable) + "\n")
    for result in results:
        plot_problem(result, out / f"peers_{result['problem']}.png")
    print(readme_tables(payload))
    if args.write_readme and not args.quick:
        write_readme(payload, README)
    print(f"\nwritten to {out}" + (f" and {README}" if args.write_readme and not args.quick else ""))


if __name__ == "__main__":
    main()
