"""``frc robots`` and ``frc show``: what ships, and the model at a scene's state."""

from __future__ import annotations

from pathlib import Path

from rich.table import Table

from .common import console, handle_errors, print_json, set_quiet
from .options import JsonOpt, QuietOpt, SceneArg, SetOpt, scene_overrides

DESCRIPTION_CHARS = 120
"""[characters] The longest description ``frc robots`` shows (the comment's first sentence, cut at a word)."""


def _leading_comment(path: Path, opener: str, closer: str = "") -> str:
    """The first sentence of a file's leading comment (a URDF's ``<!-- ... -->``, a scene's ``# ...``)."""
    words: list[str] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        text = line.strip()
        if text.startswith("<?xml") or (not text and not words):
            continue
        if not words and not text.startswith(opener):
            break
        if opener == "#" and not text.startswith("#"):
            break
        words.append(text.removeprefix(opener).strip())
        if closer and closer in text:
            break
    comment = " ".join(words).split(closer)[0] if closer else " ".join(words)
    sentence = comment.split(". ")[0].strip().rstrip(".")
    if len(sentence) <= DESCRIPTION_CHARS:
        return sentence
    return sentence[:DESCRIPTION_CHARS].rsplit(" ", 1)[0] + " ..."


def catalog() -> list[dict[str, str]]:
    """Every robot and scene a scene file can name: ``{"kind", "name", "description"}`` rows.

    The shipped URDFs (``robot = "rod.urdf"``), the example-robot-data robots when that package is
    installed (``robot = "example-robot-data:solo/solo12"``), and the shipped scenes.
    """
    from frcontrol.errors import FrcontrolError
    from frcontrol.plane import EXAMPLE_ROBOT_DATA_PREFIX, example_robot_data_robots
    from frcontrol.scene import shipped_robots_dir

    root = shipped_robots_dir()
    rows = [{"kind": "robot", "name": p.name, "description": _leading_comment(p, "<!--", "-->")}
            for p in sorted(root.glob("*.urdf"))]
    try:
        extra = example_robot_data_robots()
    except FrcontrolError:  # example-robot-data not installed: nothing more a scene can name
        extra = {}
    bare = {path: name for name, path in extra.items() if "/" not in name}
    for name, path in extra.items():
        if "/" in name:
            alias = f" (also example-robot-data:{bare[path]})" if path in bare else ""
            rows.append({"kind": "robot", "name": EXAMPLE_ROBOT_DATA_PREFIX + name,
                         "description": f"{path.parent.parent.name}/{path.name} from the example-robot-data "
                                        f"package, a 3-D URDF made planar by the scene's [plane]{alias}"})
    rows += [{"kind": "scene", "name": p.stem, "description": _leading_comment(p, "#")}
             for p in sorted((root / "scenes").glob("*.toml"))]
    return rows


@handle_errors
def robots(json: JsonOpt = False, quiet: QuietOpt = False) -> None:
    """List every robot a scene can name (shipped and example-robot-data) and the shipped scenes.

    \b
    Example:
      frc robots --json
    """
    set_quiet(quiet)
    from frcontrol.scene import shipped_robots_dir

    root = shipped_robots_dir()
    rows = catalog()
    if json:
        print_json({"folder": str(root),
                    "robots": [p.name for p in sorted(root.glob("*.urdf"))],
                    "scenes": [p.stem for p in sorted((root / "scenes").glob("*.toml"))],
                    "catalog": rows})
        return
    table = Table(title=f"what a scene can name (shipped files in {root})")
    for column in ("kind", "name", "description"):
        table.add_column(column, overflow="fold")
    for row in rows:
        table.add_row(row["kind"], row["name"], row["description"])
    console.print(table)


def show_payload(scene_file: str | Path, overrides: dict | None = None) -> dict:
    """The ``frc show --json`` document for a scene."""
    from frcontrol.scene import load_scene

    scene = load_scene(scene_file, overrides=overrides)
    state = scene.robot.state(scene.q, scene.v)
    contacts = {}
    for i, contact in enumerate(scene.contacts):
        contacts[contact.name] = {
            "gap": state.gaps[i],
            "v_n": state.normal_velocities[i],
            "v_t": state.tangential_velocities[i],
            "jacobian_n": state.jacobian_normal[i],
            "jacobian_t": state.jacobian_tangent[i],
            "drift_n": state.drift_normal[i],
            "drift_t": state.drift_tangent[i],
            "active": contact.active,
            "point": state.contact_points[i],
        }
    return {
        "scene": scene.name,
        "coordinates": list(scene.coordinate_names),
        "q": scene.q,
        "v": scene.v,
        "mass_matrix": state.mass_matrix,
        "bias": state.bias,
        "contacts": contacts,
        "inputs": list(scene.inputs.coordinates),
        "gap_tolerance": scene.gap_tolerance,
    }


@handle_errors
def show(scene: SceneArg, json: JsonOpt = False, sets: SetOpt = None, quiet: QuietOpt = False) -> None:
    """Print the coordinates, M(q), h(q, v) and every contact's gap, velocities and rows.

    \b
    Examples:
      frc show rhex_flip
      frc show rod_on_table --set state.q=[0,0.45,2.0] --json
    """
    set_quiet(quiet)
    payload = show_payload(scene, scene_overrides(sets))
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
    "catalog",
    "robots",
    "show",
    "show_payload",
]
