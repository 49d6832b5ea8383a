"""Contact modes and the linear system each one imposes (docs/maths.md, *Mode letters in every output*).

Every active contact is in one of four modes, always spelled S, L, R, F:

| mode | equalities | inequalities |
| --- | --- | --- |
| S separate | lam_N = 0, lam_T = 0 | a_N >= 0 (only if v_N = 0) |
| F fixed | a_N = 0, a_T = 0 | lam_N >= 0, -mu lam_N <= lam_T <= mu lam_N |
| R slide right (+t) | a_N = 0, lam_T = -mu lam_N | lam_N >= 0, a_T >= 0 (only if v_T = 0) |
| L slide left (-t) | a_N = 0, lam_T = +mu lam_N | lam_N >= 0, a_T <= 0 (only if v_T = 0) |

Velocity pruning: v_N > 0 leaves S only; v_T > 0 leaves {S, R}; v_T < 0 leaves {S, L}; v_N < 0
is an impact, reported as :class:`~frcontrol.errors.ImpactState`.

With the unknowns ``x = (dv, lam_N, lam_T)`` (n + 2k entries) a mode of the whole system
(one letter per contact, e.g. ``"SFF"``) is the linear system::

    A x = B u + c          (dynamics: n rows; mode equalities: 2 rows per contact)
    G x <= g               (mode inequalities)

built here by :func:`build_mode_system` without solving anything. A partial assignment (fewer
letters than contacts) leaves the remaining contacts' forces free and their accelerations
unconstrained: a relaxation of every mode that completes it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

import numpy as np

from .drives import drives_report, resting_joint_torques
from .errors import ImpactState, InputError
from .records import replaced
from .response import BALANCING_FRICTION
from .scene import Scene

MODE_LETTERS = "SLRF"
"""The four contact modes, in their canonical order."""

VELOCITY_TOLERANCE = 1e-9
"""[m/s] A contact velocity (normal or tangential) with magnitude <= this counts as zero."""


FRICTION_PLANS = 1024
"""The most compiled plans a problem's family keeps (:attr:`ContactProblem.plans_by_friction`)."""


