r"""The stability of a rigid-body solution under contact compliance (Kraus, Kumar, Dupont).

The maths in short: docs/maths.md, *Stability under compliance*.

Make every contact a stiff Kelvin–Voigt element (stiffness ``k/eps``, damping ``b/sqrt(eps)``).
As ``eps -> 0`` the motion splits into the rigid (slow) dynamics and a fast *boundary layer* of the
contact deformations ``y`` (time ``tau = t / sqrt(eps)``)::

    y'' + b D y' + k D y = 0,        D = J_r M^-1 J_c^T                      (KKD eq. 9-10)

The rows ``J_r`` are the constraints the mode holds: ``J_N,i`` for every contact in F, L or R and
``J_T,i`` for every contact in F (rolling/sticking). The columns ``J_c`` are the same rows, except
that a sliding contact's normal column carries its friction: ``J_N,i - mu_i J_T,i`` for R (sliding
toward +t, ``lam_T = -mu lam_N``) and ``J_N,i + mu_i J_T,i`` for L (KKD eq. 3). Contacts in S hold
nothing. For an eigenvalue d of D the boundary layer's roots solve ``s^2 + b d s + k d = 0``:

- d real and positive: both roots in the left half-plane for every ``k, b > 0``: **stable**; the
  compliant solution converges to the rigid one as the stiffness grows;
- ``Re d < 0``: a root in the right half-plane for every ``k, b > 0`` (the product or the sum of the
  roots says so): **unstable**; the compliant solution leaves the rigid one, faster as k grows;
- d complex with ``Re d > 0``: stable for enough damping, ``b^2 / k >= beta*(d)`` [kg]; the verdict
  is stable and ``critical_damping`` reports ``max beta*`` (pass ``stiffness`` and ``damping`` to
  check the roots themselves);
- ``Re d ~ 0``: **not analysable** (``stable = None``).

Also not analysable (None, with the reason): a held contact with ``lam_N = 0`` (impending
separation), a sticking contact on its friction cone's edge ``|lam_T| = mu lam_N`` (impending
slip), a contact that starts sliding from rest with ``a_T = 0``, a separating contact with
``v_N = 0, a_N = 0`` (impending contact).

Dependent rows (statically indeterminate modes, e.g. a box resting on two corners) give D zero
eigenvalues whose eigenvectors are self-equilibrated internal forces: they do not move the robot
and the boundary layer leaves them where they are. KKD's change of coordinates needs independent
rows, so here D is restricted to the row space of ``J_r`` (an SVD with a relative rank tolerance):
``D_rho = U^T J_r M^-1 J_c^T U``, whose eigenvalues are D's minus these ``r - rho`` zeros, which
are counted in ``indeterminate_modes``. The verdict is then about the motion; the internal forces
of the compliant model stay whatever its history made them.

Singular M (massless links) is never inverted. If M is positive definite, ``D = J_r X`` with
``M X = J_c^T`` solved by Cholesky. Otherwise D's eigenvalues are those of the pencil::

    [ M    -J_c^T ] [x]       [ 0  0 ] [x]
    [ J_r   0     ] [v]  = d  [ 0  I ] [v]          (M x = J_c^T v, J_r x = d v)

(QZ; ``eig(A, B)``): its finite eigenvalues are D's. An eigenvalue of D that is infinite at zero
mass (a contact on a massless link: its effective mass is 0) behaves as ``c / eps`` for a small
rotor inertia ``eps``; its sign, which decides stability, is that of the nonzero eigenvalues c of
``J_r N N^T J_c^T`` (N an orthonormal basis of null(M)), reported as ``massless_eigenvalues``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import scipy.linalg

from .cholesky import cholesky_solve, cholesky_upper
from .errors import InputError, KernelError
from .kernel import backend, extension_function, twin
from .modes import ContactProblem, check_mode

if TYPE_CHECKING:
    from .engine import RigidSolution

FORCE_TOLERANCE = 1e-9
"""[-] A force is zero, or on the friction cone's edge, within this times the force scale
``max(1 N, max |lam|, |M| g)``."""

ACCELERATION_TOLERANCE = 1e-9
"""[-] A contact acceleration is zero within this times ``max(1, |a|, |dv|)`` [m/s^2]."""

EIGENVALUE_TOLERANCE = 1e-9
"""[-] An eigenvalue of D has a zero real part within this times D's natural scale
``max|J|^2 / max|M|`` [1/kg]."""

RANK_TOLERANCE = 1e-10
"""[-] Singular values of J_r (or eigenvalues of M) at most this times the largest are zero."""

FINITE_TOLERANCE = 1e-10
"""[-] A pencil eigenvalue ``alpha / beta`` is infinite when ``|beta| <= this * |alpha|``."""

MASS_FACTORS_KEPT = 16
"""Mass matrices whose factorisations :func:`classify_solutions` keeps, by their bytes (an atlas's
points often share M: a free body's never changes, and neither does M along a friction axis)."""

UNSCALED_EIGENVALUE_RANGE = (1e-130, 1e130)
"""[1/kg] The magnitudes of a 1 x 1 D whose eigenvalue LAPACK's ``geev`` returns as D itself, with
no scaling (it scales a matrix whose largest entry is below about 1e-138 or above 1e138): inside
it, :func:`classify_solutions` reads the eigenvalue of one held row without the call."""

VERDICT_ROUND_OFF_BAND = 1e-8
"""[-] The compiled verdict (``held_verdict``, one or two held rows) leaves a solution to the
reference path when one of D's eigenvalues has a real part within this times D's componentwise
round-off scale (``max_ab |J_r[a]| |U^-1| |U^-T| |J_c[b]|^T``, U M's Cholesky factor) of
:data:`EIGENVALUE_TOLERANCE`'s bound: the two sum in other orders, so there they could disagree.
(Within round-off of a double root it widens by the square root of this: the real parts of a
double root move by the square root of the discriminant's round-off.)"""

VERDICT_RANK_SEPARATION = 1e-6
"""[-] The compiled verdict takes two held rows as of rank 2 when their Gram matrix's smaller
eigenvalue exceeds this times its larger (a singular-value ratio above 1e-3, far from
:data:`RANK_TOLERANCE`'s 1e-10 and from the Gram matrix's round-off); other pairs go to the
reference path, whose SVD decides their rank."""


SpectrumMethod = Literal["cholesky", "pencil"]
"""How D's spectrum was found: through M's Cholesky factor, or QZ on the pencil (M singular)."""


@dataclass(frozen=True)
class Stability:
    """The singular-perturbation verdict on one rigid-body solution.

    Attributes:
        mode: the solution's mode (one letter per active contact).
        stable: True (stable), False (unstable) or None (not analysable: see ``reason``).
        eigenvalues: the eigenvalues of D [1/kg] (complex; restricted to the row space of J_r;
            without the infinite ones of massless directions), sorted by real part.
        reason: why, in words.
        rows: the constrained rows, e.g. ``("tip: N",)`` or ``("left: N", "left: T")``.
        delassus: D (r x r) [1/kg] when M is positive definite, else None.
        indeterminate_modes: zero eigenvalues of D removed because J_r's rows are dependent.
        massless_eigenvalues: leading coefficients c of the eigenvalues c/eps that grow without
            bound as a massless link's inertia eps -> 0 (their sign decides).
        critical_damping: ``max beta*`` [kg]: with complex eigenvalues the boundary layer is
            stable iff ``b^2 / k >= beta*``; None when every eigenvalue is real.
        boundary_layer_roots: the roots s [1/s] of ``s^2 + b d s + k d`` when ``stiffness`` and
            ``damping`` were given, else None.
        method: ``"cholesky"`` (M positive definite) or ``"pencil"`` (QZ on the pencil).
        tolerances: the tolerances used.
    """

    mode: str
    stable: bool | None
    eigenvalues: np.ndarray
    reason: str
    rows: tuple[str, ...] = ()
    delassus: np.ndarray | None = None
    indeterminate_modes: int = 0
    massless_eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0))
    critical_damping: float | None = None
    boundary_layer_roots: np.ndarray | None = None
    method: SpectrumMethod = "cholesky"
    tolerances: dict = field(default_factory=dict)


