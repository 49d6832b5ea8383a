"""The engine, the LCP solvers, the statics and the compliant model at the extremes.

The cases live in ``extreme_cases.py`` (shared with ``benchmarks/extremes.py``, which writes the
table ``benchmarks/extremes.md``). Each returns the right answer to its stated tolerance, or, for the
cases listed in ``TYPED_ERROR_CASES``, the typed error named there (a message that names the cause);
a case exposing a known library bug is ``xfail(strict=True)`` with the diagnosis, so that the fix
flips it.
"""

from __future__ import annotations

import pytest
from extreme_cases import CASES, TYPED_ERROR_CASES, Case, Outcome

SLOW_CASES = {"box-contacts-1e-12-apart", "box-duplicate-contact"}
"""The cases that take seconds (``pytest -m 'not slow'`` leaves them out)."""


def _param(case: Case):
    marks = [pytest.mark.xfail(strict=True, reason=case.known_failure)] if case.known_failure else []
    if case.id in SLOW_CASES:
        marks.append(pytest.mark.slow)
    return pytest.param(case, id=case.id, marks=marks)


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_extreme_case(case: Case, tmp_path):
    outcome = case.run(tmp_path)
    assert isinstance(outcome, Outcome)
    if case.id in TYPED_ERROR_CASES:
        assert outcome.kind == "typed error", outcome
        assert outcome.detail.startswith(TYPED_ERROR_CASES[case.id]), outcome
    else:
        assert outcome.kind == "pass", outcome
    assert outcome.detail


def test_case_ids_are_unique_and_every_group_is_covered():
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))
    assert {c.group for c in CASES} == {"friction", "stiffness", "mass ratio", "singular", "many contacts",
                                        "scale"}