@dataclass(frozen=True)
class ContactProblem:
    """The rigid-body contact problem of a scene's active contacts at one state.

    ``M dv + h = S^T u + J_N^T lam_N + J_T^T lam_T`` with contact accelerations
    ``a_N = J_N dv + drift_N`` and ``a_T = J_T dv + drift_T``.

    Attributes:
        coordinates: names of the n minimal coordinates.
        contacts: names of the k active contacts, in scene order.
        inputs: names of the m inputs.
        mass_matrix: M (n, n) [kg, kg m, kg m^2].
        bias: h (n,) [N, N m].
        input_map: S^T (n, m).
        jacobian_normal: J_N (k, n); jacobian_tangent: J_T (k, n).
        drift_normal: dJ_N v (k,) [m/s^2]; drift_tangent: dJ_T v (k,) [m/s^2].
        normal_velocities: v_N (k,) [m/s]; tangential_velocities: v_T (k,) [m/s].
        mu: friction coefficients (k,).
        lower: input lower limits (m,) (-inf where none); upper: upper limits (m,).
        velocity_tolerance: [m/s] what counts as a zero contact velocity.
        input_units: each input's unit (``"N"``, ``"N m"``, ``"V"`` for a DC motor's voltage).
        drives: the scene's drives at this state (:func:`frcontrol.drives.drives_report`), by joint.
        springs: the joint springs at this state (:meth:`frcontrol.springs.JointSprings.report`: k, c,
            rest, deflection [m or rad] and force [N or N m], in h already), by joint.
        scene_contacts: every contact of the scene, in scene order (empty: not from a scene).
    """

    coordinates: tuple[str, ...]
    contacts: tuple[str, ...]
    inputs: tuple[str, ...]
    mass_matrix: np.ndarray
    bias: np.ndarray
    input_map: np.ndarray
    jacobian_normal: np.ndarray
    jacobian_tangent: np.ndarray
    drift_normal: np.ndarray
    drift_tangent: np.ndarray
    normal_velocities: np.ndarray
    tangential_velocities: np.ndarray
    mu: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    velocity_tolerance: float = VELOCITY_TOLERANCE
    input_units: tuple[str, ...] = ()
    drives: Mapping[str, Any] = field(default_factory=dict)
    springs: Mapping[str, Any] = field(default_factory=dict)
    scene_contacts: tuple[str, ...] = ()

    @property
    def n(self) -> int:
        """Number of coordinates."""
        return len(self.coordinates)

    @property
    def k(self) -> int:
        """Number of active contacts."""
        return len(self.contacts)

    @property
    def m(self) -> int:
        """Number of inputs."""
        return len(self.inputs)

    @classmethod
    def from_scene(
        cls,
        scene: Scene,
        q: np.ndarray | None = None,
        v: np.ndarray | None = None,
        *,
        contacts: Sequence[int] | None = None,
        velocity_tolerance: float = VELOCITY_TOLERANCE,
        drive_torque: np.ndarray | None = None,
    ) -> ContactProblem:
        """The problem at the scene's state (or at ``q``, ``v``).

        Args:
            scene: the scene.
            q: configuration (default: the scene's).
            v: velocity (default: the scene's).
            contacts: indices into ``scene.contacts`` of the contacts that take part (default: the
                scene's active contacts), e.g. those a simulator finds touching.
            velocity_tolerance: [m/s] |v| at most this is zero (see :data:`VELOCITY_TOLERANCE`).
            drive_torque: [N m] per coordinate, the known torques of elastic transmissions, moved
                into the bias (default: their torques at rest at the scene's state,
                :func:`frcontrol.drives.resting_joint_torques`; zero without elastic drives).
        """
        indices = list(scene.active_indices if contacts is None else contacts)
        active = [scene.contacts[i] for i in indices]
        return cls(
            coordinates=scene.coordinate_names,
            contacts=tuple(c.name for c in active),
            inputs=scene.inputs.coordinates,
            input_map=scene.inputs.selection_transpose(scene.robot.nv),
            mu=np.array([c.mu for c in active], dtype=float),
            lower=scene.inputs.lower,
            upper=scene.inputs.upper,
            velocity_tolerance=velocity_tolerance,
            input_units=scene.inputs.units,
            scene_contacts=tuple(c.name for c in scene.contacts),
            **_state_fields(scene, scene.q if q is None else q, scene.v if v is None else v, indices,
                            drive_torque),
        )

    def at_state(self, scene: Scene, q: np.ndarray, v: np.ndarray, mu: np.ndarray | None = None
                 ) -> ContactProblem:
        """``from_scene(scene, q, v)`` for this problem, made by ``from_scene(scene)``.

        The state's arrays are found anew, every other field is shared; ``mu``: other coefficients
        [-] of its contacts (as :meth:`with_friction` of the result). For a scene whose touching
        contacts are the same at ``(q, v)`` as at its own state (the caller's to know:
        :func:`frcontrol.scene_numbers.state_with_numbers` says where they are).
        """
        fields = _state_fields(scene, q, v, scene.active_indices, None)
        if mu is not None:  # as with_friction(mu) of the result, at once
            fields["mu"] = mu
        problem = replaced(self, **fields)
        problem.__dict__["plans_by_friction"] = self.plans_by_friction
        return problem

    def scene_mode(self, mode: str) -> str:
        """``mode`` (a letter per contact of this problem) over every scene contact, as outputs print it.

        Without the scene's contacts (a problem not built from a scene) the mode is returned as is.
        """
        if not self.scene_contacts:
            return mode
        places = self._scene_places
        if places is None or len(mode) != self.k:  # the checks and errors of scene_mode
            return scene_mode(mode, self.contacts, self.scene_contacts)
        return "".join([mode[i] if i >= 0 else "S" for i in places])

    @cached_property
    def _scene_places(self) -> tuple[int, ...] | None:
        """Per scene contact, its index among this problem's contacts (-1: apart).

        None when a contact of this problem is not a scene contact (:func:`scene_mode` then says so).
        """
        contacts = self.contacts
        if any(name not in self.scene_contacts for name in contacts):
            return None
        return tuple(contacts.index(name) if name in contacts else -1 for name in self.scene_contacts)

    def named_mode(self, mode: str) -> str:
        """``mode`` as messages name it: the scene's letters with each contact's name beside its own.

        ``"LL"`` of a problem touching ``left`` and ``right`` in a scene that also lists ``top`` is
        ``"LLS (left L, right L, top S)"`` (:func:`mode_label` of :meth:`scene_mode`): the letters
        every output prints. Without the scene's contacts, the problem's own contacts are named; a
        partial mode (fewer letters than contacts, as the enumeration grows them) names the contacts
        it assigns.
        """
        if len(mode) < self.k:
            assigned = zip(self.contacts[:len(mode)], mode, strict=True)
            return f"{mode} ({', '.join(f'{contact} {letter}' for contact, letter in assigned)})"
        scene, names = self.scene_mode(mode), self._label_names
        if len(scene) != len(names):  # mode_label's error
            return mode_label(scene, self.scene_contacts or self.contacts)
        return f"{scene} ({', '.join(map(str.__add__, names, scene))})"  # mode_label's words

    @cached_property
    def _label_names(self) -> tuple[str, ...]:
        """Each contact's name and a space, as :func:`mode_label` puts it before the contact's letter."""
        return tuple(f"{name} " for name in self.scene_contacts or self.contacts)

    def with_friction(self, mu: np.ndarray) -> ContactProblem:
        """The same problem with other Coulomb coefficients [-] (k,) of its contacts.

        Nothing else depends on friction: the state's arrays are shared with this problem (a
        problem is not changed in place), and so are :attr:`state_cache` and
        :attr:`plans_by_friction` (the kernel's plans, by coefficients); what is found once per
        problem (the row table) is found again for the new one.
        """
        problem = replaced(self, mu=mu)
        problem.__dict__["state_cache"] = self.state_cache
        problem.__dict__["plans_by_friction"] = self.plans_by_friction
        return problem

    @cached_property
    def state_cache(self) -> dict[str, Any]:
        """What is found once per state (from M, h, the Jacobians, the velocities alone), by name.

        Shared with the problems :meth:`with_friction` makes; one made by ``dataclasses.replace``
        starts empty. (:func:`frcontrol.stability.stable_verdicts` keeps M's factor and the bias's
        scale here.) As :attr:`kernel_cache`, it holds for a problem not changed in place: make a
        new problem for another state, never write into one's arrays.
        """
        return {}

    @cached_property
    def plans_by_friction(self) -> dict[bytes, Any]:
        """The compiled kernel's plans of this problem's family, by their coefficients' bytes.

        The family: this problem and those :meth:`with_friction` and :meth:`at_state` make from it,
        which differ from it in friction and state only, as a plan does not (it holds the input
        map, the limits and the coefficients): an atlas's points share their plans. At most
        :data:`FRICTION_PLANS` are kept (then they are found again).
        """
        return {}

    @cached_property
    def kernel_cache(self) -> dict[str, Any]:
        """What a kernel made once for this problem (a compiled plan), by name.

        A problem made from this one (:meth:`with_friction`, ``dataclasses.replace``) starts empty.
        """
        return {}

    @cached_property
    def row_table(self) -> ContactRowTable:
        """Every contact's rows in every mode letter (:func:`contact_row_table`), built once."""
        return contact_row_table(self)

    @cached_property
    def row_labels(self) -> np.ndarray:
        """Each inequality row's label, ``"tip: lam_N >= 0"``, indexed like the row table (k, 4, 3)."""
        labels = np.empty((self.k, len(MODE_LETTERS), ROWS_PER_CONTACT), dtype=object)
        for i, name in enumerate(self.contacts):
            for letter, row_labels in enumerate(_ROW_LABELS):
                labels[i, letter] = [f"{name}: {label}" for label in row_labels]
        return labels

    @cached_property
    def letter_row_counts(self) -> np.ndarray | None:
        """Per contact and letter (k, 4), how many inequality rows it has, when its valid rows lead.

        :func:`extend_child_systems` reads a child's rows as a leading slice; None where a letter's
        valid rows are not its first ones.
        """
        valid = self.row_table.valid
        counts = valid.sum(axis=2)
        leading = np.arange(ROWS_PER_CONTACT) < counts[:, :, None]
        return counts if np.array_equal(valid, leading) else None

    @cached_property
    def _letter_blocks(self) -> dict[tuple[int, str], LetterBlock]:
        return {}

    def _letter_block(self, contact: int, letters: str) -> LetterBlock:
        """The rows ``letters`` give contact ``contact``, one block per letter, found once (read-only).

        For :func:`extend_child_systems`, which checks its arguments: ``0 <= contact < k``, letters
        of S, L, R, F, and :attr:`letter_row_counts` not None (a letter's valid rows lead).
        """
        key = (contact, letters)
        block = self._letter_blocks.get(key)
        if block is None:
            table, counts = self.row_table, self.letter_row_counts
            if counts is None:
                raise InputError("the problem's rows do not lead with each letter's valid ones")
            chosen = [MODE_LETTERS.index(ch) for ch in letters]
            own = [int(counts[contact, i]) for i in chosen]
            labels = self.row_labels[contact]
            block = self._letter_blocks[key] = LetterBlock(
                equalities=table.equalities[contact, chosen],
                equality_rhs=table.equality_rhs[contact, chosen],
                inequalities=table.inequalities[contact, chosen],
                inequality_rhs=table.inequality_rhs[contact, chosen],
                motion=table.motion[contact, chosen],
                counts=tuple(own),
                labels=tuple(tuple(labels[i, :n]) for i, n in zip(chosen, own, strict=True)))
            for array in (block.equalities, block.equality_rhs, block.inequalities, block.inequality_rhs,
                          block.motion):
                array.setflags(write=False)
        return block

    @cached_property
    def _padded_input_maps(self) -> dict[int, np.ndarray]:
        return {}

    def _padded_input_map(self, rows: int) -> np.ndarray:
        """``B`` of a mode with ``rows`` equations: the input map over the dynamics' rows, zeros below.

        Read-only, shared by every mode of that size.
        """
        B = self._padded_input_maps.get(rows)
        if B is None:
            B = np.zeros((rows, self.m))
            B[:self.n] = self.input_map
            B.setflags(write=False)
            self._padded_input_maps[rows] = B
        return B

    @cached_property
    def dynamics(self) -> np.ndarray:
        """The dynamics' rows of every mode's ``A`` (:func:`dynamics_rows`), built once."""
        return dynamics_rows(self)

    def allowed_modes(self) -> tuple[str, ...]:
        """Per contact, the modes its velocity allows (velocity pruning), in S, L, R, F order.

        Raises:
            ImpactState: a contact moves into its surface (v_N < -tolerance).
        """
        tol = self.velocity_tolerance
        allowed = []
        for name, vn, vt in zip(self.contacts, self.normal_velocities, self.tangential_velocities,
                                strict=True):
            if vn < -tol:
                raise ImpactState(name, vn)
            if vn > tol:
                allowed.append("S")
            elif vt > tol:
                allowed.append("SR")
            elif vt < -tol:
                allowed.append("SL")
            else:
                allowed.append(MODE_LETTERS)
        return tuple(allowed)

    def check_numbers(self) -> None:
        """Check the problem's arrays: their shapes agree with n, k and m, their numbers are finite.

        The input limits may be infinite (no limit) but not NaN; the friction coefficients are at
        least 0. A problem made from a scene passes (the scene is checked when loaded); one made by
        hand is checked by :func:`~frcontrol.engine.analyze` and
        :func:`~frcontrol.engine.solutions_at` before they read it.

        Raises:
            InputError: the first array of another shape, or with a NaN or infinite entry (a NaN
                limit, a negative friction coefficient), named.
        """
        n, k, m = self.n, self.k, self.m
        shapes = {"mass_matrix": (n, n), "bias": (n,), "input_map": (n, m), "jacobian_normal": (k, n),
                  "jacobian_tangent": (k, n), "drift_normal": (k,), "drift_tangent": (k,),
                  "normal_velocities": (k,), "tangential_velocities": (k,), "mu": (k,), "lower": (m,),
                  "upper": (m,)}
        for name, shape in shapes.items():
            values = np.asarray(getattr(self, name), dtype=float)
            if values.shape != shape:
                raise InputError(f"ContactProblem.{name} has shape {values.shape}; its n = {n} coordinates, "
                                 f"k = {k} contacts and m = {m} inputs make it {shape}")
            limit = name in ("lower", "upper")  # (an infinite limit: none)
            if (np.isnan(values) if limit else ~np.isfinite(values)).any():
                what = "a NaN" if limit else "a NaN or infinite"
                raise InputError(f"ContactProblem.{name} has {what} entry: {values.tolist()}")
        if (np.asarray(self.mu) < 0.0).any():
            raise InputError(f"ContactProblem.mu has a negative friction coefficient: {list(self.mu)}")

    def input_bound_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The finite input limits as rows ``C u <= d``."""
        m = self.m
        eye = np.eye(m)
        up = np.isfinite(self.upper)
        lo = np.isfinite(self.lower)
        if not m:  # a robot with no inputs: no rows over an empty u
            return np.zeros((0, 0)), np.zeros(0)
        rows = np.vstack([eye[up], -eye[lo]])
        rhs = np.concatenate([self.upper[up], -self.lower[lo]])
        return rows.reshape(-1, m), rhs


def _state_fields(scene: Scene, q: np.ndarray, v: np.ndarray, indices: Sequence[int],
                  drive_torque: np.ndarray | None) -> dict[str, Any]:
    """The fields of :class:`ContactProblem` that depend on the state ``(q, v)`` (and ``drive_torque``)."""
    state = scene.robot.state(q, v, indices)
    torque = _drive_torque(scene, drive_torque)
    bias = state.bias if torque is _NO_TORQUE else state.bias - torque  # (x - 0.0 is x, to the bit)
    return {"mass_matrix": state.mass_matrix, "bias": bias,
            "jacobian_normal": state.jacobian_normal, "jacobian_tangent": state.jacobian_tangent,
            "drift_normal": state.drift_normal, "drift_tangent": state.drift_tangent,
            "normal_velocities": state.normal_velocities,
            "tangential_velocities": state.tangential_velocities,
            "drives": _drives_report(scene, v), "springs": scene.robot.springs.report(state.q, state.v)}


def _drives_report(scene: Scene, v: np.ndarray) -> dict[str, Any]:
    """The scene's drives at the joint speeds ``v`` (empty without drives)."""
    if not scene.drives:
        return {}
    return drives_report(scene.drives, dict(zip(scene.coordinate_names, v, strict=True)))


