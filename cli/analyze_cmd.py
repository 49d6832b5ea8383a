"""``frc analyze``: every contact mode, its domain and the ambiguity; the solutions at an input."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the engine loads when a command runs, not for --help
    from frcontrol.scene import Scene

    from .progress import Progress

from . import common, options
from .common import console


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
    from frcontrol.answers import analyze_answer

    loaded = options.load_scene_with_overrides(scene, sets)
    assignments = options.parse_inputs(inputs)
    with common.progress("analysing contact modes (at most)", "modes") as shown:
        answer = analyze_answer(loaded, assignments if inputs else None,
                                progress=_mode_counter(loaded, shown), stage=shown.stage)
    common.answer(answer.document, render, json=json)


def _mode_counter(scene: Scene, shown: Progress) -> Callable[[str], None]:
    """The engine's per-mode callback as a count of the modes evaluated, of those velocity allows.

    Pruning leaves some of those unevaluated, so the fraction is a lower bound and the time left
    an upper one.
    """
    from math import prod

    from frcontrol.modes import ContactProblem

    total = prod(len(letters) for letters in ContactProblem.from_scene(scene).allowed_modes())
    count = [0]

    def evaluated(mode: str) -> None:
        count[0] += 1
        shown(count[0], total)

    return evaluated


RESPONSE_WORDS = {
    "unique": "unique",
    "ambiguous": "ambiguous",
    "constrained": "inputs constrained",
    "ambiguous_constrained": "ambiguous, inputs constrained",
}
"""The rank case of a mode's response (JSON ``rank_case``) in words."""

MODE_COLUMNS = {
    "response": "unique: one motion and one set of forces per input; ambiguous: a family of them "
                "(the mode's equations leave directions free); inputs constrained: the mode holds "
                "only for inputs on a hyperplane (JSON rank_case)",
    "free directions": "how many directions the response leaves free (w, JSON ambiguity_dim)",
    "ambiguous outputs": "what those directions move: none, forces (accelerations determined) or "
                         "accelerations (the motion itself)",
    "interior": "whether the mode's domain has an interior (JSON full_dimensional); without one "
                "it holds only on a boundary",
    "faces": "inequalities of the domain's minimal description (JSON halfspaces)",
    "overlaps with": "the modes whose domains share an interior with this one (ambiguity between modes)",
}
"""The columns of the feasible-modes table and what each says (``frc analyze --help`` shows them)."""

SOLUTION_COLUMNS = ("accelerations dv", "normal forces", "tangential forces", "free directions", "stability")
"""The columns of the solutions table, after the mode: ``dv`` per coordinate, the contacts' forces
(touching contacts, in scene order) [N], the free directions (w) and the stability under compliance."""


analyze_command.__doc__ = (analyze_command.__doc__ or "") + (
    "\n    The feasible-modes table: "
    + "; ".join(f"{name}: {meaning}" for name, meaning in MODE_COLUMNS.items()) + ".\n")


def render(payload: dict[str, Any]) -> None:
    """The analysis as rich tables, each mode over every contact of the scene, columns in words."""
    from frcontrol.modes import mode_heading, mode_key

    e = payload["enumeration"]
    names = payload["scene_contacts"]
    console.print(
        f"contacts: {', '.join(payload['contacts']) or '(none active)'}"
        + (f"  (inactive: {', '.join(payload['inactive_contacts'])})" if payload["inactive_contacts"] else "")
    )
    console.print(
        f"modes: {e['total']} in all, {e['pruned_velocity']} pruned by velocity, {e['evaluated']} evaluated, "
        f"{e['feasible']} feasible; pruned: {e['pruned_freedom']} freedom, "
        f"{e['pruned_infeasible']} infeasible"
    )
    console.print(mode_key(names))
    scene_of = {m["mode"]: m["scene_mode"] for m in payload["modes"]}
    rows = [(m["scene_mode"], RESPONSE_WORDS.get(m["rank_case"], m["rank_case"]), str(m["ambiguity_dim"]),
             m["ambiguous_outputs"], "yes" if m["full_dimensional"] else "no", str(m["halfspaces"]),
             ", ".join(scene_of[o] for o in m["overlaps"]) or "-")
            for m in payload["modes"] if m["feasible"]]
    common.print_table("feasible modes", (mode_heading(names), *MODE_COLUMNS), rows)
    console.print("columns: " + "; ".join(f"{name}: {meaning}" for name, meaning in MODE_COLUMNS.items()))
    if "solutions" in payload:
        rows = [(s["scene_mode"], " ".join(f"{x:.4g}" for x in s["dv"]),
                 " ".join(f"{c['lambda_n']:.4g}" for c in s["contacts"].values()),
                 " ".join(f"{c['lambda_t']:.4g}" for c in s["contacts"].values()), str(s["ambiguity_dim"]),
                 {True: "stable", False: "unstable", None: "not analysable"}[s["stable"]])
                for s in payload["solutions"]]
        if rows:
            common.print_table("rigid-body solutions at the input",
                               (mode_heading(names), *SOLUTION_COLUMNS), rows)
        else:
            console.print("no rigid-body solution at this input")
    t = payload["timings"]
    console.print(f"time: {1e3 * t['total']:.1f} ms")


__all__ = [
    "analyze_command",
    "MODE_COLUMNS",
    "render",
    "RESPONSE_WORDS",
    "SOLUTION_COLUMNS",
]