def boundary_layer_roots(eigenvalues: Sequence[complex] | np.ndarray, stiffness: float,
                         damping: float) -> np.ndarray:
    """The roots s [1/s] of ``s^2 + b d s + k d = 0`` for each eigenvalue d of D, two per d.

    Raises:
        InputError: a non-positive stiffness or a negative damping.
    """
    if not (math.isfinite(stiffness) and stiffness > 0):
        raise InputError(f"the stiffness must be > 0 [N/m], got {stiffness}")
    if not (math.isfinite(damping) and damping >= 0):
        raise InputError(f"the damping must be >= 0 [N s/m], got {damping}")
    roots = [np.roots([1.0, damping * d, stiffness * d]) for d in np.asarray(eigenvalues, dtype=complex)]
    return np.concatenate(roots) if roots else np.zeros(0, dtype=complex)


def critical_damping(eigenvalue: complex) -> float:
    """``beta*`` [kg]: the boundary layer of eigenvalue d is stable iff ``b^2 / k >= beta*``.

    With ``s = sqrt(k) x`` the roots solve ``x^2 + sqrt(beta) d x + d = 0`` (``beta = b^2/k``), so
    ``beta*`` depends on d alone; found by bisection on ``log(beta)``. 0 for a real positive d,
    ``inf`` when ``Re d <= 0``.
    """
    d = complex(eigenvalue)
    if d.real <= 0:
        return math.inf
    if d.imag == 0:
        return 0.0

    def stable(beta: float) -> bool:
        return bool(np.all(np.roots([1.0, math.sqrt(beta) * d, d]).real < 0))

    lo, hi = -40.0, 40.0  # log10 of beta [kg]
    if stable(10**lo):
        return 0.0
    if not stable(10**hi):
        return math.inf
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if stable(10**mid) else (mid, hi)
        if hi - lo < 1e-12:
            break
    return float(10**hi)