_NO_TORQUE = 0.0
""":func:`_drive_torque` of a scene without elastic transmissions (this very float)."""


def _drive_torque(scene: Scene, given: np.ndarray | None) -> np.ndarray | float:
    """The elastic transmissions' known joint torques (:data:`_NO_TORQUE` when the scene has none)."""
    if given is not None:
        return np.asarray(given, dtype=float)
    if not any(d.elastic for d in scene.drives.values()):
        return _NO_TORQUE
    return resting_joint_torques(scene.drives, scene.coordinate_names)


@dataclass(frozen=True)
class ModeSystem:
    """The linear system of one (possibly partial) contact mode: ``A x = B u + c``, ``G x <= g``.

    ``x = (dv, lam_N, lam_T)``. Rows of ``G`` carry a label each (``"tip: lam_N >= 0"``) so that
    reports can say which physical condition bounds a domain, and a flag ``motion``: True for the
    rows that state the mode's motion (``a_N >= 0`` of S, ``a_T >= 0`` / ``<= 0`` of R / L), which
    a non-degenerate solution of the mode satisfies strictly.
    """

    mode: str
    A: np.ndarray
    B: np.ndarray
    c: np.ndarray
    G: np.ndarray
    g: np.ndarray
    labels: tuple[str, ...]
    motion: np.ndarray


