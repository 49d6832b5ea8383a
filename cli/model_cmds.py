"""``frc robots`` and ``frc show``: what ships, and the model at a scene's state."""

from __future__ import annotations

from rich.table import Table

from .common import console, handle_errors, print_json, set_quiet
from .options import JsonOpt, QuietOpt, SceneArg, SetOpt, scene_overrides


@handle_errors
def robots(json: JsonOpt = False, quiet: QuietOpt = False) -> None:
    """List every robot a scene can name (shipped and example-robot-data) and the shipped scenes.

    \b
    Example:
      frc robots --json
    """
    set_quiet(quiet)
    from frcontrol.answers import robots_answer
    from frcontrol.scene import shipped_robots_dir

    root = shipped_robots_dir()
    document = robots_answer().document
    if json:
        print_json({"folder": str(root), **document})
        return
    rows = document["catalog"]
    table = Table(title=f"what a scene can name (shipped files in {root})")
    for column in ("kind", "name", "description"):
        table.add_column(column, overflow="fold")
    for row in rows:
        table.add_row(row["kind"], row["name"], row["description"])
    console.print(table)


@handle_errors
def show(scene: SceneArg, json: JsonOpt = False, sets: SetOpt = None, quiet: QuietOpt = False) -> None:
    """Print the coordinates, M(q), h(q, v) and every contact's gap, velocities and rows.

    \b
    Examples:
      frc show rhex_flip
      frc show rod_on_table --set state.q=[0,0.45,2.0] --json
    """
    set_quiet(quiet)
    from frcontrol.answers import show_answer
    from frcontrol.scene import load_scene

    payload = show_answer(load_scene(scene, overrides=scene_overrides(sets))).document
    if json:
        print_json(payload)
        return
    names = payload["coordinates"]
    console.print(f"[bold]{payload['scene']}[/bold]  coordinates: {', '.join(names)}")
    mass = Table(title="mass matrix M(q) and bias h(q, v)")
    mass.add_column("", overflow="fold")
    for name in names:
        mass.add_column(name, justify="right", overflow="fold")
    mass.add_column("h", justify="right", overflow="fold")
    for i, name in enumerate(names):
        mass.add_row(name, *[f"{x:.4g}" for x in payload["mass_matrix"][i]], f"{payload['bias'][i]:.4g}")
    console.print(mass)
    import numpy as np

    rows = Table(title="contacts (rows J_N, J_T over the coordinates)")
    for col in ("contact", "active", "gap [m]", "v_n", "v_t", "J_N", "J_T"):
        rows.add_column(col, overflow="fold")
    for name, c in payload["contacts"].items():
        rows.add_row(
            name, "yes" if c["active"] else "no", f"{c['gap']:.3g}", f"{c['v_n']:.3g}",
            f"{c['v_t']:.3g}", np.array2string(np.asarray(c["jacobian_n"]), precision=3),
            np.array2string(np.asarray(c["jacobian_t"]), precision=3),
        )
    console.print(rows)


__all__ = [
    "robots",
    "show",
]