def _constraint_rows(problem: ContactProblem, solution: RigidSolution, force_tol: float, accel_tol: float,
                     ) -> tuple[list[np.ndarray], list[np.ndarray], list[str], str | None, list[str]]:
    """Rows J_r, columns J_c and labels of the mode; a reason when it is not analysable."""
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    labels: list[str] = []
    notes: list[str] = []
    jn, jt, mu = problem.jacobian_normal, problem.jacobian_tangent, problem.mu.tolist()
    vtol = problem.velocity_tolerance
    # the per-contact numbers as Python floats (the same values; NumPy's scalars cost more)
    v_n, v_t = problem.normal_velocities.tolist(), problem.tangential_velocities.tolist()
    a_n, a_t = solution.a_n.tolist(), solution.a_t.tolist()
    for i, (letter, lam_n, lam_t) in enumerate(zip(solution.mode, solution.lambda_n.tolist(),
                                                   solution.lambda_t.tolist(), strict=False)):
        name = problem.contacts[i]
        if letter == "S":
            if abs(v_n[i]) <= vtol and abs(a_n[i]) <= accel_tol:
                return rows, cols, labels, (f"impending contact at {name!r}: it separates with v_N = 0 and "
                                            f"a_N = {a_n[i]:.3g} ~ 0"), notes
            continue
        if lam_n <= force_tol:
            return rows, cols, labels, (f"impending separation at {name!r}: it is held ({letter}) with "
                                        f"lam_N = {lam_n:.3g} ~ 0"), notes
        if letter == "F":
            if abs(lam_t) >= mu[i] * lam_n - force_tol:
                return rows, cols, labels, (f"impending slip at {name!r}: it sticks with |lam_T| = "
                                            f"{abs(lam_t):.6g} = mu lam_N = {mu[i] * lam_n:.6g}"), notes
            rows += [jn[i], jt[i]]
            cols += [jn[i], jt[i]]
            labels += [f"{name}: N", f"{name}: T"]
            continue
        sign = 1.0 if letter == "R" else -1.0  # R: lam_T = -mu lam_N
        if abs(v_t[i]) <= vtol:
            if abs(a_t[i]) <= accel_tol:
                return rows, cols, labels, (f"impending slip at {name!r}: {letter} from rest (v_T = 0) with "
                                            f"a_T = {a_t[i]:.3g} ~ 0"), notes
            notes.append(f"{name!r} starts sliding from rest ({letter}, a_T = {a_t[i]:.3g})")
        rows.append(jn[i])
        cols.append(jn[i] - sign * mu[i] * jt[i])
        labels.append(f"{name}: N ({letter}, column J_N {'-' if sign > 0 else '+'} mu J_T)")
    return rows, cols, labels, None, notes


def stability_of(
    problem: ContactProblem,
    solution: RigidSolution,
    *,
    stiffness: float | None = None,
    damping: float | None = None,
) -> Stability:
    """Classify a rigid-body solution as stable, unstable or not analysable (module docstring).

    Args:
        problem: the contact problem the solution belongs to (its state, M, rows).
        solution: a rigid-body solution (e.g. from :func:`frcontrol.engine.solutions_at`).
        stiffness: k [N/m]; with ``damping`` [N s/m], also the boundary layer's roots for that
            (k, b) (one value for every contact, as in KKD).
        damping: b [N s/m].

    Raises:
        InputError: the solution's mode does not fit the problem, only one of stiffness and
            damping is given, or they are out of range.
    """
    return _stability(problem, solution, stiffness, damping, None)


