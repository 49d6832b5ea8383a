"""The acceleration-level contact problem as a linear complementarity problem.

The maths: docs/maths.md, *The contact problem as an LCP*.

Independent of the mode enumeration, this formulates the same rigid-body problem at one input as
``w = W z + b >= 0, z >= 0, z^T w = 0`` and solves it with :mod:`frcontrol.lcp` (Lemke's method, or
the enumeration of every solution). It needs a positive-definite mass matrix (the forces are
mapped to accelerations by ``dv = M^-1 (S^T u - h + J^T lam)``, computed with a Cholesky
factorisation, never an explicit inverse); with massless links use the mode enumeration.

Per active contact with ``v_N = 0``:

- if ``v_T = 0`` (it may stick), the unknowns are ``z = (lam_N, lam_T+, lam_T-, beta)`` with
  ``lam_T = lam_T+ - lam_T-`` and the complementary slacks
  ``(a_N, beta + a_T, beta - a_T, mu lam_N - lam_T+ - lam_T-)``;
- if ``v_T != 0`` (it slides), ``lam_T = -sign(v_T) mu lam_N`` and only ``lam_N`` ⟂ ``a_N``.

A contact with ``v_N > 0`` separates: it carries no force and takes no part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .errors import IllConditioned, InputError
from .lcp import LCPSolution, enumerate_lcp_solutions, solve_lcp
from .modes import ContactProblem, contact_mode_letter, mode_outputs

MASS_CHOLESKY_TOLERANCE = 1e-8
"""The LCP form needs M positive definite and well conditioned: its smallest eigenvalue over its
largest must exceed this, else :class:`~frcontrol.errors.IllConditioned` is raised (use the mode
enumeration, which never inverts M). At 1e-12 a leg of 1e-9 of the body's mass passed and the
Delassus matrix lost 11 digits (a wrong mode at some inputs); 1e-8 matches the engine's
ill-conditioned band."""

CLASSIFY_TOLERANCE = 1e-7
"""[N or m/s^2] A force or contact acceleration at most this in magnitude counts as zero when an
LCP solution is named by its mode."""

SAME_SOLUTION_TOLERANCE = 1e-8
"""[-] Two enumerated LCP solutions whose ``x = (dv, lambda)`` differ by at most this times
``max(1, ||x||_inf)``, plus their cancellation round-off (:data:`CANCELLATION_ROUNDOFF`), are one
physical solution (listed once by :func:`all_contact_lcp_solutions`)."""

CANCELLATION_ROUNDOFF = 1e-13
"""[-] Relative round-off of a cancelling friction split. An LCP solution may carry friction
``lam_T = lam_T+ - lam_T-`` with both parts positive (then ``beta = a_T = 0``: it sticks, and the
split is not unique). Up to ``lam_T+ + lam_T- = mu lam_N`` (at mu = 1e8, 1e9 N for a 9 N load), so
``lam_T`` and ``x`` carry an absolute error of about ``eps * cond * min(lam_T+, lam_T-)``; this
factor (about 500 machine epsilons) times the cancelled part bounds that error when two solutions
are compared, and the solution with the smaller cancellation is the one kept."""


@dataclass(frozen=True)
class ContactLCP:
    """The LCP of a contact problem at one input, and how to read its solutions back.

    Attributes:
        W: (N, N) LCP matrix; b: (N,) LCP vector.
        sticking: indices of the contacts that may stick (v_T = 0, v_N = 0).
        sliding: indices of the sliding contacts, with ``sign`` their v_T signs.
        separating: indices of contacts with v_N > 0.
    """

    problem: ContactProblem
    u: np.ndarray
    W: np.ndarray
    b: np.ndarray
    sticking: np.ndarray
    sliding: np.ndarray
    sign: np.ndarray
    separating: np.ndarray
    factor: tuple[np.ndarray, bool]

    def unknowns_from(self, z: np.ndarray) -> np.ndarray:
        """``x = (dv, lam_N, lam_T)`` from an LCP solution z."""
        p = self.problem
        k = p.k
        normal = np.concatenate([self.sticking, self.sliding])
        ns = len(self.sticking)
        nn = len(normal)
        lam_n = np.zeros(k)
        lam_t = np.zeros(k)
        lam_n[normal] = z[:nn]
        lam_t[self.sticking] = z[nn:nn + ns] - z[nn + ns:nn + 2 * ns]
        mu = p.mu
        lam_t[self.sliding] = -self.sign * mu[self.sliding] * lam_n[self.sliding]
        force = p.input_map @ self.u - p.bias + p.jacobian_normal.T @ lam_n + p.jacobian_tangent.T @ lam_t
        dv = scipy.linalg.cho_solve(self.factor, force)
        return np.concatenate([dv, lam_n, lam_t])

    def cancelled(self, z: np.ndarray) -> float:
        """[N] The largest friction that cancels in a sticking contact's split: ``min(lam_T+, lam_T-)``.

        Zero for a canonical solution; see :data:`CANCELLATION_ROUNDOFF`.
        """
        nn, ns = len(self.sticking) + len(self.sliding), len(self.sticking)
        if ns == 0:
            return 0.0
        return float(np.max(np.minimum(z[nn:nn + ns], z[nn + ns:nn + 2 * ns]).clip(min=0.0)))


def build_contact_lcp(problem: ContactProblem, u: np.ndarray) -> ContactLCP:
    """Assemble the LCP at input ``u``.

    Raises:
        IllConditioned: M is not numerically positive definite (e.g. massless links).
        ImpactState: a contact moves into its surface.
    """
    u = np.asarray(u, dtype=float).reshape(-1)
    if u.shape != (problem.m,):
        raise InputError(f"expected {problem.m} inputs, got {u.size}")
    M = problem.mass_matrix
    eig = np.linalg.eigvalsh(M)
    if eig[0] <= MASS_CHOLESKY_TOLERANCE * max(eig[-1], 1e-300):
        raise IllConditioned("the mass matrix (the LCP form needs it positive definite)",
                             eig[-1] / max(eig[0], 1e-300), MASS_CHOLESKY_TOLERANCE)
    factor = scipy.linalg.cho_factor(M)
    allowed = problem.allowed_modes()  # raises ImpactState
    sticking = np.array([i for i, a in enumerate(allowed) if a == "SLRF"], dtype=int)
    sliding = np.array([i for i, a in enumerate(allowed) if a in ("SR", "SL")], dtype=int)
    sign = np.array([1.0 if allowed[i] == "SR" else -1.0 for i in sliding])
    separating = np.array([i for i, a in enumerate(allowed) if a == "S"], dtype=int)
    jn, jt, mu = problem.jacobian_normal, problem.jacobian_tangent, problem.mu
    normal = np.concatenate([sticking, sliding])
    # generalized force of a unit normal force, including the sliding friction it drags along
    normal_cols = jn[normal].T.copy()
    if sliding.size:
        normal_cols[:, len(sticking):] -= (jt[sliding] * (sign * mu[sliding])[:, None]).T
    tangent_cols = jt[sticking].T
    K_n = scipy.linalg.cho_solve(factor, normal_cols)
    K_t = scipy.linalg.cho_solve(factor, tangent_cols)
    K_f = scipy.linalg.cho_solve(factor, problem.input_map @ u - problem.bias)
    nn, ns = len(normal), len(sticking)
    size = nn + 3 * ns
    W = np.zeros((size, size))
    b = np.zeros(size)
    JN, JT = jn[normal], jt[sticking]
    # a_N rows
    W[:nn, :nn] = JN @ K_n
    W[:nn, nn:nn + ns] = JN @ K_t
    W[:nn, nn + ns:nn + 2 * ns] = -JN @ K_t
    b[:nn] = JN @ K_f + problem.drift_normal[normal]
    # beta + a_T and beta - a_T rows
    a_t_n, a_t_t, a_t_0 = JT @ K_n, JT @ K_t, JT @ K_f + problem.drift_tangent[sticking]
    beta = nn + 2 * ns
    rows_p = slice(nn, nn + ns)
    rows_m = slice(nn + ns, nn + 2 * ns)
    W[rows_p, :nn] = a_t_n
    W[rows_p, nn:nn + ns] = a_t_t
    W[rows_p, nn + ns:nn + 2 * ns] = -a_t_t
    W[rows_p, beta:] = np.eye(ns)
    b[rows_p] = a_t_0
    W[rows_m, :nn] = -a_t_n
    W[rows_m, nn:nn + ns] = -a_t_t
    W[rows_m, nn + ns:nn + 2 * ns] = a_t_t
    W[rows_m, beta:] = np.eye(ns)
    b[rows_m] = -a_t_0
    # friction cone slack: mu lam_N - lam_T+ - lam_T-
    W[beta:, :ns] = np.diag(mu[sticking])
    W[beta:, nn:nn + ns] = -np.eye(ns)
    W[beta:, nn + ns:nn + 2 * ns] = -np.eye(ns)
    return ContactLCP(problem, u, W, b, sticking, sliding, sign, separating, factor)


def classify(problem: ContactProblem, x: np.ndarray, *, tolerance: float = CLASSIFY_TOLERANCE) -> str:
    """The mode letters of a solution ``x = (dv, lam_N, lam_T)`` (S when lam_N is zero)."""
    out = mode_outputs(problem, x)
    return "".join(
        contact_mode_letter(out["lambda_n"][i], problem.tangential_velocities[i], tolerance,
                            problem.velocity_tolerance, out["a_t"][i], tolerance)
        for i in range(problem.k))


@dataclass(frozen=True)
class LCPContactSolution:
    """A solution of the contact LCP, read back as accelerations and forces."""

    mode: str
    x: np.ndarray
    lcp: LCPSolution


def solve_contact_lcp(
    problem: ContactProblem, u: np.ndarray, method: str = "lemke"
) -> LCPContactSolution | LCPSolution:
    """One solution by Lemke's method (or the first of the enumeration).

    Returns the read-back solution, or the raw :class:`~frcontrol.lcp.LCPSolution` when none was
    found (``status`` says why: ``"ray"``, ``"infeasible"``...).
    """
    lcp = build_contact_lcp(problem, u)
    result = solve_lcp(lcp.W, lcp.b, method=method)
    if not result.found or result.z is None:
        return result
    x = lcp.unknowns_from(result.z)
    return LCPContactSolution(classify(problem, x), x, result)


def all_contact_lcp_solutions(problem: ContactProblem, u: np.ndarray) -> list[LCPContactSolution]:
    """Every solution of the contact LCP (exhaustive enumeration of complementary supports).

    Each physical solution ``x = (dv, lambda)`` is listed once: two LCP solutions ``z`` may differ
    only in variables that do not reach ``x`` (a sticking contact's friction split and its
    multiplier), and those within :data:`SAME_SOLUTION_TOLERANCE` of one already listed (relative
    to ``max(1, ||x||_inf)``) are dropped.
    """
    lcp = build_contact_lcp(problem, u)
    found = []
    for sol in enumerate_lcp_solutions(lcp.W, lcp.b):
        if sol.z is None:  # pragma: no cover - enumerated solutions are found ones
            continue
        x = lcp.unknowns_from(sol.z)
        found.append((lcp.cancelled(sol.z), x, sol))
    found.sort(key=lambda item: item[0])  # stable: the most precise representative first
    out: list[LCPContactSolution] = []
    kept_cancelled: list[float] = []
    for cancelled, x, sol in found:
        scale = SAME_SOLUTION_TOLERANCE * max(1.0, float(np.max(np.abs(x))) if x.size else 0.0)
        if any(float(np.max(np.abs(x - kept.x), initial=0.0))
               <= scale + CANCELLATION_ROUNDOFF * (cancelled + other)
               for kept, other in zip(out, kept_cancelled, strict=True)):
            continue
        out.append(LCPContactSolution(classify(problem, x), x, sol))
        kept_cancelled.append(cancelled)
    return out


__all__ = [
    "all_contact_lcp_solutions",
    "build_contact_lcp",
    "CANCELLATION_ROUNDOFF",
    "classify",
    "CLASSIFY_TOLERANCE",
    "ContactLCP",
    "LCPContactSolution",
    "MASS_CHOLESKY_TOLERANCE",
    "SAME_SOLUTION_TOLERANCE",
    "solve_contact_lcp",
]