def check_mode(problem: ContactProblem, mode: str, *, partial: bool = False) -> str:
    """Validate a mode string (one letter S, L, R, F per active contact); return it.

    Raises:
        InputError: a wrong letter or length.
    """
    if not isinstance(mode, str) or any(ch not in MODE_LETTERS for ch in mode):
        raise InputError(f"a mode is a string of the letters S, L, R, F; got {mode!r}")
    if len(mode) > problem.k or (not partial and len(mode) != problem.k):
        scene = problem.scene_contacts
        hint = (f": {mode!r} has one per scene contact ({', '.join(scene)})"
                if scene and len(mode) == len(scene) != problem.k else "")
        raise InputError(f"mode {mode!r} has {len(mode)} letters; a mode here has one per touching contact, "
                         f"{problem.k} ({', '.join(problem.contacts)}){hint}")
    return mode


def needs_balancing(problem: ContactProblem, modes: Sequence[str]) -> np.ndarray:
    """Per mode: whether its system may be balanced.

    True where one of its sliding contacts (L or R) has mu above
    :data:`~frcontrol.response.BALANCING_FRICTION`.
    """
    rough = problem.mu > BALANCING_FRICTION
    if not rough.any():
        return np.zeros(len(modes), dtype=bool)
    return np.array([any(rough[i] for i, ch in enumerate(mode) if ch in "LR") for mode in modes], dtype=bool)


