"""The CI benchmark's gate, benchmarks page table and calibration (``benchmarks/ci.py``), with no timing.

``benchmarks`` is not an installed package: the module is loaded from its file. Its top level
imports only the standard library and NumPy, so nothing here runs a benchmark.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _load_ci():
    spec = importlib.util.spec_from_file_location("benchmarks_ci_under_test", ROOT / "benchmarks" / "ci.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


ci = _load_ci()


def _run(ratios: dict[str, float | None], gated: tuple[str, ...] = ()) -> dict:
    """A result dict as measure() writes it, with the given ratios (None: an invalid answer)."""
    figures = {}
    for name, ratio in ratios.items():
        figures[name] = {"label": name, "gated": name not in gated, "valid": ratio is not None,
                         "median_s": None if ratio is None else 1e-3 * ratio, "runs": 7,
                         "ratio_to_calibration": ratio, "target_s": None, "met": None}
        if ratio is None:
            figures[name]["reason"] = "InvalidAnswer: wrong modes"
    return {"figures": figures}


def test_readme_table_is_the_rendering_of_the_committed_json():
    result = json.loads((ROOT / "benchmarks" / "results" / "ci.json").read_text())
    block = ci.readme_block((ROOT / "docs" / "benchmarks.md").read_text())
    assert block == ci.render_table(result), (
        "docs/benchmarks.md's figures table differs from benchmarks/results/ci.json: run "
        "`python -m benchmarks.ci --readme` (or restore the committed ci.json)")


def test_committed_json_and_baseline_cover_every_figure():
    result = json.loads((ROOT / "benchmarks" / "results" / "ci.json").read_text())
    baseline = json.loads((ROOT / "benchmarks" / "baseline.json").read_text())
    names = [f.name for f in ci.FIGURES]
    assert list(result["figures"]) == names
    assert set(baseline["figures"]) == set(names)
    for name in names:
        entry = result["figures"][name]
        assert {"median_s", "runs", "ratio_to_calibration", "target_s", "met"} <= set(entry)
        assert entry["valid"], f"{name}: {entry.get('reason')}"
        assert entry["runs"] >= 3
        assert baseline["figures"][name]["ratio_to_calibration"] > 0
    assert {"calibration", "versions", "cores", "date"} <= set(result)
    # nothing in the committed run regresses against the committed baseline
    assert ci.regressions(result, baseline) == []


def test_gate_flags_a_1_6x_regression_and_passes_a_1_4x_one():
    baseline = _run({"a": 2.0, "b": 0.01})
    assert ci.regressions(_run({"a": 1.4 * 2.0, "b": 1.4 * 0.01}), baseline) == []
    lines = ci.regressions(_run({"a": 1.6 * 2.0, "b": 0.01}), baseline)
    assert len(lines) == 1 and lines[0].startswith("regression: a:") and "1.60x" in lines[0]
    lines = ci.regressions(_run({"a": 2.0, "b": 1.6 * 0.01}), baseline)
    assert len(lines) == 1 and lines[0].startswith("regression: b:")
    assert ci.regressions(_run({"a": 0.5, "b": 0.001}), baseline) == []  # faster is never a regression


def test_gate_limit_is_the_named_factor():
    baseline = _run({"a": 1.0})
    just_below = _run({"a": ci.REGRESSION_FACTOR * 0.999})
    just_above = _run({"a": ci.REGRESSION_FACTOR * 1.001})
    assert ci.regressions(just_below, baseline) == []
    assert len(ci.regressions(just_above, baseline)) == 1


def test_gate_flags_invalid_and_missing_figures_and_skips_ungated_ones():
    baseline = _run({"a": 1.0, "b": 1.0, "ref": 1.0}, gated=("ref",))
    lines = ci.regressions(_run({"a": None, "ref": 10.0}, gated=("ref",)), baseline)
    assert len(lines) == 2
    assert any(line.startswith("regression: a: invalid answer") for line in lines)
    assert any(line.startswith("regression: b:") and "not measured" in line for line in lines)


def test_baseline_from_a_run_gates_that_run():
    run = _run({"a": 1.0, "b": 3.0})
    run.update(date="2026-11-25T00:00:00Z", cores=2, machine="x86_64", versions={}, runs=7,
               calibration={"median_s": 3e-3}, regression_factor=ci.REGRESSION_FACTOR)
    baseline = ci.baseline_from(run)
    assert ci.regressions(run, baseline) == []
    slower = copy.deepcopy(run)
    slower["figures"]["b"]["ratio_to_calibration"] = 3.0 * 1.6
    assert len(ci.regressions(slower, baseline)) == 1


def test_readme_rewrite_replaces_only_the_block():
    result = json.loads((ROOT / "benchmarks" / "results" / "ci.json").read_text())
    text = f"# title\n\nbefore\n\n{ci.README_BEGIN}\nstale | table\n{ci.README_END}\n\nafter\n"
    rewritten = ci.rewrite_readme(text, result)
    assert rewritten.startswith("# title\n\nbefore\n\n") and rewritten.endswith("\n\nafter\n")
    assert "stale" not in rewritten
    assert ci.readme_block(rewritten) == ci.render_table(result)
    assert ci.rewrite_readme(rewritten, result) == rewritten
    with pytest.raises(ValueError, match="markers|needs the lines"):
        ci.readme_block("no markers here")


def test_calibration_workload_is_deterministic_and_correct():
    first = ci.calibration_workload()
    assert all(ci.calibration_workload() == first for _ in range(3))
    assert first.solution_error <= ci.CALIBRATION_RESIDUAL_TOLERANCE
    assert first.singular_value_sum > 0 and first.checksum > 0


def test_format_seconds_picks_a_readable_unit():
    assert ci.format_seconds(0.5) == "500 ms"
    assert ci.format_seconds(1.234) == "1.23 s"
    assert ci.format_seconds(7.17e-4) == "717 us"
    assert ci.format_seconds(4.5e-6) == "4.5 us"
    assert ci.format_seconds(None) == "-"


def test_a_figure_with_a_same_run_reference_is_gated_on_that_ratio():
    baseline = _run({"a": 1.0})
    baseline["figures"]["a"]["ratio_to_bare_pinocchio"] = 2.0
    noisy = _run({"a": 3.0})  # its CPU ratio to the calibration tripled, its own reference's did not
    noisy["figures"]["a"]["ratio_to_bare_pinocchio"] = 2.1
    assert ci.regressions(noisy, baseline) == []
    slower = _run({"a": 1.0})
    slower["figures"]["a"]["ratio_to_bare_pinocchio"] = 2.0 * 1.6
    lines = ci.regressions(slower, baseline)
    assert len(lines) == 1 and "ratio to bare pinocchio" in lines[0] and "1.60x" in lines[0]


def test_the_contacts_benchmark_turns_running_out_of_memory_into_a_memory_error():
    """benchmarks.contacts.memory_limit: an allocation past the limit raises MemoryError inside the
    block (the forced analysis is then reported out of memory, not killed), and the limit is
    restored after it."""
    resource = pytest.importorskip("resource", reason="RLIMIT_AS needs the resource module (POSIX)")
    if str(ROOT) not in sys.path:  # the benchmarks beside the package; the checkout LAST
        sys.path.append(str(ROOT))
    import numpy as np

    from benchmarks.contacts import memory_limit

    before = resource.getrlimit(resource.RLIMIT_AS)
    with Path("/proc/self/status").open() as status:
        size = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmSize:"))
    with memory_limit(size + 2**30), pytest.raises(MemoryError, match="allocate"):
        np.empty(2**32, dtype=np.uint8)  # (untouched: without the limit it would not use the memory)
    assert resource.getrlimit(resource.RLIMIT_AS) == before
