r"""Statics of a body in frictional contact: closure, equilibrium, support region, stability.

Hauser's analyses of contact statics (docs/maths.md, *Statics of one body*) on one rigid body in the
plane. A robot with joints is treated as **locked**: one rigid body with the robot's total mass
``m`` and centre of mass ``c`` (Pinocchio's ``computeTotalMass`` and ``centerOfMass``) at its
configuration. Statics needs a floating (planar) base; a fixed-base scene raises
:class:`~frcontrol.errors.InputError`, because its base link is bolted to the world and every wrench
on it is resisted. Only the scene's *active* (touching) contacts take part.

**Wrenches.** A force ``f`` at the point ``p`` exerts on the body the planar wrench
``(f_x, f_y, (p - c) x f)`` about the centre of mass, with ``a x b = a_x b_y - a_y b_x``. Contact
``i`` (point ``p_i``, unit normal ``n_i`` pointing into the body, tangent ``t_i = (n_y, -n_x)``,
friction coefficient ``mu_i``) carries ``f_i = lam_N,i n_i + lam_T,i t_i`` with
``lam_N,i >= 0`` and ``|lam_T,i| <= mu_i lam_N,i`` (the planar friction cone is exact: two edges).
To compare forces and torques, closure and residuals use the *scaled* wrench
``(f_x, f_y, tau / L)`` with a characteristic length ``L`` [m]: by default the locked body's radius
of gyration ``sqrt(I_c / m)`` about its centre of mass (reported on every result).

**Form closure** (first order, frictionless). The primitive wrenches are the scaled normal wrenches
``w_i = (n_i, (p_i - c) x n_i / L)``. The body is in first-order form closure iff they positively
span ``R^3``, i.e. the only twist ``x`` with ``w_i . x >= 0`` for all ``i`` is ``x = 0`` (Hauser's
``N^T G^T x >= 0``). Equivalently: ``rank [w_1 .. w_p] = 3`` and there is a strictly positive
combination ``sum lam_i w_i = 0``, tested by the LP

.. math::

    s^* = \max_{\lambda, s}\ s \quad\text{s.t.}\quad W\lambda = 0,\ \textstyle\sum_i \lambda_i = 1,\
    \lambda_i \ge s,\ \lambda \ge 0,

closed iff the rank is 3 and :math:`s^* >` :data:`CLOSURE_TOLERANCE`. In the plane it takes at
least 4 contacts (``p >= d + 1`` vectors positively span ``R^d``), and never holds for a disk
(every normal passes through the centre, so the torque row vanishes).

**Force closure** is the same test with two primitive wrenches per contact, the friction cone's
unit edges ``e_i^± = (n_i ± mu_i t_i) / sqrt(1 + mu_i^2)`` (a frictionless contact gives the normal
twice). Two contacts suffice with friction (Nguyen: iff the segment joining them lies strictly
inside both friction cones).

**Margin** (Ferrari-Canny's epsilon). With the primitive wrenches' coefficients normalised by
``sum lam_j <= 1`` (total normal force at most 1 N for form closure; total edge force at most
1 N for force closure), the wrenches the contacts can exert form the convex hull
``conv{0, w_1, .., w_p}``. The margin is the radius of the largest ball of scaled wrenches
centred at the origin inside that hull: every disturbance wrench ``(f_x, f_y, tau/L)`` of norm at
most ``margin`` [N per N of total contact force] is resisted. It is computed exactly from the
hull's facets (Qhull): ``margin = min over facets of the facet's distance to the origin``, i.e.
``min_{|d| = 1} max_j d . w_j``; 0 when the body is not in closure.

**Static equilibrium** under gravity ``(0, -m g)`` at ``c`` and the applied inputs. Inputs on the
base coordinates ``x, y, theta`` are a force ``(u_x, u_y)`` at the base origin and a torque
``u_theta``; inputs on joints are internal to the locked body and ignored here (they count in
:func:`weak_stability`). With ``G`` the ``3 x 2k`` matrix of scaled contact wrenches and ``w`` the
scaled external wrench, equilibrium is ``G lam + w = 0`` with ``lam`` in the cones. It is decided
by the phase-one LP ``r* = min r s.t. |G lam + w|_inf <= r, lam in the cones`` (always feasible and
bounded), equilibrium iff ``r* <= EQUILIBRIUM_TOLERANCE * |w|_inf``; ``r*`` is the smallest
residual wrench [N] the cones leave, a continuous measure of how far the body is from equilibrium.
The set ``Lam`` of equilibrium force sets is a polyhedron: its dimension is ``2k`` minus the rank of
the equalities together with the cone rows that are tight on all of ``Lam`` (found by one LP,
Freund-Roundy-Todd); dimension > 0 means statically indeterminate. The reported force set is an
interior one: it maximises the smallest distance [N] to the boundaries of the cones (among the
rows not tight on all of ``Lam``), capped at the load ``|w|_inf``, with the least total normal
force as a tie-break.

**Support region.** Gravity is vertical, so the torque of the weight about any point depends only
on the centre of mass's abscissa: the set of ``c_x`` for which equilibrium exists (the contacts and
inputs fixed) is an interval ``[x_min, x_max]``, found by two LPs over ``(lam, c_x)``. In the plane
the region of ``(c_x, c_y)`` is that vertical strip. It becomes a bounded polygon when the body
must also stay at rest while its supports accelerate horizontally by up to ``±a``
(``lateral_acceleration``; d'Alembert: a load ``(-m a_s, -m g)`` at ``c`` for ``a_s = ±a``, the
extreme loads sufficing by convexity): the region is then the intersection over the two loads of
the projections of ``{(c, lam) : equilibrium}`` onto ``c``, computed with
:func:`frcontrol.polytope.project` (Fourier-Motzkin). A box of half-width ``b`` on flat ground
gives the rhombus ``|c_x| + (a / g)|c_y| <= b`` (when ``a <= mu g``).

**Weak and strong stability** (Pang and Trinkle, in the lecture). These concern the robot with its
joints, at rest (the scene's velocity is ignored) under the given inputs. *Weakly stable*: some
contact forces in the cones balance the generalized equations at rest,
``J_N^T lam_N + J_T^T lam_T = h(q, 0) - S^T u`` (for a single rigid body this is exactly the static
equilibrium above). *Strongly stable*: weakly stable, and every solution of the rigid-body contact
problem at rest (:func:`frcontrol.engine.solutions_at`, every contact mode S, L, R, F whose domain
holds the input) has zero acceleration ``dv``; for a mode whose accelerations depend on its
ambiguity variables ``w``, the range of ``dv`` over all admissible ``w`` is found by LPs. A body
that may stay or may slide is weakly but not strongly stable.

Every LP goes through :func:`frcontrol.solvers.solve_lp` (DAQP by default); a back-end error is
retried once with the reference back-end (HiGHS).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from . import polytope as poly
from .engine import solutions_at
from .errors import InputError
from .geometry import hull_facets, row_norms, vertices_from_halfspaces
from .jsonable import finite_or_none, to_jsonable
from .kernel import backend
from .modes import ContactProblem, add_scene_modes, build_mode_system
from .response import AmbiguousOutputs, solve_affine
from .scene import INPUT_LIMIT_SLACK, InputValues, Scene, input_vector
from .solvers import DoorOptions, SolverFailed, SolverSettings, must_solve, settings_from, solve_lp

__all__ = [
    "BodyLoad",
    "BodyScale",
    "ACCELERATION_TOLERANCE",
    "CLOSURE_TOLERANCE",
    "DAQP_PRIMAL_TOLERANCE",
    "EQUILIBRIUM_TOLERANCE",
    "IMPLICIT_SLACK_THRESHOLD",
    "RANK_TOLERANCE",
    "TIE_BREAK_WEIGHT",
    "Closure",
    "Equilibrium",
    "RestSolution",
    "StaticBody",
    "StaticsReport",
    "StrongStability",
    "SupportRegion",
    "WeakStability",
    "analyze_statics",
    "cone_rows",
    "force_closure",
    "form_closure",
    "primitive_wrenches",
    "static_body",
    "static_body_from_scene",
    "static_equilibrium",
    "strong_stability",
    "support_region",
    "weak_stability",
    "wrench_matrix",
]

# ---------------------------------------------------------------------------------------------
# tolerances

RANK_TOLERANCE = 1e-9
"""Relative rank threshold [-]: a singular value of a matrix of unit-norm rows (or of scaled
wrenches) counts as zero below ``RANK_TOLERANCE`` times the largest. Default ``1e-9``."""

CLOSURE_TOLERANCE = 1e-9
"""Closure holds when the smallest coefficient ``s*`` of the best strictly positive combination
``sum lam_j w_j = 0`` (normalised ``sum lam_j = 1``) exceeds this [-]. Default ``1e-9``."""

EQUILIBRIUM_TOLERANCE = 1e-8
"""Equilibrium holds when the smallest residual scaled wrench the cones leave, ``r*`` [N], is at
most this times the load ``|w|_inf`` [N] (relative). Default ``1e-8``. Also the relative residual
accepted by :func:`weak_stability` (per generalized row, relative to the row's scale)."""

IMPLICIT_SLACK_THRESHOLD = 0.5
"""In the Freund-Roundy-Todd LP every slack variable ends at 0 (the row is tight on the whole
equilibrium set) or 1 (the row can be strict); rows below this value [-] are declared tight.
Default ``0.5``."""

TIE_BREAK_WEIGHT = 1e-6
"""Weight [-] of the total normal force (relative to the load) in the interior-force LP, so that
among the force sets of largest cone slack the least squeezing one is chosen. Default ``1e-6``."""

ACCELERATION_TOLERANCE = 1e-6
"""A rigid solution is at rest when every acceleration has magnitude at most this
[m/s^2 or rad/s^2]. Default ``1e-6``."""

DAQP_PRIMAL_TOLERANCE = 1e-10
"""DAQP's ``primal_tol`` for every LP of this module [units of the constraint rows]. DAQP's own
default (``1e-6``) stops its proximal iterations early: on a ladder ``1e-7`` rad below its
limiting angle the phase-one LP returned ``r* = 0`` instead of ``6.9e-7`` N; with ``1e-10`` it is
exact to round-off (and not slower). Default ``1e-10``."""

_MODE_SLICE_TOLERANCE = 1e-7
"""Slack [normalised units of the mode's inequalities] added when the exact w-slice of a mode that
the engine accepted (within its own tolerance) turns out empty; the engine's DOMAIN_TOLERANCE."""


# ---------------------------------------------------------------------------------------------
# the body


@dataclass(frozen=True, eq=False)
class StaticBody:
    r"""One rigid body (a robot locked at its configuration) with point contacts, in the world.

    Build it with :func:`static_body` (arrays, validated) or :func:`static_body_from_scene`.

    Attributes:
        contact_names: the ``k`` contacts, in order.
        points: contact points ``p_i`` [m], shape ``(k, 2)``.
        normals: unit normals ``n_i`` [-] (pointing into the body), shape ``(k, 2)``.
        mu: friction coefficients [-], shape ``(k,)``, ``>= 0``.
        mass: total mass ``m`` [kg], ``> 0``.
        com: centre of mass ``c`` [m], shape ``(2,)``.
        gravity: ``g`` [m/s^2] along ``-y``, ``>= 0``.
        applied_force: the inputs' force [N], shape ``(2,)``, acting at ``applied_point``.
        applied_point: where it acts [m] (the base origin), shape ``(2,)``.
        applied_torque: the inputs' pure torque [N m].
        characteristic_length: ``L`` [m] of the scaled wrench ``(f_x, f_y, tau / L)``.
        length_source: how ``L`` was chosen (``"radius of gyration"``, ``"given"``,
            ``"farthest contact"``, ``"unit"``).
    """

    contact_names: tuple[str, ...]
    points: np.ndarray
    normals: np.ndarray
    mu: np.ndarray
    mass: float
    com: np.ndarray
    gravity: float
    applied_force: np.ndarray
    applied_point: np.ndarray
    applied_torque: float
    characteristic_length: float
    length_source: str

    @property
    def k(self) -> int:
        """Number of contacts."""
        return len(self.contact_names)

    @property
    def tangents(self) -> np.ndarray:
        """Unit tangents ``t_i = (n_y, -n_x)`` [-], shape ``(k, 2)``: mode R slides along ``+t``."""
        return np.column_stack([self.normals[:, 1], -self.normals[:, 0]])

    @property
    def weight(self) -> float:
        """``m g`` [N]."""
        return self.mass * self.gravity

    def external_wrench(self, reference: np.ndarray | None = None) -> np.ndarray:
        """Gravity plus the applied inputs as ``(F_x, F_y, tau)`` [N, N, N m] about ``reference``.

        The reference point defaults to the centre of mass.
        """
        o = self.com if reference is None else np.asarray(reference, dtype=float)
        force = self.applied_force + np.array([0.0, -self.weight])
        torque = (self.applied_torque + _cross(self.applied_point - o, self.applied_force)
                  + _cross(self.com - o, np.array([0.0, -self.weight])))
        return np.array([force[0], force[1], torque])


def _cross(a: np.ndarray, b: np.ndarray) -> Any:
    """Planar cross product ``a_x b_y - a_y b_x`` (row-wise for stacked vectors)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _finite_array(name: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name} must be numbers, got {value!r}") from err
    if shape and array.shape != shape:
        raise InputError(f"{name} must have shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite (no NaN or infinity), got {array.tolist()}")
    return array


def _finite_scalar(name: str, value: Any, *, positive: bool = False, nonnegative: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name} must be a number, got {value!r}") from err
    if not math.isfinite(x):
        raise InputError(f"{name} must be finite, got {value!r}")
    if positive and x <= 0.0:
        raise InputError(f"{name} must be > 0, got {x}")
    if nonnegative and x < 0.0:
        raise InputError(f"{name} must be >= 0, got {x}")
    return x


@dataclass(frozen=True)
class BodyLoad:
    """What loads a body besides its contacts (checked by :func:`static_body`).

    Attributes:
        gravity: [m/s^2] along ``-y``, ``>= 0``.
        force: [N] applied at ``point``.
        point: [m] where ``force`` applies (default: the centre of mass).
        torque: [N m] applied.
    """

    gravity: float = 9.81
    force: Any = (0.0, 0.0)
    point: Any = None
    torque: float = 0.0


@dataclass(frozen=True)
class BodyScale:
    """The length ``L`` [m] that turns torques into forces (checked by :func:`static_body`).

    Attributes:
        characteristic_length: ``L`` [m], ``> 0``; default ``sqrt(inertia / mass)``, else the
            distance from the centre of mass to the farthest contact (1 m if that is 0).
        inertia: planar inertia about the centre of mass [kg m^2]; gives the default ``L``.
    """

    characteristic_length: float | None = None
    inertia: float | None = None


def static_body(
    points: Any,
    normals: Any,
    mu: Any,
    mass: float,
    com: Any,
    *,
    load: BodyLoad = BodyLoad(),
    scale: BodyScale = BodyScale(),
    names: Sequence[str] | None = None,
) -> StaticBody:
    """A validated :class:`StaticBody` from arrays.

    Args:
        points: contact points [m], shape ``(k, 2)``, ``k >= 1``.
        normals: contact normals (any non-zero length; normalised here), shape ``(k, 2)``.
        mu: friction coefficients [-], a scalar or shape ``(k,)``, ``>= 0``.
        mass: [kg], ``> 0``.
        com: centre of mass [m], shape ``(2,)``.
        load: gravity and the applied force and torque (:class:`BodyLoad`).
        scale: the characteristic length ``L``, or the inertia that gives it (:class:`BodyScale`).
        names: contact names (default ``c0, c1, ...``).

    Raises:
        InputError: wrong shapes, NaN or infinite entries, a zero normal, a negative
            friction coefficient, mass or length, repeated names.
    """
    pts = _finite_array("points", points, ())
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InputError(f"points must have shape (k, 2), got {pts.shape}")
    k = pts.shape[0]
    if k == 0:  # no contact: the free body (no closure, no support; equilibrium only if unloaded)
        normals = np.zeros((0, 2))
    nrm = _finite_array("normals", normals, (k, 2))
    lengths = row_norms(nrm)
    if np.any(lengths < 1e-12):
        raise InputError(f"every normal must be non-zero; got {nrm.tolist()}")
    nrm = nrm / lengths[:, None]
    mu_arr = _finite_array("mu", np.broadcast_to(np.asarray(mu, dtype=float), (k,)), (k,))
    if np.any(mu_arr < 0):
        raise InputError(f"friction coefficients must be >= 0, got {mu_arr.tolist()}")
    m = _finite_scalar("mass", mass, positive=True)
    c = _finite_array("com", com, (2,))
    g = _finite_scalar("gravity", load.gravity, nonnegative=True)
    force = _finite_array("applied_force", load.force, (2,))
    point = c.copy() if load.point is None else _finite_array("applied_point", load.point, (2,))
    torque = _finite_scalar("applied_torque", load.torque)
    inertia = scale.inertia
    if scale.characteristic_length is not None:
        length = _finite_scalar("characteristic_length", scale.characteristic_length, positive=True)
        source = "given"
    elif inertia is not None and _finite_scalar("inertia", inertia, nonnegative=True) > 1e-12 * m:
        length, source = math.sqrt(float(inertia) / m), "radius of gyration"
    else:
        far = float(np.max(row_norms(pts - c)))
        length, source = (far, "farthest contact") if far > 1e-9 else (1.0, "unit")
    contact_names = tuple(names) if names is not None else tuple(f"c{i}" for i in range(k))
    if len(contact_names) != k or len(set(contact_names)) != k:
        raise InputError(f"names must be {k} distinct strings, got {list(contact_names)}")
    return StaticBody(contact_names, pts, nrm, mu_arr, m, c, g, force, point, torque, length, source)


def _scene_inputs(scene: Scene, inputs: InputValues) -> np.ndarray:
    """The input vector u (zeros by default), validated against the scene's inputs and limits."""
    return input_vector(scene.inputs.coordinates, scene.inputs.lower, scene.inputs.upper, inputs)


def _check_statics_scene(scene: Scene) -> None:
    if scene.robot.base != "planar":
        raise InputError(
            f"scene {scene.name!r} has a fixed base: statics analyses one free body (the robot locked "
            "at its configuration) and needs base = \"planar\" in the scene file"
        )


def static_body_from_scene(
    scene: Scene,
    inputs: InputValues = None,
    *,
    characteristic_length: float | None = None,
) -> StaticBody:
    r"""The scene's robot, locked at its configuration, with its active contacts.

    Mass and centre of mass come from Pinocchio (``computeTotalMass``, ``centerOfMass``). The
    inertia about the centre of mass is ``I_c = M_theta,theta - m |c - o|^2`` (``M``'s base block
    is the locked body's inertia about the base origin ``o``), and ``L = sqrt(I_c / m)``. The
    inputs' base rows ``(S^T u)_{x, y, theta}`` become a force at ``o`` and a torque.

    Args:
        scene: a scene with a planar base.
        inputs: ``{name: value}`` (others 0), the full input vector, or None (all 0).
        characteristic_length: overrides ``L`` [m].

    Raises:
        InputError: a fixed base, bad inputs (length, NaN, outside limits). No active contact is
            an ordinary case: the free body.
        CoordinateNotFound: an unknown input name.
    """
    _check_statics_scene(scene)
    u = _scene_inputs(scene, inputs)
    robot = scene.robot
    mass = robot.total_mass
    com = robot.center_of_mass(scene.q)
    state = scene.state(scene.q, np.zeros(robot.nv))
    origin = scene.q[:2].astype(float)
    inertia = float(state.mass_matrix[2, 2]) - mass * float(np.sum((com - origin) ** 2))
    generalized = scene.inputs.selection_transpose(robot.nv) @ u
    active = scene.active_contacts
    if mass <= 0.0:
        raise InputError(f"scene {scene.name!r}: the robot has no mass; statics needs m > 0")
    return static_body(
        state.contact_points,
        np.array([c.point.normal_in_world for c in active]).reshape(-1, 2),
        np.array([c.mu for c in active]),
        mass,
        com,
        load=BodyLoad(gravity=robot.gravity, force=generalized[:2], point=origin,
                      torque=float(generalized[2])),
        scale=BodyScale(characteristic_length=characteristic_length, inertia=max(inertia, 0.0)),
        names=[c.name for c in active],
    )


# ---------------------------------------------------------------------------------------------
# matrices (build)


def wrench_matrix(
    body: StaticBody, reference: np.ndarray | None = None, *, scaled: bool = True
) -> np.ndarray:
    r"""``G`` (3, 2k): the wrenches of unit ``lam_N`` (columns ``0..k-1``) and ``lam_T`` (``k..2k-1``).

    Column ``i`` is ``(n_i, (p_i - o) x n_i)``, column ``k + i`` is ``(t_i, (p_i - o) x t_i)``,
    about ``reference`` ``o`` (default the centre of mass); the torque row is divided by ``L``
    when ``scaled``.
    """
    o = body.com if reference is None else np.asarray(reference, dtype=float)
    r = body.points - o
    t = body.tangents
    scale = 1.0 / body.characteristic_length if scaled else 1.0
    top = np.hstack([body.normals.T, t.T])
    torque = np.concatenate([_cross(r, body.normals), _cross(r, t)]) * scale
    return np.vstack([top, torque])


def cone_rows(body: StaticBody) -> tuple[np.ndarray, tuple[str, ...]]:
    r"""The friction cones as ``C lam <= 0`` over ``lam = (lam_N, lam_T)``, rows of unit norm.

    Per contact: ``-lam_N <= 0``, ``(lam_T - mu lam_N) / sqrt(1 + mu^2) <= 0`` and
    ``(-lam_T - mu lam_N) / sqrt(1 + mu^2) <= 0``; each row's value is minus the distance [N] of
    the force to that boundary of the cone. Returns the rows and a label per row.
    """
    k = body.k
    rows = np.zeros((3 * k, 2 * k))
    labels: list[str] = []
    for i, (name, mu) in enumerate(zip(body.contact_names, body.mu, strict=True)):
        s = math.sqrt(1.0 + mu * mu)
        rows[3 * i, i] = -1.0
        rows[3 * i + 1, i], rows[3 * i + 1, k + i] = -mu / s, 1.0 / s
        rows[3 * i + 2, i], rows[3 * i + 2, k + i] = -mu / s, -1.0 / s
        labels += [f"{name}: lam_N >= 0", f"{name}: lam_T <= mu lam_N", f"{name}: -lam_T <= mu lam_N"]
    return rows, tuple(labels)


def primitive_wrenches(body: StaticBody, *, friction: bool) -> np.ndarray:
    r"""The scaled primitive wrenches (3, p) about the centre of mass.

    Without friction: the normals, ``(n_i, (p_i - c) x n_i / L)`` (``p = k``). With friction: the
    cone's unit edges ``e^± = (n ± mu t) / sqrt(1 + mu^2)``, ``(e, (p_i - c) x e / L)``
    (``p = 2k``, columns ``e_0^+, e_0^-, e_1^+, ...``).
    """
    r = body.points - body.com
    if friction:
        s = np.sqrt(1.0 + body.mu**2)[:, None]
        plus = (body.normals + body.mu[:, None] * body.tangents) / s
        minus = (body.normals - body.mu[:, None] * body.tangents) / s
        forces = np.stack([plus, minus], axis=1).reshape(-1, 2)
        r = np.repeat(r, 2, axis=0)
    else:
        forces = body.normals
    return np.vstack([forces.T, _cross(r, forces) / body.characteristic_length])


# ---------------------------------------------------------------------------------------------
# LP helpers


_STATICS_LP = must_solve("a statics LP", bounded=False, retry_unbounded=False)
"""The fallback policy of every statics LP: a back-end error is solved again by the other back-end;
no usable answer raises :class:`~frcontrol.solvers.SolverFailed`."""


@functools.lru_cache(maxsize=8)
def _lp_settings(settings: SolverSettings) -> SolverSettings:
    """``settings`` for a statics LP: DAQP gets ``primal_tol = DAQP_PRIMAL_TOLERANCE`` unless set."""
    if "primal_tol" in settings.options.get("daqp", {}):
        return settings
    return settings.with_options("daqp", primal_tol=DAQP_PRIMAL_TOLERANCE)


def _lp_door(settings: SolverSettings) -> DoorOptions:
    """How a statics LP is solved: :func:`_lp_settings`, :data:`_STATICS_LP`, the kernel's check."""
    return DoorOptions(_lp_settings(settings), fallback=_STATICS_LP, check=backend().lp_check)


def _rank(matrix: np.ndarray, *, normalise_rows: bool = False) -> int:
    if matrix.size == 0:
        return 0
    m = matrix
    if normalise_rows:
        norms = row_norms(m)
        m = m[norms > 0] / norms[norms > 0, None]
        if m.shape[0] == 0:
            return 0
    sv = np.linalg.svd(m, compute_uv=False)
    return int(np.sum(sv > RANK_TOLERANCE * sv[0])) if sv.size and sv[0] > 0 else 0


# ---------------------------------------------------------------------------------------------
# closure


ClosureKind = Literal["form", "force"]
"""Form closure (frictionless normals) or force closure (friction-cone edges)."""


@dataclass(frozen=True, eq=False)
class Closure:
    """Form or force closure of the body by its contacts.

    Attributes:
        kind: ``"form"`` (frictionless normals) or ``"force"`` (friction-cone edges).
        closed: the primitive wrenches positively span R^3.
        margin: Ferrari-Canny epsilon [N of scaled wrench per N of total contact force]: the
            radius of the largest origin-centred ball of scaled wrenches ``(f_x, f_y, tau / L)``
            inside ``conv{w_j}``; 0 when not closed.
        weakest_direction: unit scaled wrench along which the margin is attained (the nearest
            facet's normal), or None when not closed.
        rank: rank of the primitive wrench matrix.
        min_coefficient: ``s*`` of the positive-combination LP (``nan`` if no non-negative
            combination of the primitive wrenches vanishes).
        wrenches: the primitive wrenches (3, p), scaled.
        characteristic_length: ``L`` [m].
        tolerances: the tolerances used.
    """

    kind: ClosureKind
    closed: bool
    margin: float
    weakest_direction: np.ndarray | None
    rank: int
    min_coefficient: float
    wrenches: np.ndarray
    characteristic_length: float
    tolerances: Mapping[str, float]


def _closure(body: StaticBody, kind: ClosureKind, settings: SolverSettings) -> Closure:
    W = primitive_wrenches(body, friction=kind == "force")
    p = W.shape[1]
    rank = _rank(W)
    # max s s.t. W lam = 0, sum lam = 1, lam_j >= s, lam >= 0   (variables lam, s)
    cost = np.zeros(p + 1)
    cost[-1] = -1.0
    A_ub = np.hstack([-np.eye(p), np.ones((p, 1))])
    A_eq = np.vstack([np.hstack([W, np.zeros((3, 1))]), np.concatenate([np.ones(p), [0.0]])])
    b_eq = np.array([0.0, 0.0, 0.0, 1.0])
    lb = np.concatenate([np.zeros(p), [-np.inf]])
    ub = np.concatenate([np.full(p, np.inf), [1.0]])
    result = solve_lp(cost, A_ub=A_ub, b_ub=np.zeros(p), A_eq=A_eq, b_eq=b_eq, lb=lb, ub=ub,
                      door=_lp_door(settings))
    s_star = float(result.x[-1]) if result.x is not None else float("nan")
    closed = bool(rank == 3 and result.found and s_star > CLOSURE_TOLERANCE)
    margin, direction = 0.0, None
    if closed:
        normals, distances = hull_facets(W.T)
        j = int(np.argmin(distances))
        margin = max(float(distances[j]), 0.0)
        direction = normals[j].copy()
    return Closure(
        kind=kind, closed=closed, margin=margin, weakest_direction=direction, rank=rank,
        min_coefficient=s_star, wrenches=W, characteristic_length=body.characteristic_length,
        tolerances={"closure": CLOSURE_TOLERANCE, "rank": RANK_TOLERANCE},
    )


def form_closure(body: StaticBody, *, solver: str | None = None,
                 settings: SolverSettings | None = None) -> Closure:
    """First-order form closure (frictionless) and its margin; see the module docstring."""
    settings = settings_from(solver, settings)
    return _closure(body, "form", settings)


def force_closure(body: StaticBody, *, solver: str | None = None,
                  settings: SolverSettings | None = None) -> Closure:
    """Force closure with the friction cones (two edges per contact) and its margin."""
    settings = settings_from(solver, settings)
    return _closure(body, "force", settings)


# ---------------------------------------------------------------------------------------------
# equilibrium


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """Static equilibrium of the locked body under gravity and the applied inputs.

    Attributes:
        exists: some contact forces inside the friction cones balance the body.
        residual: ``r*`` [N]: the smallest ``|G lam + w|_inf`` (scaled wrench) over forces in the
            cones; 0 in equilibrium, growing with the distance from it.
        load: the external wrench ``w`` (gravity + inputs) about the centre of mass
            [N, N, N m], unscaled.
        lambda_n, lambda_t: an interior equilibrium force set [N], shape ``(k,)`` (None if none).
        cone_slack: the smallest distance [N] of that force set to the boundaries of the cones
            that some equilibrium force set leaves (0 if every row is tight).
        dimension: dimension of the set of equilibrium force sets (-1 if empty).
        tight: labels of the cone rows tight on every equilibrium force set (e.g. a contact that
            can carry no force), from the Freund-Roundy-Todd LP.
        lambda_n_range, lambda_t_range: ``(k, 2)`` min and max of each force component over
            all equilibrium force sets [N] (``±inf`` if unbounded; None if not computed or empty).
        balance_residual: ``|G lam + w|_inf`` of the reported force set [N] (scaled wrench).
        characteristic_length: ``L`` [m].
        tolerances: the tolerances used.
    """

    exists: bool
    residual: float
    load: np.ndarray
    lambda_n: np.ndarray | None
    lambda_t: np.ndarray | None
    cone_slack: float
    dimension: int
    tight: tuple[str, ...]
    lambda_n_range: np.ndarray | None
    lambda_t_range: np.ndarray | None
    balance_residual: float
    characteristic_length: float
    tolerances: Mapping[str, float]

    @property
    def statically_indeterminate(self) -> bool:
        """More than one equilibrium force set (the set has dimension > 0)."""
        return self.dimension > 0


def _phase_one(A: np.ndarray, b: np.ndarray, C: np.ndarray, settings: SolverSettings
               ) -> tuple[float, np.ndarray]:
    """``min r s.t. |A lam - b|_inf <= r, C lam <= 0``; returns ``(r*, lam)``."""
    m, nv = A.shape
    cost = np.zeros(nv + 1)
    cost[-1] = 1.0
    ones = np.ones((m, 1))
    A_ub = np.vstack([
        np.hstack([A, -ones]),
        np.hstack([-A, -ones]),
        np.hstack([C, np.zeros((C.shape[0], 1))]),
    ])
    b_ub = np.concatenate([b, -b, np.zeros(C.shape[0])])
    lb = np.concatenate([np.full(nv, -np.inf), [0.0]])
    result = solve_lp(cost, A_ub=A_ub, b_ub=b_ub, lb=lb, door=_lp_door(settings))
    if result.x is None:
        raise SolverFailed("the equilibrium phase-one LP", {result.solver: result.raw_status})
    return max(float(result.x[-1]), 0.0), result.x[:-1]


def static_equilibrium(
    body: StaticBody, *, force_ranges: bool = True, solver: str | None = None,
    settings: SolverSettings | None = None,
) -> Equilibrium:
    """Static equilibrium, an interior force set and the indeterminacy; see the module docstring.

    Args:
        body: the body.
        force_ranges: also compute the range of every force component (4k LPs).
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).
    """
    settings = settings_from(solver, settings)
    k = body.k
    nv = 2 * k
    G = wrench_matrix(body)
    load = body.external_wrench()
    w = load * np.array([1.0, 1.0, 1.0 / body.characteristic_length])
    scale = float(np.max(np.abs(w)))
    force_scale = scale if scale > 0 else 1.0
    C, labels = cone_rows(body)
    tolerances = {"equilibrium": EQUILIBRIUM_TOLERANCE, "rank": RANK_TOLERANCE,
                  "implicit_slack_threshold": IMPLICIT_SLACK_THRESHOLD, "tie_break": TIE_BREAK_WEIGHT}
    r_star, lam0 = _phase_one(G, -w, C, settings)
    if r_star > EQUILIBRIUM_TOLERANCE * scale:
        return Equilibrium(False, r_star, load, None, None, 0.0, -1, (), None, None, float("nan"),
                           body.characteristic_length, tolerances)

    m = C.shape[0]
    strict = _strict_cone_rows(G, w, C, force_scale, settings)
    tight = tuple(label for label, s in zip(labels, strict, strict=True) if not s)
    dimension = nv - _rank(np.vstack([G, C[~strict]]), normalise_rows=True)

    # interior force set: max sigma - eps sum(lam_N)/F  s.t.  G lam = -w, C_J lam + F sigma <= 0,
    # C_tight lam <= 0, 0 <= sigma <= 1
    cost = np.concatenate([TIE_BREAK_WEIGHT * np.ones(k) / force_scale, np.zeros(k), [-1.0]])
    A_ub = np.hstack([C, force_scale * strict[:, None].astype(float)])
    lb = np.concatenate([np.full(nv, -np.inf), [0.0]])
    ub = np.concatenate([np.full(nv, np.inf), [1.0]])
    interior = solve_lp(cost, A_ub=A_ub, b_ub=np.zeros(m), A_eq=np.hstack([G, np.zeros((3, 1))]), b_eq=-w,
                        lb=lb, ub=ub, door=_lp_door(settings))
    if interior.x is not None:
        lam = interior.x[:nv]
        slack = float(interior.x[-1]) * force_scale if np.any(strict) else 0.0
    else:
        lam, slack = lam0, 0.0

    n_range = t_range = None
    if force_ranges and interior.found:
        bounds = _force_ranges(G, w, C, lam, settings)
        n_range, t_range = bounds[:k], bounds[k:]
    return Equilibrium(
        exists=True, residual=r_star, load=load, lambda_n=lam[:k].copy(), lambda_t=lam[k:].copy(),
        cone_slack=slack, dimension=int(dimension), tight=tight, lambda_n_range=n_range,
        lambda_t_range=t_range, balance_residual=float(np.max(np.abs(G @ lam + w))),
        characteristic_length=body.characteristic_length, tolerances=tolerances,
    )


def _strict_cone_rows(G: np.ndarray, w: np.ndarray, C: np.ndarray, force_scale: float,
                      settings: SolverSettings) -> np.ndarray:
    """Per cone row, whether some equilibrium force set holds it strictly (Freund-Roundy-Todd).

    One LP: max sum s  s.t.  G lam + w tau = 0, C lam + F s <= 0, tau >= 1, 0 <= s <= 1 (F the
    force scale); a row is strict when its s exceeds :data:`IMPLICIT_SLACK_THRESHOLD`. Without an
    answer (equilibrium on the boundary of existence, r* within tolerance) every row is tight.
    """
    nv, m = G.shape[1], C.shape[0]
    cost = np.concatenate([np.zeros(nv + 1), -np.ones(m)])
    A_eq = np.hstack([G, w[:, None], np.zeros((3, m))])
    A_ub = np.hstack([C, np.zeros((m, 1)), force_scale * np.eye(m)])
    lb = np.concatenate([np.full(nv, -np.inf), [1.0], np.zeros(m)])
    ub = np.concatenate([np.full(nv + 1, np.inf), np.ones(m)])
    frt = solve_lp(cost, A_ub=A_ub, b_ub=np.zeros(m), A_eq=A_eq, b_eq=np.zeros(3), lb=lb, ub=ub,
                   door=_lp_door(settings))
    if frt.x is not None:
        return frt.x[nv + 1:] > IMPLICIT_SLACK_THRESHOLD
    return np.zeros(m, dtype=bool)


def _force_ranges(G: np.ndarray, w: np.ndarray, C: np.ndarray, lam: np.ndarray,
                  settings: SolverSettings) -> np.ndarray:
    """``(2k, 2)``: the least and largest value of every force component over the equilibria.

    Two LPs per component; an unbounded side is infinite, one without an answer keeps ``lam``'s.
    """
    nv, m = G.shape[1], C.shape[0]
    bounds = np.empty((nv, 2))
    for j in range(nv):
        for side, sign in ((0, 1.0), (1, -1.0)):
            cost = np.zeros(nv)
            cost[j] = sign
            res = solve_lp(cost, A_ub=C, b_ub=np.zeros(m), A_eq=G, b_eq=-w, door=_lp_door(settings))
            if res.status == "unbounded":
                bounds[j, side] = -sign * np.inf
            elif res.found:
                bounds[j, side] = sign * res.objective
            else:
                bounds[j, side] = lam[j]
    return bounds


# ---------------------------------------------------------------------------------------------
# support region


SupportMethod = Literal["interval", "fourier_motzkin"]
"""How a support region was found: the strip of two LPs (no lateral acceleration) or by projection."""


@dataclass(frozen=True, eq=False)
class SupportRegion:
    """The centre-of-mass positions for which the body can be in equilibrium.

    Attributes:
        feasible: some centre-of-mass position admits equilibrium.
        x_min, x_max: the horizontal support interval [m] (gravity and inputs only; ``±inf`` if
            unbounded; ``nan`` if infeasible).
        com: the body's centre of mass [m].
        contains_com: the centre of mass is in the interval (equivalent to equilibrium).
        lateral_acceleration: ``a`` [m/s^2] of the planar region.
        region: the planar region in ``(c_x, c_y)`` [m] (a vertical strip when ``a = 0``; the
            canonical empty set when no position survives, e.g. ``a > mu g`` on flat ground).
        region_contains_com: the centre of mass is in ``region``.
        bounded: whether ``region`` is bounded.
        vertices: its vertices [m], counter-clockwise, shape ``(v, 2)``, when bounded and non-empty.
        method: ``"interval"`` (``a = 0``: the strip of the two LPs) or ``"fourier_motzkin"``.
    """

    feasible: bool
    x_min: float
    x_max: float
    com: np.ndarray
    contains_com: bool
    lateral_acceleration: float
    region: poly.Polytope
    region_contains_com: bool
    bounded: bool
    vertices: np.ndarray | None
    method: SupportMethod


def _moved_com_system(
    body: StaticBody, lateral: float, with_y: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Equilibrium about the current CoM ``c0`` with the CoM moved by ``d``: ``A [d; lam/F] = b``.

    Variables ``d = (d_x[, d_y])`` [m] and ``lam / F`` [-] (F the load scale). The load at
    ``c = c0 + d`` is ``(-m a_s, -m g)`` with ``a_s = lateral``; its torque about ``c0`` is
    ``d x load = -m g d_x + m a_s d_y``. Returns ``A``, ``b`` and the cone rows over all variables.
    """
    L = body.characteristic_length
    G = wrench_matrix(body)  # about c0, scaled
    w_in = replace(body, gravity=0.0).external_wrench() * np.array([1.0, 1.0, 1.0 / L])
    m = body.mass
    load = np.array([-m * lateral, -body.weight])
    w_fixed = w_in + np.array([load[0], load[1], 0.0])
    force_scale = float(np.max(np.abs(w_fixed))) or 1.0
    nd = 2 if with_y else 1
    d_cols = np.zeros((3, nd))
    d_cols[2, 0] = -body.weight / L
    if with_y:
        d_cols[2, 1] = m * lateral / L
    A = np.hstack([d_cols, G * force_scale])
    C, _ = cone_rows(body)
    C_full = np.hstack([np.zeros((C.shape[0], nd)), C])
    return A, -w_fixed, C_full


def support_region(
    body: StaticBody, *, lateral_acceleration: float = 0.0, solver: str | None = None,
    settings: SolverSettings | None = None,
) -> SupportRegion:
    """The support interval (two LPs) and the planar support region; see the module docstring.

    Args:
        body: the body (its inputs stay applied where they are while the centre of mass moves).
        lateral_acceleration: ``a`` [m/s^2], ``>= 0``: the supports' horizontal acceleration
            (either way) under which the body must stay at rest. ``0`` gives the vertical strip.
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).

    Raises:
        InputError: a negative or non-finite ``lateral_acceleration``.
    """
    settings = settings_from(solver, settings)
    a = _finite_scalar("lateral_acceleration", lateral_acceleration, nonnegative=True)
    c0 = body.com
    A, b, C = _moved_com_system(body, 0.0, with_y=False)
    nvar = A.shape[1]
    ends = []
    feasible = True
    for sign in (1.0, -1.0):
        cost = np.zeros(nvar)
        cost[0] = sign
        res = solve_lp(cost, A_ub=C, b_ub=np.zeros(C.shape[0]), A_eq=A, b_eq=b, door=_lp_door(settings))
        if res.status == "infeasible":
            feasible = False
            break
        ends.append(-sign * np.inf if res.status == "unbounded" else sign * res.objective)
        if not res.found and res.status != "unbounded":
            raise SolverFailed("the support-interval LP", {res.solver: res.raw_status})
    if not feasible:
        return SupportRegion(False, float("nan"), float("nan"), c0.copy(), False, a,
                             poly.Polytope.empty_set(2), False, True, None,
                             "interval" if a == 0 else "fourier_motzkin")
    x_min, x_max = c0[0] + ends[0], c0[0] + ends[1]
    tol = 1e-9 * max(1.0, abs(c0[0]))
    contains = bool(x_min - tol <= c0[0] <= x_max + tol)
    if a == 0.0:
        rows, rhs = [], []
        if math.isfinite(x_max):
            rows.append([1.0, 0.0])
            rhs.append(x_max)
        if math.isfinite(x_min):
            rows.append([-1.0, 0.0])
            rhs.append(-x_min)
        region = poly.Polytope(np.array(rows, dtype=float).reshape(-1, 2), np.array(rhs, dtype=float))
        return SupportRegion(True, float(x_min), float(x_max), c0.copy(), contains, a, region, contains,
                             False, None, "interval")

    pieces = []
    for lateral in (a, -a):
        A2, b2, C2 = _moved_com_system(body, lateral, with_y=True)
        lifted = poly.Polytope(C2, np.zeros(C2.shape[0]), A2, b2)
        pieces.append(poly.project(lifted, [0, 1], settings=settings))
    moved = poly.minimal_representation(poly.intersect(*pieces), settings=settings)
    # back to world coordinates: d = c - c0, so A d <= b becomes A c <= b + A c0
    region = poly.Polytope(moved.A, moved.b + moved.A @ c0, moved.A_eq, moved.b_eq + moved.A_eq @ c0)
    if moved.empty:
        return SupportRegion(True, float(x_min), float(x_max), c0.copy(), contains, a, region, False,
                             True, None, "fourier_motzkin")
    bounded = all(math.isfinite(poly.support(region, d, settings=settings))
                  for d in ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)))
    planar = bounded and region.A_eq.shape[0] == 0
    vertices = vertices_from_halfspaces(region.A, region.b) if planar else None
    return SupportRegion(True, float(x_min), float(x_max), c0.copy(), contains, a, region,
                         poly.contains(region, c0, tolerance=1e-9), bounded, vertices, "fourier_motzkin")


# ---------------------------------------------------------------------------------------------
# weak and strong stability (the robot with its joints, at rest)


@dataclass(frozen=True, eq=False)
class WeakStability:
    """Whether contact forces in the cones hold the robot at rest under the inputs.

    Attributes:
        weakly_stable: ``J_N^T lam_N + J_T^T lam_T = h(q, 0) - S^T u`` has a solution in the cones.
        residual: the smallest relative residual (each generalized row divided by its scale).
        lambda_n, lambda_t: one such force set [N] (the phase-one LP's), or None.
        tolerance: :data:`EQUILIBRIUM_TOLERANCE`.
    """

    weakly_stable: bool
    residual: float
    lambda_n: np.ndarray | None
    lambda_t: np.ndarray | None
    tolerance: float


def weak_stability(
    scene: Scene,
    inputs: InputValues = None,
    *,
    solver: str | None = None, settings: SolverSettings | None = None,
) -> WeakStability:
    """Weak stability of the scene's robot (joints included) at rest under ``inputs``.

    Each generalized row ``i`` is divided by ``max(|row of [J_N^T J_T^T]|_inf, |rhs_i|)`` so that the
    phase-one residual is relative.

    Raises:
        InputError: a fixed base, bad inputs.
    """
    settings = settings_from(solver, settings)
    _check_statics_scene(scene)
    u = _scene_inputs(scene, inputs)
    state = scene.state(scene.q, np.zeros(scene.robot.nv))
    k = len(scene.active_contacts)
    A = np.hstack([state.jacobian_normal.T, state.jacobian_tangent.T])
    rhs = state.bias - scene.inputs.selection_transpose(scene.robot.nv) @ u
    row_scale = np.maximum(np.max(np.abs(A), axis=1, initial=0.0), np.abs(rhs))
    row_scale[row_scale == 0.0] = 1.0
    body = static_body(state.contact_points, [c.point.normal_in_world for c in scene.active_contacts],
                       [c.mu for c in scene.active_contacts], 1.0, np.zeros(2),
                       scale=BodyScale(characteristic_length=1.0))
    C, _ = cone_rows(body)
    r_star, lam = _phase_one(A / row_scale[:, None], rhs / row_scale, C, settings)
    ok = r_star <= EQUILIBRIUM_TOLERANCE
    return WeakStability(bool(ok), r_star, lam[:k].copy() if ok else None, lam[k:].copy() if ok else None,
                         EQUILIBRIUM_TOLERANCE)


@dataclass(frozen=True)
class RestSolution:
    """One rigid-body solution at rest, as the strong-stability test sees it.

    Attributes:
        mode: one letter S, L, R, F per active contact.
        max_abs_dv: the largest ``|dv_j|`` [m/s^2, rad/s^2] at the engine's representative
            solution; when that is at rest but the mode's accelerations depend on its ambiguity
            ``w``, the largest over every admissible ``w`` (``inf`` if unbounded).
        at_rest: ``max_abs_dv <= ACCELERATION_TOLERANCE``.
        ambiguous_outputs: the engine's ``"none"``, ``"forces"`` or ``"accelerations"``.
    """

    mode: str
    max_abs_dv: float
    at_rest: bool
    ambiguous_outputs: AmbiguousOutputs


@dataclass(frozen=True, eq=False)
class StrongStability:
    """Strong stability: every rigid-body solution at rest has zero acceleration.

    Attributes:
        strongly_stable: weakly stable and every solution is at rest.
        solutions: every rigid-body solution the engine found.
        moving_modes: the modes of the solutions that accelerate.
        tolerance: :data:`ACCELERATION_TOLERANCE`.
    """

    strongly_stable: bool
    solutions: tuple[RestSolution, ...]
    moving_modes: tuple[str, ...]
    tolerance: float


def _dv_range_over_ambiguity(problem: Any, mode: str, u: np.ndarray, settings: SolverSettings) -> float:
    """``max_j |dv_j|`` over every ambiguity value ``w`` admissible in ``mode`` at input ``u``."""
    system = build_mode_system(problem, mode)
    response = solve_affine(system.A, system.B, system.c)
    n = problem.n
    base = response.X_u @ u + response.x_0
    H_w = system.G @ response.X_w
    h = system.g - system.G @ base
    norms = row_norms(np.hstack([system.G @ response.X_u, H_w]))
    norms[norms == 0.0] = 1.0
    H_w, h = H_w / norms[:, None], h / norms
    p = H_w.shape[1]
    worst = 0.0
    for relax in (0.0, _MODE_SLICE_TOLERANCE):
        worst = 0.0
        empty = False
        for j in range(n):
            for sign in (1.0, -1.0):
                cost = sign * response.X_w[j]
                res = solve_lp(cost, A_ub=H_w, b_ub=h + relax, lb=np.full(p, -np.inf),
                               door=_lp_door(settings))
                if res.status == "infeasible":
                    empty = True
                    break
                if res.status == "unbounded":
                    return float("inf")
                worst = max(worst, abs(base[j] + sign * res.objective))
            if empty:
                break
        if not empty:
            return worst
    return worst


def strong_stability(
    scene: Scene,
    inputs: InputValues = None,
    *,
    weak: WeakStability | None = None,
    solver: str | None = None, settings: SolverSettings | None = None,
) -> StrongStability:
    """Strong stability at rest under ``inputs``, with the mode-domain engine.

    Args:
        scene: the scene (its velocity is replaced by zero).
        inputs: ``{name: value}``, the input vector, or None (all 0).
        weak: the weak-stability result if already computed.
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).

    Raises:
        InputError: a fixed base, bad inputs.
    """
    settings = settings_from(solver, settings)
    _check_statics_scene(scene)
    u = _scene_inputs(scene, inputs)
    weak = weak if weak is not None else weak_stability(scene, u, settings=settings)
    problem = ContactProblem.from_scene(scene, scene.q, np.zeros(scene.robot.nv))
    found = []
    for sol in solutions_at(problem, u, settings=settings):
        size = float(np.max(np.abs(sol.dv), initial=0.0))
        if sol.ambiguous_outputs == "accelerations" and size <= ACCELERATION_TOLERANCE:
            size = max(size, _dv_range_over_ambiguity(problem, sol.mode, u, settings))
        found.append(RestSolution(sol.mode, size, size <= ACCELERATION_TOLERANCE, sol.ambiguous_outputs))
    moving = tuple(s.mode for s in found if not s.at_rest)
    return StrongStability(bool(weak.weakly_stable and found and not moving), tuple(found), moving,
                           ACCELERATION_TOLERANCE)


# ---------------------------------------------------------------------------------------------
# everything at once


def _bound_pairs(array: np.ndarray | None) -> list[list[float | None]] | None:
    """``(lower, upper)`` rows with infinite bounds as None."""
    return None if array is None else [[finite_or_none(lo), finite_or_none(hi)] for lo, hi in array]


def _closure_dict(c: Any) -> dict[str, Any]:
    """A closure test as JSON values (``frc statics --json``'s ``closure.form`` and ``.force``)."""
    return {"closed": c.closed, "margin": c.margin, "rank": c.rank,
            "min_coefficient": finite_or_none(c.min_coefficient),
            "weakest_direction": None if c.weakest_direction is None else c.weakest_direction}


def _equilibrium_dict(eq: Equilibrium, names: list[str]) -> dict[str, Any]:
    """The equilibrium as JSON values, its forces and ranges per contact (``names``; null if none)."""
    forces = None
    if eq.lambda_n is not None and eq.lambda_t is not None:
        forces = {name: {"lambda_n": eq.lambda_n[i], "lambda_t": eq.lambda_t[i]}
                  for i, name in enumerate(names)}
    ranges = None
    n_range, t_range = _bound_pairs(eq.lambda_n_range), _bound_pairs(eq.lambda_t_range)
    if n_range is not None and t_range is not None:
        ranges = {name: {"lambda_n": n_range[i], "lambda_t": t_range[i]} for i, name in enumerate(names)}
    return {
        "exists": eq.exists,
        "residual": eq.residual,
        "load": eq.load,
        "forces": forces,
        "cone_slack": eq.cone_slack,
        "dimension": eq.dimension,
        "statically_indeterminate": eq.statically_indeterminate,
        "tight": list(eq.tight),
        "ranges": ranges,
    }


@dataclass(frozen=True, eq=False)
class StaticsReport:
    """All the statics of a scene at its configuration.

    Attributes:
        scene_name: the scene's name.
        inactive_contacts: contacts of the scene that do not touch (left out).
        inputs: the input vector used.
        body: the locked body.
        form_closure, force_closure: closure results.
        equilibrium: static equilibrium of the locked body.
        support: the support region.
        weak: weak stability (the robot with its joints).
        strong: strong stability (None if not computed).
        timings: seconds per part, and ``"total"``.
        scene_contacts: every contact of the scene, in scene order (the letters of a scene mode).
        tolerances: every tolerance that shaped the answers.
    """

    scene_name: str
    inactive_contacts: tuple[str, ...]
    inputs: np.ndarray
    body: StaticBody
    form_closure: Closure
    force_closure: Closure
    equilibrium: Equilibrium
    support: SupportRegion
    weak: WeakStability
    strong: StrongStability | None
    timings: Mapping[str, float] = field(default_factory=dict)
    tolerances: Mapping[str, float] = field(default_factory=dict)
    scene_contacts: tuple[str, ...] = ()

    @property
    def weakly_stable(self) -> bool:
        """Some equilibrium forces exist (the robot with its joints, under the inputs)."""
        return self.weak.weakly_stable

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON values (the ``frc statics --json`` document; infinite bounds are null)."""
        report = self
        body = report.body
        eq = report.equilibrium
        sup = report.support
        strong = report.strong
        return add_scene_modes(to_jsonable({
            "scene": report.scene_name,
            "form_closure": report.form_closure.closed,
            "form_closure_margin": report.form_closure.margin,
            "force_closure": report.force_closure.closed,
            "force_closure_margin": report.force_closure.margin,
            "static_equilibrium": eq.exists,
            "weakly_stable": report.weakly_stable,
            "strongly_stable": report.strongly_stable,
            "support_region": {
                "x_min": finite_or_none(sup.x_min),
                "x_max": finite_or_none(sup.x_max),
                "com": sup.com,
                "contains_com": sup.contains_com,
                "lateral_acceleration": sup.lateral_acceleration,
                "method": sup.method,
                "empty": bool(sup.region.empty),
                "bounded": sup.bounded,
                "region_contains_com": sup.region_contains_com,
                "halfplanes": {"A": np.asarray(sup.region.A), "b": np.asarray(sup.region.b)},
                "vertices": sup.vertices,
            },
            "contacts": list(body.contact_names),
            "inactive_contacts": list(report.inactive_contacts),
            "inputs": report.inputs,
            "body": {"mass": body.mass, "com": body.com, "gravity": body.gravity,
                     "characteristic_length": body.characteristic_length,
                     "length_source": body.length_source},
            "closure": {"form": _closure_dict(report.form_closure),
                        "force": _closure_dict(report.force_closure)},
            "equilibrium": _equilibrium_dict(eq, list(body.contact_names)),
            "weak_stability": {"weakly_stable": report.weakly_stable, "residual": report.weak.residual},
            "strong_stability": None if strong is None else {
                "strongly_stable": strong.strongly_stable,
                "moving_modes": list(strong.moving_modes),
                "solutions": [{"mode": s.mode, "max_abs_dv": finite_or_none(s.max_abs_dv),
                               "at_rest": s.at_rest, "ambiguous_outputs": s.ambiguous_outputs}
                              for s in strong.solutions],
            },
            "timings": dict(report.timings),
            "tolerances": dict(report.tolerances),
        }), report.scene_contacts or (*report.body.contact_names, *report.inactive_contacts))

    @property
    def strongly_stable(self) -> bool | None:
        """Every rigid-body solution at rest is at rest (None if not computed)."""
        return None if self.strong is None else self.strong.strongly_stable


def analyze_statics(
    scene: Scene,
    inputs: InputValues = None,
    *,
    lateral_acceleration: float = 0.0,
    characteristic_length: float | None = None,
    strong: bool = True,
    force_ranges: bool = True,
    solver: str | None = None, settings: SolverSettings | None = None,
) -> StaticsReport:
    """Closure, equilibrium, support region and stability of a scene at its configuration.

    Args:
        scene: a scene with a planar base and at least one active contact.
        inputs: ``{name: value}`` (others 0), the full input vector, or None (all 0).
        lateral_acceleration: [m/s^2] for the planar support region (see :func:`support_region`).
        characteristic_length: ``L`` [m] (default: the radius of gyration).
        strong: run the strong-stability test (the mode-domain engine: the slowest part).
        force_ranges: compute the range of every equilibrium force component.
        solver: LP back-end (a name).
        settings: the solver settings (instead of ``solver``).

    Raises:
        InputError: a fixed base, bad inputs or lateral acceleration.
        CoordinateNotFound: an unknown input name.
    """
    settings = settings_from(solver, settings)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    u = _scene_inputs(scene, inputs) if scene.robot.base == "planar" else None
    body = static_body_from_scene(scene, u, characteristic_length=characteristic_length)
    t1 = time.perf_counter()
    timings["model"] = t1 - t0
    form = form_closure(body, settings=settings)
    force = force_closure(body, settings=settings)
    t2 = time.perf_counter()
    timings["closure"] = t2 - t1
    equilibrium = static_equilibrium(body, force_ranges=force_ranges, settings=settings)
    t3 = time.perf_counter()
    timings["equilibrium"] = t3 - t2
    support = support_region(body, lateral_acceleration=lateral_acceleration, settings=settings)
    t4 = time.perf_counter()
    timings["support"] = t4 - t3
    weak = weak_stability(scene, u, settings=settings)
    t5 = time.perf_counter()
    timings["weak_stability"] = t5 - t4
    strong_result = strong_stability(scene, u, weak=weak, settings=settings) if strong else None
    t6 = time.perf_counter()
    timings["strong_stability"] = t6 - t5
    timings["total"] = t6 - t0
    return StaticsReport(
        scene_name=scene.name,
        inactive_contacts=tuple(c.name for c in scene.contacts if not c.active),
        scene_contacts=tuple(c.name for c in scene.contacts),
        inputs=np.asarray(u, dtype=float),
        body=body, form_closure=form, force_closure=force, equilibrium=equilibrium, support=support,
        weak=weak, strong=strong_result, timings=timings,
        tolerances={
            "rank": RANK_TOLERANCE, "closure": CLOSURE_TOLERANCE, "equilibrium": EQUILIBRIUM_TOLERANCE,
            "input_limit": INPUT_LIMIT_SLACK, "implicit_slack_threshold": IMPLICIT_SLACK_THRESHOLD,
            "tie_break": TIE_BREAK_WEIGHT,
            "acceleration": ACCELERATION_TOLERANCE, "daqp_primal": DAQP_PRIMAL_TOLERANCE,
        },
    )