def _stability(problem: ContactProblem, solution: RigidSolution, stiffness: float | None,
               damping: float | None, state: _StateTerms | None) -> Stability:
    """:func:`stability_of`, or :func:`classify_solutions`'s path with ``state``.

    ``state`` (:func:`_state_terms` of ``problem``): M's factorisation and the bias's scale are read
    from it instead of being found again (the same numbers).
    """
    mode = check_mode(problem, solution.mode)
    if (stiffness is None) != (damping is None):
        raise InputError("give both stiffness and damping (or neither) for the boundary layer's roots")
    held = _held_spectrum(problem, solution, state)
    if isinstance(held, Stability):
        return held
    spectrum, eig_tol = held.spectrum, held.eigenvalue_tolerance
    eigenvalues, massless = np.asarray(spectrum.eigenvalues, dtype=complex), spectrum.massless
    if eigenvalues.size > 1:
        eigenvalues = eigenvalues[np.argsort(eigenvalues.real, kind="stable")]
    roots = None
    if stiffness is not None and damping is not None:
        roots = boundary_layer_roots(eigenvalues, stiffness, damping)
    complex_ones = [d for d in eigenvalues.tolist() if abs(d.imag) > eig_tol and d.real > eig_tol]
    crit = max((critical_damping(d) for d in complex_ones), default=None)
    suffix = _notes_suffix(held.indeterminate, held.decoupled, massless, held.notes)
    common: dict[str, Any] = {
        "rows": held.labels, "delassus": spectrum.delassus, "indeterminate_modes": held.indeterminate,
        "massless_eigenvalues": massless, "critical_damping": crit, "boundary_layer_roots": roots,
        "method": spectrum.method, "tolerances": held.tolerances}
    return _verdict(mode, eigenvalues, massless, eig_tol, roots, complex_ones, crit, stiffness, damping,
                    suffix, common)


@dataclass(frozen=True)
class _Held:
    """A solution's held rows and D's spectrum on them."""

    spectrum: _Spectrum
    eigenvalue_tolerance: float  # [1/kg]
    labels: tuple[str, ...]
    notes: list[str]
    indeterminate: int
    decoupled: int
    tolerances: dict[str, float]


def _held_spectrum(problem: ContactProblem, solution: RigidSolution, state: _StateTerms | None
                   ) -> _Held | Stability:
    """D's spectrum on the solution's held rows, or the verdict itself where it needs none.

    (No row is held, a change is impending, or the spectrum cannot be found.)
    """
    mode = solution.mode
    tolerances = _solution_tolerances(problem, solution, None if state is None else state.bias_scale)
    rows, cols, labels, impending, notes = _constraint_rows(problem, solution, tolerances["force"],
                                                            tolerances["acceleration"])
    empty = np.zeros(0, dtype=complex)
    if impending is not None:
        return Stability(mode, None, empty, impending + ": not analysable", tuple(labels),
                         tolerances=tolerances)
    if not rows:
        return Stability(mode, True, empty, "no contact is held (every contact separates): no boundary layer",
                         tolerances=tolerances)
    J_r, J_c = np.array(rows), np.array(cols)
    M = np.asarray(problem.mass_matrix, dtype=float)
    m_scale = max(float(np.abs(M).max()), 1e-300) if state is None else state.mass.scale
    j_r_size = _largest_magnitude(J_r)
    j_scale = max(j_r_size, _largest_magnitude(J_c), 1e-300)
    d_scale = j_scale**2 / m_scale
    eig_tol = EIGENVALUE_TOLERANCE * d_scale
    tolerances["eigenvalue"] = eig_tol
    if state is not None and state.mass.factor is not None:
        spectrum, rho = _factored_spectrum(state.mass.factor, J_r, J_c, j_scale, j_r_size)
        indeterminate, decoupled = len(rows) - rho, 0
    else:
        reduced = _reduced_rows(M, J_r, J_c, j_scale)
        indeterminate, decoupled = len(rows) - reduced.rho, problem.n - reduced.M.shape[0]
        spectrum = _spectrum(reduced, m_scale, j_scale, d_scale)
    if spectrum.problem is not None:
        return Stability(mode, None, spectrum.eigenvalues, spectrum.problem, tuple(labels),
                         indeterminate_modes=indeterminate, method=spectrum.method, tolerances=tolerances)
    return _Held(spectrum, eig_tol, tuple(labels), notes, indeterminate, decoupled, tolerances)


def _solution_tolerances(problem: ContactProblem, solution: RigidSolution, bias_scale: float | None = None
                         ) -> dict[str, float]:
    """The absolute tolerances of one solution's analysis.

    Forces [N] relative to its forces and the bias, accelerations relative to its accelerations
    (each scale at least 1). ``bias_scale``: ``max |h|`` [N, N m] if known.
    """
    if bias_scale is None:
        bias_scale = _bias_scale(problem)
    force_scale = max(_scale_of((solution.lambda_n, solution.lambda_t)), bias_scale)
    accel_scale = _scale_of((solution.dv, solution.a_n, solution.a_t))
    return {"force": FORCE_TOLERANCE * force_scale, "acceleration": ACCELERATION_TOLERANCE * accel_scale,
            "rank": RANK_TOLERANCE, "finite": FINITE_TOLERANCE}


