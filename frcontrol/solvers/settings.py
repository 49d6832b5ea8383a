"""The solver settings: which back-end solves the LPs and the QPs, with which options and tolerance.

One frozen object travels from the public functions (``analyze``, the polytope and statics
functions, ...) down to the door (:func:`frcontrol.solvers.solve_lp`) instead of a back-end name
per signature. A public function that takes ``solver=`` (a back-end name, as the CLI and the
planners pass it) turns it into settings with :func:`settings_from`, the one conversion.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from frcontrol.errors import InputError

__all__ = [
    "DEFAULT_LP_SOLVER",
    "DEFAULT_SETTINGS",
    "FEASIBILITY_TOLERANCE",
    "LP_SOLVER_ENVIRONMENT_VARIABLE",
    "SolverSettings",
    "settings_from",
]

LP_SOLVER_ENVIRONMENT_VARIABLE = "FRC_LP_SOLVER"
"""Name of the environment variable that, when set, replaces :data:`DEFAULT_LP_SOLVER` for the whole
process (read once, at import): ``FRC_LP_SOLVER=highs frc analyze rhex_flip`` runs every default
LP on HiGHS. An unknown name raises :class:`~frcontrol.errors.SolverNotFound` at the first LP."""

DEFAULT_LP_SOLVER = os.environ.get(LP_SOLVER_ENVIRONMENT_VARIABLE, "").strip().lower() or "daqp"
"""Back-end used when none is named: DAQP, the fastest on small dense LPs, with no failure
measured; or the value of :data:`LP_SOLVER_ENVIRONMENT_VARIABLE` when it is set."""

FEASIBILITY_TOLERANCE = 1e-6
r"""Largest accepted primal residual of an "optimal" answer, relative to the size of the terms.

The answer ``x`` is accepted when ``primal_residual <= FEASIBILITY_TOLERANCE * scale`` with
:math:`\text{scale} = 1 + \max_i |r_i| + (\max_i \|a^{ub}_i\|_1 + \max_j \|a^{eq}_j\|_1)
\|x\|_\infty` over the finite right-hand sides ``r`` (``b_ub``, ``b_eq``, ``lb``, ``ub``) and
the constraint rows (the size of the terms of :math:`a^\top x - r`).
Default ``1e-6``, DAQP's own primal tolerance; :attr:`SolverSettings.feasibility_tolerance`
replaces it per call. The value used is reported on every result (``residual_tolerance``).
"""

_NO_OPTIONS: Mapping[str, Mapping[str, Any]] = MappingProxyType({})


@dataclass(frozen=True)
class SolverSettings:
    """Which back-ends solve, with which options and which residual tolerance (frozen).

    Attributes:
        lp: the LP back-end (see :func:`frcontrol.solvers.available_solvers`).
        qp: the QP back-end.
        feasibility_tolerance: the door's relative residual tolerance (see
            :data:`FEASIBILITY_TOLERANCE`) [dimensionless].
        options: per back-end name, its options (passed on verbatim, e.g. DAQP's
            ``primal_tol``); a back-end not named runs with its defaults. Read-only.
    """

    lp: str = DEFAULT_LP_SOLVER
    qp: str = DEFAULT_LP_SOLVER
    feasibility_tolerance: float = FEASIBILITY_TOLERANCE
    options: Mapping[str, Mapping[str, Any]] = field(default_factory=lambda: _NO_OPTIONS, hash=False)

    def __post_init__(self) -> None:
        for name in ("lp", "qp"):
            value = getattr(self, name)
            if not isinstance(value, str) or not value:
                raise InputError(f"SolverSettings.{name} must be a back-end name, got {value!r}")
        tolerance = self.feasibility_tolerance
        if not isinstance(tolerance, (int, float)) or not 0.0 < float(tolerance) < 1.0:
            raise InputError(f"SolverSettings.feasibility_tolerance must be in (0, 1), got {tolerance!r}")
        frozen = {str(name): MappingProxyType(dict(opts)) for name, opts in dict(self.options).items()}
        object.__setattr__(self, "options", MappingProxyType(frozen) if frozen else _NO_OPTIONS)

    def options_for(self, solver: str) -> dict[str, Any]:
        """The options of back-end ``solver`` (a new dict; empty when none are set)."""
        return dict(self.options.get(solver, {}))

    def with_options(self, solver: str, **options: Any) -> SolverSettings:
        """These settings with ``options`` added to back-end ``solver``'s."""
        merged = {name: dict(opts) for name, opts in self.options.items()}
        merged.setdefault(solver, {}).update(options)
        return replace(self, options=merged)


DEFAULT_SETTINGS = SolverSettings()
"""The settings used when none are given: :data:`DEFAULT_LP_SOLVER` for LPs and QPs, no option,
:data:`FEASIBILITY_TOLERANCE`."""


def settings_from(solver: str | None = None, settings: SolverSettings | None = None) -> SolverSettings:
    """The settings of a public call that takes ``solver=`` (a back-end name) and ``settings=``.

    The one conversion at the boundary: ``settings`` when given (``solver`` then must be None or
    its LP back-end), else :data:`DEFAULT_SETTINGS` with ``solver`` as the LP back-end.

    Raises:
        InputError: ``solver`` is not a string, or contradicts ``settings``.
    """
    if settings is not None:
        if solver is not None and solver != settings.lp:
            raise InputError(f"solver={solver!r} contradicts settings.lp={settings.lp!r}; give one of them")
        return settings
    if solver is None:
        return DEFAULT_SETTINGS
    if not isinstance(solver, str):
        raise InputError(f"solver must be a back-end name (a string), got {solver!r}")
    if solver == DEFAULT_SETTINGS.lp:
        return DEFAULT_SETTINGS
    return SolverSettings(lp=solver, qp=DEFAULT_SETTINGS.qp)