def build_mode_system(problem: ContactProblem, mode: str) -> ModeSystem:
    """Assemble the equalities and inequalities of ``mode`` (a prefix of letters is allowed).

    Contacts beyond ``len(mode)`` are unassigned: no rows for them. The rows are those of
    :func:`contact_row_table`, in contact order.
    """
    check_mode(problem, mode, partial=True)
    n, k = problem.n, problem.k
    nx = n + 2 * k
    table = problem.row_table
    contacts = np.arange(len(mode), dtype=int)
    letters = np.array([MODE_LETTERS.index(ch) for ch in mode], dtype=int)
    valid = table.valid[contacts, letters].reshape(-1)
    A = np.vstack([problem.dynamics, table.equalities[contacts, letters].reshape(-1, nx)])
    B = np.vstack([problem.input_map, np.zeros((2 * len(mode), problem.m))])
    c = np.concatenate([-problem.bias, table.equality_rhs[contacts, letters].reshape(-1)])
    labels = problem.row_labels[contacts, letters].reshape(-1)[valid].tolist()
    return ModeSystem(
        mode=mode,
        A=A,
        B=B,
        c=c,
        G=table.inequalities[contacts, letters].reshape(-1, nx)[valid],
        g=table.inequality_rhs[contacts, letters].reshape(-1)[valid],
        labels=tuple(labels),
        motion=table.motion[contacts, letters].reshape(-1)[valid],
    )


class ChildSystems(list[ModeSystem]):
    """Children's systems (a list of :class:`ModeSystem`), with their ``A`` and ``c`` stacked as built.

    ``A`` (count, rows, nx) and ``c`` (count, rows): each child's ``A`` and ``c`` is a slice of
    them, so the stack its certificates read needs no copy.
    """

    A: np.ndarray
    c: np.ndarray

    @classmethod
    def of(cls, systems: list[ModeSystem], A: np.ndarray, c: np.ndarray) -> ChildSystems:
        """``systems`` with their stacks ``A`` and ``c``."""
        children = cls(systems)
        children.A, children.c = A, c
        return children


def build_child_systems(problem: ContactProblem, prefix: str, letters: str) -> ChildSystems:
    """:func:`build_mode_system` of ``prefix + letter`` for each letter, in one gather.

    The same rows as one call per child (the children share ``B``, which is read-only).
    """
    check_mode(problem, prefix + letters[:1], partial=True)
    if any(ch not in MODE_LETTERS for ch in letters):
        raise InputError(f"a mode is a string of the letters S, L, R, F; got {letters!r}")
    n, nx, count, j = problem.n, problem.n + 2 * problem.k, len(letters), len(prefix) + 1
    table = problem.row_table
    contacts = np.arange(j, dtype=int)
    chosen = np.empty((count, j), dtype=int)
    chosen[:] = [MODE_LETTERS.index(ch) for ch in prefix] + [0]
    chosen[:, -1] = [MODE_LETTERS.index(ch) for ch in letters]
    A = np.empty((count, n + 2 * j, nx))
    A[:, :n] = problem.dynamics
    A[:, n:] = table.equalities[contacts, chosen].reshape(count, 2 * j, nx)
    B = problem._padded_input_map(n + 2 * j)
    c = np.empty((count, n + 2 * j))
    c[:, :n] = -problem.bias
    c[:, n:] = table.equality_rhs[contacts, chosen].reshape(count, 2 * j)
    valid = table.valid[contacts, chosen].reshape(-1)
    # every child's valid rows in one gather each, then each child's block of them (a C-contiguous slice)
    G = table.inequalities[contacts, chosen].reshape(-1, nx)[valid]
    g = table.inequality_rhs[contacts, chosen].reshape(-1)[valid]
    motion = table.motion[contacts, chosen].reshape(-1)[valid]
    labels = problem.row_labels[contacts, chosen].reshape(-1)[valid].tolist()
    ends = np.cumsum(valid.reshape(count, -1).sum(axis=1)).tolist()
    starts = [0, *ends[:-1]]
    children = [ModeSystem(mode=prefix + letter, A=A[i], B=B, c=c[i], G=G[start:end], g=g[start:end],
                           labels=tuple(labels[start:end]), motion=motion[start:end])
                for i, (letter, start, end) in enumerate(zip(letters, starts, ends, strict=True))]
    return ChildSystems.of(children, A, c)