def _notes_suffix(indeterminate: int, decoupled: int, massless: np.ndarray, notes: Sequence[str]) -> str:
    """What the verdict leaves out or assumes, as a suffix of its reason."""
    suffix = ""
    if indeterminate:
        suffix += (f"; statically indeterminate: {indeterminate} internal-force mode(s) (zero eigenvalues "
                   "of D) left out, the verdict is about the motion")
    if decoupled:
        suffix += f"; {decoupled} free massless coordinate(s) left out (no held row involves them)"
    if massless.size:
        suffix += (f"; {massless.size} massless direction(s) (eigenvalue -> infinity) with leading "
                   f"coefficient(s) {_fmt(massless)}")
    if notes:
        suffix += "; " + "; ".join(notes)
    return suffix


def _verdict(mode: str, eigenvalues: np.ndarray, massless: np.ndarray, eig_tol: float,
             roots: np.ndarray | None, complex_ones: Sequence[complex], crit: float | None,
             stiffness: float | None, damping: float | None, suffix: str, common: dict[str, Any]
             ) -> Stability:
    """Stable, unstable or not analysable, from D's spectrum (and the boundary layer's roots)."""
    negative, zero = _signs(eigenvalues, massless, eig_tol)
    if negative:
        return Stability(mode, False, eigenvalues,
                         f"unstable: D has eigenvalue(s) with negative real part {_fmt(negative)}: the "
                         "boundary layer diverges, the compliant solution leaves this one" + suffix, **common)
    if zero:
        return Stability(mode, None, eigenvalues,
                         f"D has eigenvalue(s) with zero real part {_fmt(zero)}: not analysable" + suffix,
                         **common)
    if roots is not None and stiffness is not None and damping is not None and np.any(roots.real >= 0):
        return Stability(mode, False, eigenvalues,
                         f"unstable for b^2/k = {damping**2 / stiffness:.4g} kg: complex eigenvalues "
                         f"{_fmt(complex_ones)} need b^2/k >= {crit:.4g} kg" + suffix, **common)
    reason = f"stable: every eigenvalue of D has a positive real part {_fmt(eigenvalues)}"
    if complex_ones:
        reason += f" (complex ones need damping b^2/k >= {crit:.4g} kg)"
    return Stability(mode, True, eigenvalues, reason + suffix, **common)


def _signs(eigenvalues: np.ndarray, massless: np.ndarray, eig_tol: float) -> tuple[list[Any], list[Any]]:
    """The eigenvalues of D with a negative real part, and those with a zero one (within ``eig_tol``).

    The first list also holds the massless directions' negative leading coefficients.
    """
    values = eigenvalues.tolist()  # Python's complex numbers: the same values, compared faster
    negative = [d for d in values if d.real < -eig_tol] + [c for c in massless if c.real < 0]
    return negative, [d for d in values if abs(d.real) <= eig_tol]


@dataclass(frozen=True)
class _Rows:
    """The held rows restricted to their row space, without decoupled massless coordinates."""

    M: np.ndarray  # mass matrix of the coupled coordinates
    Jr: np.ndarray  # (rho, n) rows of the held contacts' velocities, in the row space
    Jc: np.ndarray  # (rho, n) their force directions
    J_r: np.ndarray  # the original rows (coupled coordinates)
    J_c: np.ndarray
    rho: int  # rank of the held rows


def _reduced_rows(M: np.ndarray, J_r: np.ndarray, J_c: np.ndarray, j_scale: float) -> _Rows:
    """The held rows on the row space of J_r, without the coordinates they do not couple.

    Dependent rows are internal (indeterminate) forces. A massless coordinate that no held row
    involves (a free massless leg) is decoupled from the boundary layer: it is dropped (its
    acceleration is the rigid model's within-mode ambiguity).
    """
    U, sv, _ = np.linalg.svd(J_r / j_scale)
    rho = int(np.sum(sv > RANK_TOLERANCE * sv[0])) if sv.size else 0
    U = U[:, :rho]
    Jr, Jc = U.T @ J_r, U.T @ J_c
    m_abs = float(np.abs(M).max())
    # a coordinate is coupled when its row of M, or its column of Jr or Jc, has an entry above the
    # tolerance (the largest entry of each, at once)
    held = ((np.abs(M).max(axis=1, initial=0.0) > RANK_TOLERANCE * m_abs)
            | (np.abs(Jr).max(axis=0, initial=0.0) > RANK_TOLERANCE * j_scale)
            | (np.abs(Jc).max(axis=0, initial=0.0) > RANK_TOLERANCE * j_scale))
    coupled = np.flatnonzero(held).tolist()
    if len(coupled) < M.shape[0]:
        return _Rows(M[np.ix_(coupled, coupled)], Jr[:, coupled], Jc[:, coupled], J_r[:, coupled],
                     J_c[:, coupled], rho)
    return _Rows(M, Jr, Jc, J_r, J_c, rho)


