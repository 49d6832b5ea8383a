"""``frc analyze``: every contact mode, its domain and the ambiguity; the solutions at an input."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rich.table import Table

if TYPE_CHECKING:  # the engine loads when a command runs, not for --help
    from frcontrol.engine import RigidSolution
    from frcontrol.modes import ContactProblem

from . import common, options
from .common import console


def solution_payload(solution: RigidSolution, problem: ContactProblem) -> dict[str, Any]:
    """One rigid-body solution as JSON, with its stability: :func:`frcontrol.stability.solution_report`."""
    from frcontrol.stability import solution_report

    return solution_report(problem, solution)


@common.handle_errors
def analyze_command(
    scene: options.SceneArg,
    inputs: options.InputOpt = None,
    json: options.JsonOpt = False,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Every contact mode at the scene's state: response, domain, ambiguity; with --input, the solutions.

    \b
    Examples:
      frc analyze rod_on_table
      frc analyze rod_on_table --input x=1 --input theta=0.5 --json
      frc analyze rod_on_table --set contacts.tip.mu=0.3 --input x=1
    """
    common.set_quiet(quiet)
    from frcontrol.answers import analysis_and_solutions, analysis_payload

    loaded = options.load_scene_with_overrides(scene, sets)
    assignments = options.parse_inputs(inputs)
    with common.progress("analysing contact modes...") as status:
        result, solutions = analysis_and_solutions(
            loaded, assignments if inputs else None,
            progress=lambda mode: status.update(f"analysing mode {mode}"))
    payload = analysis_payload(loaded, result, solutions)
    common.answer(payload, render, json=json)


def render(payload: dict[str, Any]) -> None:
    """The analysis as rich tables."""
    e = payload["enumeration"]
    console.print(
        f"contacts: {', '.join(payload['contacts']) or '(none active)'}"
        + (f"  (inactive: {', '.join(payload['inactive_contacts'])})" if payload["inactive_contacts"] else "")
    )
    console.print(
        f"modes: {e['total']} in all, {e['pruned_velocity']} pruned by velocity, {e['evaluated']} evaluated, "
        f"{e['feasible']} feasible; pruned: {e['pruned_freedom']} freedom, "
        f"{e['pruned_infeasible']} infeasible"
    )
    table = Table(title="feasible modes")
    for col in ("mode", "rank case", "w", "ambiguous", "full-dim", "half-spaces", "overlaps with"):
        table.add_column(col, overflow="fold")
    for m in payload["modes"]:
        if not m["feasible"]:
            continue
        table.add_row(m["mode"], m["rank_case"], str(m["ambiguity_dim"]), m["ambiguous_outputs"],
                      "yes" if m["full_dimensional"] else "no", str(m["halfspaces"]),
                      ", ".join(m["overlaps"]) or "-")
    console.print(table)
    if "solutions" in payload:
        sols = Table(title="rigid-body solutions at the input")
        for col in ("mode", "dv", "lambda_n", "lambda_t", "w", "stable"):
            sols.add_column(col, overflow="fold")
        for s in payload["solutions"]:
            cs = s["contacts"].values()
            sols.add_row(s["mode"], " ".join(f"{x:.4g}" for x in s["dv"]),
                         " ".join(f"{c['lambda_n']:.4g}" for c in cs),
                         " ".join(f"{c['lambda_t']:.4g}" for c in cs), str(s["ambiguity_dim"]),
                         {True: "stable", False: "unstable", None: "not analysable"}[s["stable"]])
        console.print(sols if payload["solutions"] else "no rigid-body solution at this input")
    t = payload["timings"]
    console.print(f"time: {1e3 * t['total']:.1f} ms")


__all__ = [
    "analyze_command",
    "render",
    "solution_payload",
]