def extend_child_systems(problem: ContactProblem, parent: ModeSystem, letters: str) -> ChildSystems:
    """:func:`build_child_systems` of ``parent.mode``, from the parent's own system: the same rows.

    A child's rows are its parent's followed by its letter's (contacts in order), so only the
    letter's rows are gathered; the parent's are copied once into a block shared by the children,
    and a child's inequality rows are a leading slice of it (a letter's valid rows lead,
    :attr:`ContactProblem.letter_row_counts`; where they do not, :func:`build_child_systems` runs).
    """
    counts = problem.letter_row_counts
    prefix, j = parent.mode, len(parent.mode)
    if counts is None or j >= problem.k or any(ch not in MODE_LETTERS for ch in letters):
        return build_child_systems(problem, prefix, letters)
    block = problem._letter_block(j, letters)
    count, nx = len(letters), parent.A.shape[1]
    rows, kept, width = parent.A.shape[0], parent.G.shape[0], parent.G.shape[0] + ROWS_PER_CONTACT
    A = np.empty((count, rows + 2, nx))
    A[:, :rows] = parent.A
    A[:, rows:] = block.equalities
    c = np.empty((count, rows + 2))
    c[:, :rows] = parent.c
    c[:, rows:] = block.equality_rhs
    B = problem._padded_input_map(rows + 2)
    G, g = np.empty((count, width, nx)), np.empty((count, width))
    motion = np.empty((count, width), dtype=bool)
    G[:, :kept], G[:, kept:] = parent.G, block.inequalities
    g[:, :kept], g[:, kept:] = parent.g, block.inequality_rhs
    motion[:, :kept], motion[:, kept:] = parent.motion, block.motion
    labels, own_rows = parent.labels, zip(letters, block.counts, block.labels, strict=True)
    children = [ModeSystem(mode=prefix + letter, A=A[i], B=B, c=c[i], G=G[i, :kept + own],
                           g=g[i, :kept + own], labels=labels + own_labels, motion=motion[i, :kept + own])
                for i, (letter, own, own_labels) in enumerate(own_rows)]
    return ChildSystems.of(children, A, c)


@dataclass(frozen=True)
class LetterBlock:
    """One contact's rows in each of some letters (``ContactProblem._letter_block``).

    ``equalities`` (count, 2, nx), ``equality_rhs`` (count, 2), ``inequalities`` (count, 3, nx),
    ``inequality_rhs`` and ``motion`` (count, 3) as the row table's; ``counts``: each letter's
    valid (leading) inequality rows; ``labels``: theirs.
    """

    equalities: np.ndarray
    equality_rhs: np.ndarray
    inequalities: np.ndarray
    inequality_rhs: np.ndarray
    motion: np.ndarray
    counts: tuple[int, ...]
    labels: tuple[tuple[str, ...], ...]


ROWS_PER_CONTACT = 3
"""The most inequality rows one contact adds in one mode (F: lam_N >= 0 and the two cone sides)."""

_ROW_LABELS = (
    ("a_N >= 0", "", ""),
    ("lam_N >= 0", "a_T <= 0", ""),
    ("lam_N >= 0", "a_T >= 0", ""),
    ("lam_N >= 0", "lam_T <= mu lam_N", "-lam_T <= mu lam_N"),
)
"""Each inequality row's label, per letter (S, L, R, F) and row."""


@dataclass(frozen=True)
class ContactRowTable:
    """Every contact's rows in every mode letter, over ``x = (dv, lam_N, lam_T)``: one table.

    Indexed ``[contact, letter, row]`` with letters in S, L, R, F order (:data:`MODE_LETTERS`):

    | letter | equalities (2 rows) | inequalities (up to 3 rows) |
    | --- | --- | --- |
    | S | lam_N = 0, lam_T = 0 | a_N >= 0 (only if v_N = 0; a motion row) |
    | F | a_N = 0, a_T = 0 | lam_N >= 0, lam_T <= mu lam_N, -lam_T <= mu lam_N |
    | R | a_N = 0, lam_T + mu lam_N = 0 | -max(1, mu) lam_N <= 0, a_T >= 0 (only if v_T = 0; motion) |
    | L | a_N = 0, lam_T - mu lam_N = 0 | -max(1, mu) lam_N <= 0, a_T <= 0 (only if v_T = 0; motion) |

    A sliding contact's ``lam_N >= 0`` is scaled by ``max(1, mu)``: the same half-space, measured
    as the friction force it implies (with mu ~ 1e9 the plain row, after the response is
    substituted, has coefficients of order 1/mu and would read as a constant).

    Attributes:
        equalities: (k, 4, 2, nx); equality_rhs: (k, 4, 2).
        inequalities: (k, 4, 3, nx) as ``G x <= g``; inequality_rhs: (k, 4, 3).
        valid: (k, 4, 3) which inequality rows exist; motion: (k, 4, 3) which state a motion.
    """

    equalities: np.ndarray
    equality_rhs: np.ndarray
    inequalities: np.ndarray
    inequality_rhs: np.ndarray
    valid: np.ndarray
    motion: np.ndarray


def dynamics_rows(problem: ContactProblem) -> np.ndarray:
    """The dynamics' rows ``[M, -J_N^T, -J_T^T]`` of every mode's ``A`` (right side ``S^T u - h``)."""
    n, k = problem.n, problem.k
    rows = np.empty((n, n + 2 * k))
    rows[:, :n] = problem.mass_matrix
    np.negative(problem.jacobian_normal.T, out=rows[:, n:n + k])
    np.negative(problem.jacobian_tangent.T, out=rows[:, n + k:])
    return rows


def contact_row_table(problem: ContactProblem) -> ContactRowTable:
    """Build :class:`ContactRowTable` for the problem's contacts (no solving).

    Every entry is one of the problem's numbers (a Jacobian entry, a drift, mu...), its negative,
    or 0, 1, -1: the table is one gather from those values through :func:`_row_template`, the one
    place where the rows are written down.
    """
    n, k, tol = problem.n, problem.k, problem.velocity_tolerance
    jn, jt, dn, dt, mu = (problem.jacobian_normal, problem.jacobian_tangent, problem.drift_normal,
                          problem.drift_tangent, problem.mu)
    plain = np.concatenate([jn.ravel(), jt.ravel(), dn, dt, mu])
    values = np.concatenate([(0.0, 1.0, -1.0), plain, -plain, -np.maximum(1.0, mu)])
    template = _row_template(n, k)
    resting = np.abs(problem.normal_velocities) <= tol
    sticking = np.abs(problem.tangential_velocities) <= tol
    valid = np.empty((k, 4, ROWS_PER_CONTACT), dtype=bool)
    valid[:] = template.always
    valid[:, 0, 0] = resting
    valid[:, 1:3, 1] = sticking[:, None]
    return ContactRowTable(values[template.equalities], values[template.equality_rhs],
                           values[template.inequalities], values[template.inequality_rhs], valid,
                           valid & template.motion)


