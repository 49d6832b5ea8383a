r"""Impulse LCPs of the rigid model: the time step's and the instantaneous impact law's.

The Coulomb impulse LCP
-----------------------
Both problems have one shape. Given a velocity ``v_base``, contact rows ``J_N``, ``J_T`` (c
contacts), friction coefficients ``mu`` and a normal offset ``o``, find impulses ``p_N``,
``p_T = p_T^+ - p_T^-`` [N s] and slip-speed multipliers ``sigma`` with
``v+ = v_base + M^-1 (J_N^T p_N + J_T^T p_T)`` and::

    0 <= p_N       _|_  J_N v+ + o                  >= 0
    0 <= p_T^+     _|_  sigma + J_T v+              >= 0
    0 <= p_T^-     _|_  sigma - J_T v+              >= 0
    0 <= sigma     _|_  mu p_N - p_T^+ - p_T^-      >= 0      (cone; slip opposes J_T v+)

an LCP in ``z = (p_N, p_T^+, p_T^-, sigma)`` with the Delassus matrix ``W = J M^-1 J^T``
(Cholesky solves, never an inverse), solved by Lemke's method (:func:`frcontrol.lcp.solve_lcp`),
retried with ``W + eps I`` (:data:`LCP_REGULARIZATION`) and by enumeration when small
(:func:`solve_impulse_lcp`). The time step (:mod:`.rigid`) has ``v_base = v + h M^-1 (S^T u - h)``
and ``o = phi~ / h``.

The impact law
--------------
A contact that closes with a normal velocity ``v_N^- < 0`` takes an instantaneous impulse
(:func:`impact_law`): the momentum balance ``M (v+ - v-) = J_N^T P_N + J_T^T P_T`` over the
touching contacts, Coulomb's law on the impulses (the LCP above with ``v_base = v-``) and Newton's
restitution on the normal velocity, ``o_i = -e_i max(0, -v_N,i^-)``: a contact that takes an
impulse leaves with ``v_N,i^+ = -e_i v_N,i^-``; with ``e = 0`` (the default) the impact is inelastic.

Energy. With ``e = 0`` the kinetic energy never grows::

    T+ - T- = P_N . v_N^+ + P_T . v_T^+ - 1/2 |v+ - v-|_M^2 <= 0

(``P_N . v_N^+ = 0`` by complementarity, ``P_T . v_T^+ <= 0`` by the cone). With ``e > 0`` the
first term is ``sum_i e_i P_N,i |v_N,i^-| >= 0``, and Newton's law with friction can gain energy on
coupled contacts (Kane's and Levinson's example). The law then halves every restitution until the
kinetic energy does not grow (at most :data:`MAX_RESTITUTION_HALVINGS` times, then ``e = 0``) and
reports the coefficients it used: energy never grows through an impact.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import FrcontrolError, InputError
from ..kernel import backend, compiled, twin
from ..lcp import ENUMERATION_MAX_SIZE, solve_lcp
from .armature import solve_mass

LCP_REGULARIZATION = 1e-10
"""[-] When Lemke's method fails, the LCP is retried with ``W + eps I`` (W scaled to unit
diagonal): this eps."""

ENERGY_TOLERANCE = 1e-12
"""[-] An impact "gains energy" when its kinetic energy after exceeds the one before by more than
this times the one before (plus this times 1 J): rounding of the LCP's solution stays below."""

MAX_RESTITUTION_HALVINGS = 20
"""Times the impact law halves the restitution coefficients of an impact that gains energy before
it falls back to the inelastic law (``e = 0``), which never does."""


@dataclass(frozen=True)
class ImpulseSolution:
    """One impulse LCP's answer.

    Attributes:
        velocity: v+ [m/s, rad/s].
        impulse_normal: p_N [N s], per contact of the problem.
        impulse_tangent: p_T [N s], per contact of the problem.
        lcp_size: number of LCP unknowns (0: no contact needed an impulse).
        residual: the LCP solution's residual.
        regularized: whether the regularised LCP or the enumeration gave the answer.
    """

    velocity: np.ndarray
    impulse_normal: np.ndarray
    impulse_tangent: np.ndarray
    lcp_size: int
    residual: float
    regularized: bool


class ImpulseLCPFailure(FrcontrolError):
    """The impulse LCP had no solution by any method (a simulation's result, not raised out)."""