@dataclass(frozen=True)
class _Spectrum:
    method: SpectrumMethod
    eigenvalues: np.ndarray  # D's finite eigenvalues
    massless: np.ndarray  # leading coefficients of the infinite ones (massless directions)
    delassus: np.ndarray | None
    problem: str | None = None  # why it is not analysable


def _spectrum(rows: _Rows, m_scale: float, j_scale: float, d_scale: float) -> _Spectrum:
    """The eigenvalues of D = J_r M^-1 J_c^T on the row space.

    By Cholesky when M is positive definite, else as the generalised eigenvalues of the pencil
    (M, J_r, J_c), with the leading coefficients of the infinite ones (massless directions).
    """
    M, Jr, Jc, rho = rows.M, rows.Jr, rows.Jc, rows.rho
    n = M.shape[0]
    m_eig, m_vec = np.linalg.eigh(M)
    if m_eig[0] > RANK_TOLERANCE * m_eig[-1]:
        factor = cholesky_upper(M)
        eigenvalues = np.linalg.eigvals(Jr @ cholesky_solve(factor, Jc.T))
        return _Spectrum("cholesky", eigenvalues, np.zeros(0), rows.J_r @ cholesky_solve(factor, rows.J_c.T))
    A = np.block([[M / m_scale, -Jc.T / j_scale], [Jr / j_scale, np.zeros((rho, rho))]])
    B = np.zeros_like(A)
    B[n:, n:] = np.eye(rho)
    (alpha, beta) = scipy.linalg.eig(A, B, right=False, homogeneous_eigvals=True)
    if np.any((np.abs(alpha) <= FINITE_TOLERANCE) & (np.abs(beta) <= FINITE_TOLERANCE)):
        return _Spectrum("pencil", np.zeros(0, dtype=complex), np.zeros(0), None,
                         "the pencil (M, J_r, J_c) is singular: the mode's constraints do not determine "
                         "the massless coordinates: not analysable")
    finite = np.abs(beta) > FINITE_TOLERANCE * np.abs(alpha)
    eigenvalues = alpha[finite] / beta[finite] * d_scale
    infinite_count = rho - int(np.sum(finite))
    if not infinite_count:
        return _Spectrum("pencil", eigenvalues, np.zeros(0), None)
    N = m_vec[:, m_eig <= RANK_TOLERANCE * m_eig[-1]]
    lead = np.linalg.eigvals(Jr @ N @ N.T @ Jc.T)
    lead = lead[np.abs(lead) > RANK_TOLERANCE * max(1.0, float(np.max(np.abs(lead), initial=0.0)))]
    if lead.size != infinite_count:
        return _Spectrum("pencil", np.sort_complex(eigenvalues), np.zeros(0), None,
                         f"{infinite_count} eigenvalue(s) of D are infinite (massless directions) but their "
                         f"limit has {lead.size} nonzero coefficient(s): not analysable")
    return _Spectrum("pencil", eigenvalues, lead, None)


def _scale_of(arrays: Sequence[np.ndarray]) -> float:
    """``max(1.0, *(_largest_magnitude(a) for a in arrays))``, as Python's ``max`` has it.

    An array with a NaN (its largest magnitude is NaN) is passed over, as ``max`` passes over a NaN
    after its first argument. Without a NaN, the largest magnitude of them all, in one pass.
    """
    sizes = list(map(abs, [x for values in arrays for x in values.ravel().tolist()]))
    total = sum(sizes)
    if total == total:
        return max(1.0, max(sizes, default=0.0))
    scale = 1.0
    for values in arrays:
        largest = _largest_magnitude(values)
        if largest > scale:
            scale = largest
    return scale


def _largest_magnitude(values: np.ndarray) -> float:
    """``float(np.abs(values).max(initial=0.0))``: the largest magnitude, 0 for none, NaN if one is NaN.

    By Python's built-ins over the entries (a few here): the same number without NumPy's cost per
    call. (The sum of the magnitudes is NaN exactly when one is.)
    """
    sizes = list(map(abs, values.ravel().tolist()))
    total = sum(sizes)
    if total != total:
        return total
    return max(sizes, default=0.0)


def _fmt(values: Sequence[complex] | np.ndarray) -> str:
    out = []
    for x in values:
        x = complex(x)
        real = abs(x.imag) <= 1e-12 * max(1.0, abs(x.real))
        out.append(f"{x.real:.4g}" if real else f"{x.real:.4g}{x.imag:+.4g}j")
    return "[" + ", ".join(out) + "]"