@dataclass(frozen=True)
class _RowTemplate:
    """Where each entry of a :class:`ContactRowTable` comes from.

    Indices into the value vector ``(0, 1, -1, P, -P, -max(1, mu))`` with the problem's numbers
    ``P = (J_N, J_T, d_N, d_T, mu)`` (each of them and its negative: one negation of P).
    """

    equalities: np.ndarray
    equality_rhs: np.ndarray
    inequalities: np.ndarray
    inequality_rhs: np.ndarray
    always: np.ndarray  # rows that exist whatever the velocities
    motion: np.ndarray  # rows that state a motion (they exist only at zero velocity)


@lru_cache(maxsize=64)
def _row_template(n: int, k: int) -> _RowTemplate:
    """The rows of the table in :class:`ContactRowTable`'s docstring, for n coordinates, k contacts."""
    nx = n + 2 * k
    S, L, R, F = range(4)
    idx = np.arange(k)
    i_n, i_t = n + idx, n + k + idx
    ZERO, ONE, MINUS = 0, 1, 2
    size = 2 * k * n + 3 * k  # P = (J_N, J_T, d_N, d_T, mu); values = (0, 1, -1, P, -P, -max(1, mu))
    plain = np.cumsum([3, k * n, k * n, k, k])  # where J_N, J_T, d_N, d_T, mu start in P
    matrix = np.arange(k * n).reshape(k, n)
    jn, jt = plain[0] + matrix, plain[1] + matrix
    neg_jn, neg_jt = jn + size, jt + size
    dn, dt, mu = (plain[j] + idx for j in range(2, 5))
    neg_dn, neg_dt, neg_mu = dn + size, dt + size, mu + size
    neg_scale = 3 + 2 * size + idx
    eq = np.full((k, 4, 2, nx), ZERO)
    eq_rhs = np.full((k, 4, 2), ZERO)
    eq[idx, S, 0, i_n] = ONE  # S: lam_N = 0, lam_T = 0
    eq[idx, S, 1, i_t] = ONE
    eq[:, 1:, 0, :n] = jn[:, None, :]  # a_N = 0 in L, R, F
    eq_rhs[:, 1:, 0] = neg_dn[:, None]
    eq[:, F, 1, :n] = jt  # F: a_T = 0
    eq_rhs[:, F, 1] = neg_dt
    eq[idx, R, 1, i_t] = ONE  # R: lam_T + mu lam_N = 0
    eq[idx, R, 1, i_n] = mu
    eq[idx, L, 1, i_t] = ONE  # L: lam_T - mu lam_N = 0
    eq[idx, L, 1, i_n] = neg_mu
    ineq = np.full((k, 4, ROWS_PER_CONTACT, nx), ZERO)
    ineq_rhs = np.full((k, 4, ROWS_PER_CONTACT), ZERO)
    always = np.zeros((4, ROWS_PER_CONTACT), dtype=bool)
    motion = np.zeros((4, ROWS_PER_CONTACT), dtype=bool)
    ineq[:, S, 0, :n] = neg_jn  # S: a_N >= 0 (at v_N = 0)
    ineq_rhs[:, S, 0] = dn
    motion[S, 0] = True
    ineq[idx, L, 0, i_n] = ineq[idx, R, 0, i_n] = neg_scale  # L, R: -max(1, mu) lam_N <= 0
    ineq[idx, F, 0, i_n] = MINUS  # F: lam_N >= 0
    always[1:, 0] = True
    ineq[:, R, 1, :n] = neg_jt  # R: a_T >= 0 (at v_T = 0)
    ineq_rhs[:, R, 1] = dt
    ineq[:, L, 1, :n] = jt  # L: a_T <= 0 (at v_T = 0)
    ineq_rhs[:, L, 1] = neg_dt
    motion[L, 1] = motion[R, 1] = True
    ineq[idx, F, 1, i_t] = ONE  # F: lam_T - mu lam_N <= 0
    ineq[idx, F, 1, i_n] = neg_mu
    ineq[idx, F, 2, i_t] = MINUS  # F: -lam_T - mu lam_N <= 0
    ineq[idx, F, 2, i_n] = neg_mu
    always[F, 1:] = True
    return _RowTemplate(eq, eq_rhs, ineq, ineq_rhs, always, motion)


def mode_outputs(problem: ContactProblem, x: np.ndarray) -> dict[str, np.ndarray]:
    """Split ``x = (dv, lam_N, lam_T)`` and add the contact accelerations a_N, a_T."""
    n, k = problem.n, problem.k
    dv = x[:n]
    return {
        "dv": dv,
        "lambda_n": x[n:n + k],
        "lambda_t": x[n + k:n + 2 * k],
        "a_n": problem.jacobian_normal @ dv + problem.drift_normal,
        "a_t": problem.jacobian_tangent @ dv + problem.drift_tangent,
    }