def coulomb_matrix(W: np.ndarray, m_ref: float, mu: np.ndarray) -> np.ndarray:
    """The LCP matrix of the module docstring for the Delassus matrix ``W`` (2c, 2c) times ``m_ref``.

    By the kernel's ``coulomb_matrix`` (:func:`frcontrol.kernel.backend`): the compiled kernel's, or
    its NumPy twin (:func:`_coulomb_matrix` of ``W * m_ref``): the same numbers.
    """
    return backend().coulomb_matrix(W, m_ref, mu)


def _coulomb_matrix_compiled(W: np.ndarray, m_ref: float, mu: np.ndarray) -> np.ndarray:
    """:func:`coulomb_matrix` by the compiled kernel."""
    c = len(mu)
    out = np.empty((4 * c, 4 * c))
    kernel: Any = compiled
    kernel.coulomb_matrix(np.ascontiguousarray(W), float(m_ref), np.ascontiguousarray(mu), out)
    return out


def _coulomb_matrix_numpy(W: np.ndarray, m_ref: float, mu: np.ndarray) -> np.ndarray:
    """:func:`coulomb_matrix` in NumPy (the reference twin)."""
    return _coulomb_matrix(W * m_ref, mu)


def _coulomb_matrix(Ws: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """The LCP matrix of the module docstring for a scaled Delassus matrix ``Ws`` (2c, 2c)."""
    c = len(mu)
    W_nn, W_nt, W_tn, W_tt = Ws[:c, :c], Ws[:c, c:], Ws[c:, :c], Ws[c:, c:]
    base = np.zeros((4 * c, 4 * c))
    n, p, m = slice(0, c), slice(c, 2 * c), slice(2 * c, 3 * c)
    base[n, n], base[n, p], base[n, m] = W_nn, W_nt, -W_nt
    base[p, n], base[p, p], base[p, m] = W_tn, W_tt, -W_tt
    base[m, n], base[m, p], base[m, m] = -W_tn, -W_tt, W_tt
    d = np.arange(c)
    base[c + d, 3 * c + d] = base[2 * c + d, 3 * c + d] = 1.0
    base[3 * c + d, d] = mu
    base[3 * c + d, c + d] = base[3 * c + d, 2 * c + d] = -1.0
    return base


twin("coulomb_matrix", numpy=_coulomb_matrix_numpy, compiled=_coulomb_matrix_compiled)


def solve_impulse_lcp(
    factor: tuple[np.ndarray, bool],
    v_base: np.ndarray,
    jn: np.ndarray,
    jt: np.ndarray,
    normal_offset: np.ndarray,
    mu: np.ndarray,
    method: str = "lemke",
) -> ImpulseSolution:
    """Solve the Coulomb impulse LCP of the module docstring.

    Args:
        factor: Cholesky factor of M (``scipy.linalg.cho_factor``).
        v_base: the velocity without contact impulses.
        jn: normal rows (c, n).
        jt: tangential rows (c, n).
        normal_offset: o (c,) [m/s]: ``J_N v+ + o >= 0``.
        mu: friction coefficients (c,).
        method: ``"lemke"`` or ``"enumerate"``.

    Raises:
        ImpulseLCPFailure: no method found a solution.
    """
    c = jn.shape[0]
    jac = np.concatenate((jn, jt))
    X = solve_mass(factor, jac.T)  # M^-1 J^T, (n, 2c)
    W = jac @ X
    scale = float(W.diagonal().max()) if c else 0.0
    m_ref = 1.0 / scale if scale > 0 else 1.0  # impulses in units of m_ref [kg] x [m/s]
    b_n = jn @ v_base + normal_offset
    b_t = jt @ v_base
    if (b_n >= 0.0).all():  # every contact separates or just touches: z = 0, sigma = |b_t|
        return ImpulseSolution(v_base.copy(), np.zeros(c), np.zeros(c), 0, 0.0, False)
    base = coulomb_matrix(W, m_ref, np.asarray(mu, dtype=float))
    diagonal = np.arange(3 * c)

    def lcp_matrix(eps: float) -> np.ndarray:
        if eps == 0.0:
            return base
        out = base.copy()
        out[diagonal, diagonal] += eps
        return out

    q_lcp = np.concatenate((b_n, b_t, -b_t, np.zeros(c)))
    attempts = [(method, 0.0)]
    if method == "lemke":
        attempts.append(("lemke", LCP_REGULARIZATION))
    if 4 * c <= ENUMERATION_MAX_SIZE and method != "enumerate":
        attempts.append(("enumerate", 0.0))
    statuses = []
    for how, eps in attempts:
        result = solve_lcp(lcp_matrix(eps), q_lcp, method=how)
        if result.found and result.z is not None:
            z = result.z
            p_n = m_ref * z[:c]
            p_t = m_ref * (z[c:2 * c] - z[2 * c:3 * c])
            v_next = v_base + X @ np.concatenate((p_n, p_t))
            return ImpulseSolution(v_next, p_n, p_t, 4 * c, float(result.residual),
                                   eps > 0 or how != method)
        statuses.append(f"{how}{' (regularised)' if eps else ''}: {result.status}")
    raise ImpulseLCPFailure(f"the impulse LCP ({4 * c} unknowns) has no solution: {'; '.join(statuses)}")


@dataclass(frozen=True)
class Impact:
    """The impact law's answer (arrays over the contacts it was given).

    Attributes:
        velocity: v+ [m/s, rad/s] after the impact.
        impulse_normal: P_N [N s]; impulse_tangent: P_T [N s].
        normal_velocity_before: J_N v- [m/s]; normal_velocity_after: J_N v+ [m/s].
        tangential_velocity_before: J_T v- [m/s]; tangential_velocity_after: J_T v+ [m/s].
        kinetic_energy_before: 1/2 v-^T M v- [J]; kinetic_energy_after: 1/2 v+^T M v+ [J].
        restitution: the coefficients e [-] used (the given ones, halved if energy would grow).
        lcp_size: LCP unknowns; residual: the LCP's residual.
    """

    velocity: np.ndarray
    impulse_normal: np.ndarray
    impulse_tangent: np.ndarray
    normal_velocity_before: np.ndarray
    normal_velocity_after: np.ndarray
    tangential_velocity_before: np.ndarray
    tangential_velocity_after: np.ndarray
    kinetic_energy_before: float
    kinetic_energy_after: float
    restitution: np.ndarray
    lcp_size: int
    residual: float


def _check_restitution(restitution: Sequence[float] | np.ndarray, c: int) -> np.ndarray:
    e = np.asarray(restitution, dtype=float).reshape(-1)
    if e.shape != (c,) or not np.all(np.isfinite(e)) or np.any(e < 0) or np.any(e > 1):
        raise InputError(f"restitution needs {c} coefficients in [0, 1], got {e.tolist()}")
    return e


def impact_law(
    mass: np.ndarray,
    factor: tuple[np.ndarray, bool],
    v: np.ndarray,
    jn: np.ndarray,
    jt: np.ndarray,
    mu: Sequence[float] | np.ndarray,
    restitution: Sequence[float] | np.ndarray,
    method: str = "lemke",
) -> Impact:
    """The instantaneous impact of the module docstring: Coulomb friction, Newton restitution.

    Args:
        mass: M (n, n) [kg, kg m^2], positive definite.
        factor: its Cholesky factor (``scipy.linalg.cho_factor``).
        v: v- [m/s, rad/s], the velocity before.
        jn: the touching contacts' normal rows (c, n).
        jt: their tangential rows (c, n).
        mu: friction coefficients [-] (c,).
        restitution: Newton's coefficients e [-] in [0, 1] (c,).
        method: the LCP method, ``"lemke"`` or ``"enumerate"``.

    Returns:
        The impact; its kinetic energy after is at most the one before (up to
        :data:`ENERGY_TOLERANCE`).

    Raises:
        InputError: restitution of the wrong length or outside [0, 1].
        ImpulseLCPFailure: the LCP has no solution by any method.
    """
    c = jn.shape[0]
    e = _check_restitution(restitution, c)
    mu_arr = np.asarray(mu, dtype=float).reshape(-1)
    vn, vt = jn @ v, jt @ v
    before = 0.5 * float(v @ mass @ v)
    allowed = before + ENERGY_TOLERANCE * (before + 1.0)
    for halving in range(MAX_RESTITUTION_HALVINGS + 1):
        if halving == MAX_RESTITUTION_HALVINGS:
            e = np.zeros(c)
        sol = solve_impulse_lcp(factor, v, jn, jt, -e * np.maximum(0.0, -vn), mu_arr, method)
        after = 0.5 * float(sol.velocity @ mass @ sol.velocity)
        if after <= allowed or not np.any(e > 0):
            break
        e = 0.5 * e
    return Impact(sol.velocity, sol.impulse_normal, sol.impulse_tangent, vn, jn @ sol.velocity, vt,
                  jt @ sol.velocity, before, after, e, sol.lcp_size, sol.residual)


__all__ = [
    "ENERGY_TOLERANCE",
    "LCP_REGULARIZATION",
    "MAX_RESTITUTION_HALVINGS",
    "Impact",
    "ImpulseLCPFailure",
    "ImpulseSolution",
    "impact_law",
    "solve_impulse_lcp",
]