def classify_solutions(problem: ContactProblem, solutions: Sequence[RigidSolution], *,
                       stiffness: float | None = None, damping: float | None = None) -> list[Stability]:
    """:func:`stability_of` for each solution (e.g. every solution at one input), the same to the bit.

    What depends on the state alone is found once: the bias's scale, and M's eigenvalues and
    Cholesky factor (kept for the last :data:`MASS_FACTORS_KEPT` mass matrices). A mode that holds
    one row (one sliding contact's normal) needs no SVD and no eigenvalue call: D is 1 x 1.

    Raises:
        InputError: as :func:`stability_of`.
    """
    state = _state_terms(problem)
    return [_stability(problem, s, stiffness, damping, state) for s in solutions]


@dataclass(frozen=True)
class _MassTerms:
    """What the verdicts read of M alone."""

    scale: float  # max(max |M|, 1e-300) [kg, kg m, kg m^2]
    # M's Cholesky factor where _spectrum would take its Cholesky branch whatever the rows (every
    # coordinate has an entry of M above the rank tolerance, and M passes the eigenvalue test);
    # None: the reference path decides
    factor: np.ndarray | None


@dataclass(frozen=True)
class _StateTerms:
    """What the verdicts of one problem's solutions share."""

    mass: _MassTerms
    bias_scale: float  # max |h| [N, N m]


_MASS_TERMS: dict[tuple[tuple[int, ...], bytes], _MassTerms] = {}


def stable_verdicts(problem: ContactProblem, solutions: Sequence[RigidSolution]) -> list[bool | None]:
    """``stability_of(problem, s).stable`` for each solution, without the reasons' words.

    :func:`classify_solutions`'s path up to D's spectrum, then only the signs of its eigenvalues:
    true (stable), false (unstable) or None (not analysable), as :class:`Stability` has them (with no
    stiffness and damping given). Where M has a Cholesky factor and a solution holds at most two
    rows, the kernel's ``held_verdict`` decides it in one call (the same checks and tolerances, D's
    eigenvalues in closed form; it leaves the solutions within :data:`VERDICT_ROUND_OFF_BAND` of a
    tolerance to this path).

    Raises:
        InputError: as :func:`stability_of`.
    """
    state = _state_terms(problem)
    decide = backend().held_verdict
    verdicts: list[bool | None] = []
    for solution in solutions:
        verdict = decide(problem, solution, state)
        if verdict is not _DECLINED:
            verdicts.append(verdict)
            continue
        check_mode(problem, solution.mode)
        held = _held_spectrum(problem, solution, state)
        if isinstance(held, Stability):
            verdicts.append(held.stable)
            continue
        negative, zero = _signs(np.asarray(held.spectrum.eigenvalues, dtype=complex), held.spectrum.massless,
                                held.eigenvalue_tolerance)
        verdicts.append(False if negative else None if zero else True)
    return verdicts


_DECLINED = object()
"""``held_verdict``'s answer where it leaves the solution to :func:`stable_verdicts`' own path."""

_held_verdict_extension = extension_function("held_verdict")

_VERDICTS: dict[int, bool | None | object] = {0: False, 1: True, -1: None, 2: _DECLINED}
"""The compiled kernel's verdict codes (``VERDICT_UNSTABLE``, ``_STABLE``, ``_NONE``, ``_DECLINED``)."""


def _held_verdict_numpy(problem: ContactProblem, solution: RigidSolution, state: _StateTerms) -> Any:
    """The NumPy twin of ``held_verdict``: it declines.

    :func:`stable_verdicts`' own path, the reference the compiled call reproduces, then decides.
    """
    return _DECLINED


def _held_verdict_compiled(problem: ContactProblem, solution: RigidSolution, state: _StateTerms) -> Any:
    """One solution's verdict by the compiled kernel: True, False, None, or :data:`_DECLINED`.

    Declined without M's Cholesky factor, and for arrays the kernel does not take (not float64).
    """
    factor = state.mass.factor
    if factor is None:
        return _DECLINED
    try:
        code = _held_verdict_extension(
            factor, problem.jacobian_normal, problem.jacobian_tangent, problem.mu, problem.normal_velocities,
            problem.tangential_velocities, solution.mode, solution.lambda_n, solution.lambda_t, solution.a_n,
            solution.a_t, solution.dv, problem.velocity_tolerance, state.mass.scale, state.bias_scale,
            FORCE_TOLERANCE, ACCELERATION_TOLERANCE, EIGENVALUE_TOLERANCE, RANK_TOLERANCE,
            *UNSCALED_EIGENVALUE_RANGE, VERDICT_ROUND_OFF_BAND, VERDICT_RANK_SEPARATION)
    except KernelError:  # arrays of another type or shape: the reference path reads (or refuses) them
        return _DECLINED
    return _VERDICTS[code]


