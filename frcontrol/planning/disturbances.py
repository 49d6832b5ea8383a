r"""Disturbance forces of a scene (``[[disturbances]]``): the polytope, its points, the lifted problem.

Used by the robust planners (the task core's robust phases, the climb, the gait).

Disturbances (the ``[[disturbances]]`` tables of a scene)
---------------------------------------------------------
This format is a contract::

    [[disturbances]]
    name = "head_push"        # unique; components are named "head_push.fx", "head_push.fy"
    link = "link8"            # a URDF link
    point = [0.2, 0.0]        # [m] point of application, in that link's frame
    lower = [-3.0, -3.0]      # [N] a box of forces (fx, fy), world frame ...
    upper = [3.0, 3.0]
    # vertices = [[fx, fy], ...]   # [N] ... or a convex polygon (its convex hull is taken:
    #                              # one point, a segment or a polygon), world frame

Give either ``lower`` and ``upper`` or ``vertices``. The disturbance polytope ``P`` is the product
of the tables' polygons. A force ``d_i`` at point ``p_i`` enters the dynamics as ``J_i^T d_i``
with ``J_i`` the point's linear Jacobian (2 x n, world x-y). Bad tables raise
:class:`~frcontrol.errors.SceneError` naming the field: missing, empty (``lower > upper``, no
vertex), unbounded (an infinite bound), NaN, unknown link or key, a duplicate name.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..engine import DOMAIN_TOLERANCE
from ..errors import FrameNotFound, SceneError
from ..geometry import polygon_rows
from ..modes import ContactProblem
from ..polytope import Polytope, hull_from_points
from ..scene import Scene

__all__ = [
    "DEFAULT_HOLD",
    "HOLD_INDEX_ROUNDOFF",
    "Disturbance",
    "DisturbanceSet",
    "PointKinematics",
    "augmented_problem",
    "load_disturbances",
    "sample_disturbances",
]

DEFAULT_HOLD = 0.05
"""[s] How long each sampled disturbance is held in :func:`simulate_climb`."""

HOLD_INDEX_ROUNDOFF = 1e-9
"""[-] In :func:`simulate_climb`, a step starting within this many holds of a hold's end starts the
next hold (``t / hold`` is rounded up over round-off)."""

# ============================================================================ disturbances
@dataclass(frozen=True)
class Disturbance:
    """One disturbance force: a point of a link and a convex polygon of forces.

    Attributes:
        name: the table's name.
        link: the URDF link the force acts on.
        point_in_link: the point of application [m] in the link's frame.
        vertices: the polygon's vertices [N] (fx, fy in the world), counter-clockwise, shape
            (k, 2) with k = 1 (a point), 2 (a segment) or >= 3.
    """

    name: str
    link: str
    point_in_link: np.ndarray
    vertices: np.ndarray

    @property
    def lower(self) -> np.ndarray:
        """[N] Componentwise lower bound of the polygon (its bounding box)."""
        return self.vertices.min(axis=0)

    @property
    def upper(self) -> np.ndarray:
        """[N] Componentwise upper bound of the polygon."""
        return self.vertices.max(axis=0)

    def contains_zero(self) -> bool:
        """Whether the zero force is in the polygon (to :data:`DOMAIN_TOLERANCE` [N])."""
        A, b, A_eq, b_eq = polygon_rows(self.vertices)
        return bool(np.all(b >= -DOMAIN_TOLERANCE) and np.all(np.abs(b_eq) <= DOMAIN_TOLERANCE))

    def polytope(self, scale: float = 1.0) -> Polytope:
        """The polygon scaled by ``scale`` about the zero force, as a 2-D H-polytope."""
        A, b, A_eq, b_eq = polygon_rows(scale * self.vertices)
        return Polytope(A, b, A_eq, b_eq)


@dataclass(frozen=True)
class DisturbanceSet:
    """The disturbance polytope P: the product of the disturbances' polygons.

    Attributes:
        items: the disturbances, in file order.
    """

    items: tuple[Disturbance, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The components' names, two per disturbance: ``"<name>.fx"``, ``"<name>.fy"``."""
        return tuple(f"{d.name}.{axis}" for d in self.items for axis in ("fx", "fy"))

    @property
    def dim(self) -> int:
        """Number of components (2 per disturbance)."""
        return 2 * len(self.items)

    @property
    def lower(self) -> np.ndarray:
        """[N] Lower corner of P's bounding box."""
        return np.concatenate([d.lower for d in self.items]) if self.items else np.zeros(0)

    @property
    def upper(self) -> np.ndarray:
        """[N] Upper corner of P's bounding box."""
        return np.concatenate([d.upper for d in self.items]) if self.items else np.zeros(0)

    def contains_zero(self) -> bool:
        """Whether the zero disturbance is in P."""
        return all(d.contains_zero() for d in self.items)

    def vertices(self, scale: float = 1.0) -> np.ndarray:
        """The vertices of ``scale P`` (every combination of the polygons' vertices), (N, dim)."""
        combos = itertools.product(*[d.vertices for d in self.items])
        return scale * np.array([np.concatenate(c) for c in combos]).reshape(-1, self.dim)

    def robust_points(self, scale: float = 1.0) -> np.ndarray:
        """``V_s``: the vertices of ``scale P``, plus the zero disturbance if P does not hold it."""
        points = self.vertices(scale)
        if not self.contains_zero():
            points = np.vstack([np.zeros((1, self.dim)), points])
        return points