def all_modes(allowed: Sequence[str]) -> list[str]:
    """Every mode string from per-contact allowed letters (the naive, exhaustive list)."""
    modes = [""]
    for letters in allowed:
        modes = [m + ch for m in modes for ch in letters]
    return modes


def contact_mode_letter(normal_force: float, tangential_velocity: float, force_tolerance: float,
                        slip_tolerance: float, tangential_acceleration: float = 0.0,
                        acceleration_tolerance: float = float("inf")) -> str:
    """The mode a contact is in: S, L, R or F. The one rule every part of frcontrol uses.

    S when the normal force [N] is at most ``force_tolerance`` [N]; else R (along +t) or L when
    ``|v_T|`` exceeds ``slip_tolerance`` [m/s]; else, at the acceleration level, R or L when
    ``|a_T|`` exceeds ``acceleration_tolerance`` [m/s^2] (a sticking contact that starts to slip;
    infinite by default: a sampled motion has no acceleration); else F.
    """
    if normal_force <= force_tolerance:
        return "S"
    if tangential_velocity > slip_tolerance:
        return "R"
    if tangential_velocity < -slip_tolerance:
        return "L"
    if tangential_acceleration > acceleration_tolerance:
        return "R"
    if tangential_acceleration < -acceleration_tolerance:
        return "L"
    return "F"


MODE_MEANINGS = {"S": "separate", "L": "slide left (-t)", "R": "slide right (+t)", "F": "fixed"}
"""What each mode letter says of its contact."""


def scene_mode(mode: str, contacts: Sequence[str], scene_contacts: Sequence[str]) -> str:
    """A mode over every contact of the scene, in scene order: the form every output prints.

    A mode of the contact problem has one letter per *touching* contact (``contacts``); the
    other contacts of the scene are apart, so they are ``S``. ``scene_mode("RL", ("toe", "heel"),
    ("toe", "hip", "heel"))`` is ``"RSL"``.

    Raises:
        InputError: the mode's length is not the number of ``contacts``, or a contact is not in
            ``scene_contacts``.
    """
    if len(mode) != len(contacts):
        raise InputError(f"mode {mode!r} has {len(mode)} letters for {len(contacts)} contacts "
                         f"({', '.join(contacts)})")
    unknown = [name for name in contacts if name not in scene_contacts]
    if unknown:
        raise InputError(f"contact {unknown[0]!r} is not among the scene's ({', '.join(scene_contacts)})")
    letters = dict(zip(contacts, mode, strict=True))
    return "".join(letters.get(name, "S") for name in scene_contacts)


def add_scene_modes(document: dict[str, Any], scene_contacts: Sequence[str]) -> dict[str, Any]:
    """Add ``"scene_contacts"``, and ``"scene_mode"`` beside every ``"mode"`` of a JSON document.

    A ``"mode"`` has one letter per contact of the nearest ``"contacts"`` (a list of names, or a
    table by name) at its level or above: the touching contacts. Its ``"scene_mode"`` has one
    letter per contact of the scene (:func:`scene_mode`): the form every text table, figure and
    page shows. Every result's ``to_dict()`` calls this. Returns ``document``, changed in place.
    """

    def walk(node: Any, contacts: list[str] | None) -> None:
        if isinstance(node, dict):
            own = node.get("contacts")
            if isinstance(own, (list, dict)) and all(isinstance(c, str) for c in own):
                contacts = list(own)
            mode = node.get("mode")
            if isinstance(mode, str) and contacts is not None and len(mode) == len(contacts):
                node["scene_mode"] = scene_mode(mode, contacts, scene_contacts)
            for value in list(node.values()):
                walk(value, contacts)
        elif isinstance(node, list):
            for value in node:
                walk(value, contacts)

    document["scene_contacts"] = list(scene_contacts)
    walk(document, None)
    return document


def mode_label(mode: str, scene_contacts: Sequence[str]) -> str:
    """A scene mode with each contact's name beside its letter: ``"RSL (toe R, hip S, heel L)"``."""
    named = ", ".join(f"{name} {letter}" for name, letter in zip(scene_contacts, mode, strict=True))
    return f"{mode} ({named})"


def mode_heading(scene_contacts: Sequence[str]) -> str:
    """A table column's heading for scene modes: ``"mode (toe hip heel)"``, the names in letter order."""
    return f"mode ({' '.join(scene_contacts)})"


def mode_key(scene_contacts: Sequence[str]) -> str:
    """The line that decodes mode strings: which contact each letter is, and what each letter means."""
    meanings = ", ".join(f"{letter} {meaning}" for letter, meaning in MODE_MEANINGS.items())
    return (f"mode letters: one per contact, in scene order ({', '.join(scene_contacts)}); "
            f"{meanings}")


__all__ = [
    "add_scene_modes",
    "all_modes",
    "mode_heading",
    "mode_key",
    "mode_label",
    "MODE_MEANINGS",
    "scene_mode",
    "ChildSystems",
    "build_child_systems",
    "extend_child_systems",
    "contact_mode_letter",
    "needs_balancing",
    "build_mode_system",
    "check_mode",
    "contact_row_table",
    "ContactProblem",
    "ContactRowTable",
    "dynamics_rows",
    "MODE_LETTERS",
    "mode_outputs",
    "ModeSystem",
    "ROWS_PER_CONTACT",
    "VELOCITY_TOLERANCE",
]