twin("held_verdict", numpy=_held_verdict_numpy, compiled=_held_verdict_compiled)


def _state_terms(problem: ContactProblem) -> _StateTerms:
    """M's terms and the bias's scale, kept in the problem's state cache (found once per state)."""
    cache = problem.state_cache
    terms = cache.get("stability")
    if terms is None:
        terms = cache["stability"] = _found_state_terms(problem)
    return terms


def _found_state_terms(problem: ContactProblem) -> _StateTerms:
    M = np.asarray(problem.mass_matrix, dtype=float)
    key = (M.shape, M.tobytes())
    mass = _MASS_TERMS.get(key)
    if mass is None:
        if len(_MASS_TERMS) >= MASS_FACTORS_KEPT:
            _MASS_TERMS.clear()
        mass = _MASS_TERMS[key] = _mass_terms(M)
    return _StateTerms(mass, _bias_scale(problem))


def _mass_terms(M: np.ndarray) -> _MassTerms:
    """M's scale, and its Cholesky factor when every held-row set would be factored (as _spectrum)."""
    m_abs = float(np.abs(M).max(initial=0.0))
    factor = None
    # _reduced_rows keeps every coordinate when each row of M has an entry above this; _spectrum
    # then tests and factors M itself (eigh with vectors: the same call, so the same eigenvalues)
    if M.size and bool(np.all(np.abs(M).max(axis=1) > RANK_TOLERANCE * m_abs)):
        m_eig, _ = np.linalg.eigh(M)
        if m_eig[0] > RANK_TOLERANCE * m_eig[-1]:
            try:
                factor = cholesky_upper(M)
            except np.linalg.LinAlgError:
                factor = None  # the reference path meets the same failure
    return _MassTerms(max(m_abs, 1e-300), factor)


def _bias_scale(problem: ContactProblem) -> float:
    """``max |h|`` [N, N m] (0 without coordinates)."""
    return _largest_magnitude(problem.bias)


def _factored_spectrum(factor: np.ndarray, J_r: np.ndarray, J_c: np.ndarray, j_scale: float,
                       j_r_size: float) -> tuple[_Spectrum, int]:
    """_spectrum's Cholesky branch on M's ``factor``, and the rank of J_r (``j_r_size``: max |J_r|).

    One row of J_r that is not zero has rank 1 and U = [+-1] (the SVD's): D = J_r X and its
    eigenvalue are then D itself (the sign cancels exactly), unless D is 0 (its sign could differ)
    or outside :data:`UNSCALED_EIGENVALUE_RANGE`.
    """
    if J_r.shape[0] == 1 and j_r_size > RANK_TOLERANCE * j_scale:
        delassus = J_r @ cholesky_solve(factor, J_c.T)
        d = abs(float(delassus[0, 0]))
        if UNSCALED_EIGENVALUE_RANGE[0] < d < UNSCALED_EIGENVALUE_RANGE[1]:
            return _Spectrum("cholesky", delassus[0].copy(), np.zeros(0), delassus), 1
    U, sv, _ = np.linalg.svd(J_r / j_scale)
    rho = int(np.sum(sv > RANK_TOLERANCE * sv[0])) if sv.size else 0
    U = U[:, :rho]
    eigenvalues = np.linalg.eigvals((U.T @ J_r) @ cholesky_solve(factor, (U.T @ J_c).T))
    return _Spectrum("cholesky", eigenvalues, np.zeros(0), J_r @ cholesky_solve(factor, J_c.T)), rho


def solution_report(problem: ContactProblem, solution: RigidSolution, *, stiffness: float | None = None,
                    damping: float | None = None) -> dict[str, Any]:
    """A rigid solution as JSON values with its stability under compliance (``frc analyze --json``).

    :meth:`RigidSolution.to_dict <frcontrol.engine.RigidSolution.to_dict>` plus ``stable`` and
    ``stability_reason`` from :func:`stability_of`.
    """
    stability = stability_of(problem, solution, stiffness=stiffness, damping=damping)
    stable = None if stability.stable is None else bool(stability.stable)  # None: not analysable
    return {**solution.to_dict(problem.contacts), "stable": stable, "stability_reason": stability.reason}


__all__ = [
    "ACCELERATION_TOLERANCE",
    "EIGENVALUE_TOLERANCE",
    "FINITE_TOLERANCE",
    "FORCE_TOLERANCE",
    "MASS_FACTORS_KEPT",
    "RANK_TOLERANCE",
    "UNSCALED_EIGENVALUE_RANGE",
    "VERDICT_RANK_SEPARATION",
    "VERDICT_ROUND_OFF_BAND",
    "Stability",
    "boundary_layer_roots",
    "classify_solutions",
    "critical_damping",
    "solution_report",
    "stability_of",
    "stable_verdicts",
]