def load_disturbances(scene: Scene, *, required: bool = True) -> DisturbanceSet:
    """Read and validate the scene's ``[[disturbances]]`` tables (format: module docstring).

    Args:
        scene: the loaded scene (its ``disturbances``, read at load).
        required: raise if the scene has none (the climb needs a disturbance polytope).

    Raises:
        SceneError: missing tables (with ``required``), a table that is not a table, an unknown
            key, a missing or duplicate name, an unknown link, a bad point, both or neither of
            bounds and vertices, an empty polytope (``lower > upper``, no vertex), an unbounded
            one (infinite bound or vertex) or a NaN.
    """
    if not scene.disturbances:
        if required:
            raise SceneError(str(scene.path), "disturbances", "missing: the climb needs at least one "
                             "[[disturbances]] table (name, link, point, lower/upper or vertices)")
        return DisturbanceSet(())
    return DisturbanceSet(tuple(Disturbance(d.name, d.link, d.point, hull_from_points(d.corners))
                                for d in scene.disturbances))


# ============================================================================ kinematics
class PointKinematics:
    """World Jacobians of a few points of the robot, by :meth:`PlanarRobot.point_kinematics`."""

    def __init__(self, scene: Scene, points: Sequence[tuple[str, str, np.ndarray]]) -> None:
        self.robot = scene.robot
        self.points = [(link, np.asarray(point, dtype=float)) for _, link, point in points]
        for link, _ in self.points:
            if link not in self.robot.link_names:
                raise FrameNotFound(link, self.robot.link_names)

    def evaluate(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points' Jacobians, drifts and positions at ``(q, v)``.

        Returns:
            ``(J, drift, positions)``: J (2p, n), rows x then y per point; drift (2p,) [m/s^2];
            positions (p, 2) [m].
        """
        kin = self.robot.point_kinematics(q, v, self.points)
        return kin.jacobians.reshape(-1, self.robot.nv), kin.drifts.reshape(-1), kin.positions

    def positions(self, q: np.ndarray) -> np.ndarray:
        """World positions [m] of the points at ``q``, shape (p, 2)."""
        return self.evaluate(q, np.zeros(self.robot.nv))[2]


def augmented_problem(
    scene: Scene,
    disturbances: DisturbanceSet,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> ContactProblem:
    """The scene's contact problem with the disturbance components as extra inputs.

    Inputs ``z = (u, d)``, input map ``[S^T, J_d^T]`` (J_d: the points' world x-y Jacobians at the
    scene's state), limits: the scene's input limits, then ``lower <= d <= upper`` (default: the
    bounding box of ``conv(0, P)``).
    """
    base = ContactProblem.from_scene(scene)
    kin = PointKinematics(scene, [(d.name, d.link, d.point_in_link) for d in disturbances.items])
    jac, _, _ = kin.evaluate(scene.q, scene.v)
    if lower is None:
        lower = np.minimum(0.0, disturbances.lower)
    if upper is None:
        upper = np.maximum(0.0, disturbances.upper)
    return replace(
        base,
        inputs=base.inputs + disturbances.names,
        input_map=np.hstack([base.input_map, jac.T]),
        lower=np.concatenate([base.lower, np.asarray(lower, dtype=float)]),
        upper=np.concatenate([base.upper, np.asarray(upper, dtype=float)]),
    )


def sample_disturbances(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Half the draws a random point of ``points``, half a random convex combination of them."""
    samples = []
    for k in range(count):
        if k % 2 == 0:
            samples.append(points[rng.integers(len(points))])
        else:
            samples.append(rng.dirichlet(np.ones(len(points))) @ points)
    return np.array(samples).reshape(count, points.shape[1])


