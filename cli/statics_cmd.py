"""``frc statics``: form and force closure, static equilibrium, support region, weak/strong stability."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich.table import Table

from frcontrol.errors import FrcontrolError, InputError, reason_from_exception
from frcontrol.scene import Scene, load_scene

if TYPE_CHECKING:  # the statics load when the command runs, not for --help
    from frcontrol.statics import StaticsReport

from .common import check_output_files, console, handle_errors, note, print_json, set_quiet
from .model_cmds import JsonOpt, SceneArg
from .options import InputOpt, QuietOpt, SetOpt, parse_inputs, scene_overrides

PlotOpt = Annotated[
    Path | None,
    typer.Option("--plot", help="Write a PNG of the body, contacts, friction cones and support region."),
]
LateralOpt = Annotated[
    float,
    typer.Option("--lateral-acceleration", min=0.0,
                 help="[m/s^2] planar support region: stay at rest while the supports accelerate "
                      "sideways by up to this (0: the vertical strip)."),
]
WeakOnlyOpt = Annotated[
    bool,
    typer.Option("--no-strong", help="Skip the strong-stability test (the mode-domain engine)."),
]


def statics_payload(report: StaticsReport) -> dict[str, Any]:
    """The ``frc statics --json`` document: :meth:`~frcontrol.statics.StaticsReport.to_dict`."""
    return report.to_dict()


@handle_errors
def statics_command(
    scene: SceneArg,
    json: JsonOpt = False,
    plot: PlotOpt = None,
    inputs: InputOpt = None,
    lateral_acceleration: LateralOpt = 0.0,
    no_strong: WeakOnlyOpt = False,
    sets: SetOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Form and force closure, static equilibrium, support region, weak and strong stability at rest.

    \b
    Examples:
      frc statics box_on_slope
      frc statics snake_climb --lateral-acceleration 2 --plot statics.png
    """
    set_quiet(quiet)
    from frcontrol.statics import analyze_statics

    check_output_files(plot=plot)
    loaded = load_scene(scene, overrides=scene_overrides(sets))
    report = analyze_statics(loaded, parse_inputs(inputs), lateral_acceleration=lateral_acceleration,
                             strong=not no_strong)
    if plot is not None:
        plot_statics(loaded, report, plot)
    payload = statics_payload(report)
    if json:
        print_json(payload)
        return
    render(payload)
    if plot is not None:
        note(f"wrote {plot}")


def _yes(flag: bool | None) -> str:
    return "-" if flag is None else ("yes" if flag else "no")


def render(payload: dict[str, Any]) -> None:
    """The statics report as rich tables."""
    body = payload["body"]
    console.print(f"[bold]{payload['scene']}[/bold]  m = {body['mass']:.4g} kg, "
                  f"CoM = ({body['com'][0]:.4g}, {body['com'][1]:.4g}) m, "
                  f"L = {body['characteristic_length']:.4g} m ({body['length_source']})")
    verdicts = Table(title="statics")
    for col in ("question", "answer", "detail"):
        verdicts.add_column(col, overflow="fold")
    for kind in ("form", "force"):
        verdicts.add_row(f"{kind} closure", _yes(payload[f"{kind}_closure"]),
                         f"margin {payload[f'{kind}_closure_margin']:.4g}, "
                         f"rank {payload['closure'][kind]['rank']}")
    eq = payload["equilibrium"]
    verdicts.add_row("static equilibrium", _yes(payload["static_equilibrium"]),
                     f"residual {eq['residual']:.3g} N, force-set dimension {eq['dimension']}")
    verdicts.add_row("weakly stable", _yes(payload["weakly_stable"]), "")
    strong = payload["strong_stability"]
    verdicts.add_row("strongly stable", _yes(payload["strongly_stable"]),
                     "" if strong is None else
                     (f"moving: {', '.join(strong['moving_modes'])}" if strong["moving_modes"] else
                      f"{len(strong['solutions'])} rigid solution(s), all at rest"))
    sup = payload["support_region"]

    def bound(x: float | None, sign: str) -> str:
        if x is None:
            return f"{sign}inf"
        return "0" if abs(x) < 1e-9 else f"{x:.4g}"  # LP round-off shows as 0

    verdicts.add_row("support interval", _yes(sup["contains_com"]),
                     f"CoM x in [{bound(sup['x_min'], '-')}, {bound(sup['x_max'], '+')}] m")
    console.print(verdicts)
    if eq["forces"]:
        forces = Table(title="an interior equilibrium force set [N]")
        for col in ("contact", "lambda_n", "lambda_t", "lambda_n range", "lambda_t range"):
            forces.add_column(col, overflow="fold")
        for name, f in eq["forces"].items():
            rng = (eq["ranges"] or {}).get(name)

            def text(pair: list | None) -> str:
                if pair is None:
                    return "-"
                return f"[{bound(pair[0], '-')}, {bound(pair[1], '+')}]"

            forces.add_row(name, f"{f['lambda_n']:.4g}", f"{f['lambda_t']:.4g}",
                           text(rng["lambda_n"] if rng else None), text(rng["lambda_t"] if rng else None))
        console.print(forces)
    console.print(f"time: {1e3 * payload['timings']['total']:.1f} ms")


# ---------------------------------------------------------------------------------------------
# plot

BODY_FACE, BODY_EDGE = "#9ecae1", "#3182bd"
"""Colours of the body's links in the plot."""


def _link_shapes(urdf_path: Path) -> dict[str, list[tuple[str, np.ndarray, float, tuple[float, ...]]]]:
    """Per link, its visuals as (kind, centre in link [m], angle in link [rad], size)."""
    shapes: dict[str, list[tuple[str, np.ndarray, float, tuple[float, ...]]]] = {}
    try:
        root = ET.parse(urdf_path).getroot()
    except (ET.ParseError, OSError):
        return shapes
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            origin = visual.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            geometry = visual.find("geometry")
            if geometry is None:
                continue
            centre = np.array(xyz[:2])
            if (box := geometry.find("box")) is not None:
                size = [float(v) for v in box.get("size", "0 0 0").split()]
                shapes.setdefault(link.get("name", ""), []).append(
                    ("box", centre, rpy[2], (size[0], size[1])))
            for kind in ("cylinder", "sphere"):
                if (shape := geometry.find(kind)) is not None:
                    # a planar disk: drawn as a circle of its radius whatever the 3-D axis
                    radius = float(shape.get("radius", "0"))
                    shapes.setdefault(link.get("name", ""), []).append(("circle", centre, 0.0, (radius,)))
    return shapes


def plot_statics(scene: Scene, report: StaticsReport, path: Path) -> None:
    """Draw the body, its contacts and friction cones, the equilibrium forces and the support region.

    Raises:
        FrcontrolError: matplotlib is not installed, or the file cannot be written.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle, Polygon, Rectangle
    except ImportError as err:
        raise FrcontrolError(
            f"--plot needs matplotlib ({err}); install it with: pip install matplotlib"
        ) from err

    body = report.body
    fig, ax = plt.subplots(figsize=(7, 6))
    poses = scene.robot.link_poses(scene.q)
    style = {"facecolor": BODY_FACE, "edgecolor": BODY_EDGE}
    extent = [body.points, body.com[None, :]]
    for link, shapes in _link_shapes(scene.robot.urdf_path).items():
        if link not in poses:
            continue
        origin, angle = poses[link]
        rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        for kind, centre, local_angle, size in shapes:
            world = origin + rot @ centre
            if kind == "box":
                theta = angle + local_angle
                c, s = math.cos(theta), math.sin(theta)
                half = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.array(size) / 2
                corners = world + half @ np.array([[c, s], [-s, c]])
                ax.add_patch(Polygon(corners, closed=True, zorder=2, **style))
                extent.append(corners)
            else:
                ax.add_patch(Circle(tuple(world), size[0], zorder=2, **style))
                extent.append(world + size[0] * np.array([[-1, -1], [1, 1]]))
    pts = np.vstack(extent)
    span = float(max(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]), 0.2))
    cone_length = 0.25 * span
    eq = report.equilibrium
    force_scale = 0.0
    if eq.lambda_n is not None and eq.lambda_t is not None:
        biggest = float(np.max(np.hypot(eq.lambda_n, eq.lambda_t), initial=0.0))
        force_scale = 0.3 * span / biggest if biggest > 0 else 0.0
    for i, name in enumerate(body.contact_names):
        p, n, t, mu = body.points[i], body.normals[i], body.tangents[i], body.mu[i]
        ax.plot(*np.array([p - 0.3 * span * t, p + 0.3 * span * t]).T, color="0.3", lw=2, zorder=1)
        half_angle = min(math.atan(mu), math.radians(89.0))
        edges = [math.cos(half_angle) * n + sgn * math.sin(half_angle) * t for sgn in (1.0, -1.0)]
        ax.add_patch(Polygon(np.array([p, p + cone_length * edges[0], p + cone_length * edges[1]]),
                             closed=True, facecolor="#fdd0a2", edgecolor="#e6550d", alpha=0.6, zorder=3))
        ax.plot(*p, "o", color="#e6550d", zorder=4)
        ax.annotate(name, p, textcoords="offset points", xytext=(4, -12), fontsize=8)
        if force_scale > 0:
            f = eq.lambda_n[i] * n + eq.lambda_t[i] * t
            ax.annotate("", p + force_scale * f, p, zorder=5,
                        arrowprops={"arrowstyle": "->", "color": "#31a354", "lw": 2})
    c = body.com
    ax.plot(*c, "k+", ms=12, mew=2, zorder=6)
    if body.weight > 0:
        ax.annotate("", c + np.array([0.0, -0.25 * span]), c,
                    arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5}, zorder=6)
    lo, hi = pts.min(axis=0) - 0.5 * span, pts.max(axis=0) + 0.5 * span
    sup = report.support
    if sup.feasible:
        x0 = sup.x_min if math.isfinite(sup.x_min) else lo[0]
        x1 = sup.x_max if math.isfinite(sup.x_max) else hi[0]
        ax.add_patch(Rectangle((x0, lo[1]), max(x1 - x0, 1e-4 * span), hi[1] - lo[1], facecolor="#a1d99b",
                               alpha=0.25, edgecolor="#31a354", ls="--", zorder=0,
                               label="support interval (CoM x)"))
        if sup.vertices is not None and len(sup.vertices) >= 3:
            label = f"support region, |a| <= {sup.lateral_acceleration:g} m/s^2"
            ax.add_patch(Polygon(sup.vertices, closed=True, facecolor="none", edgecolor="#006d2c", lw=1.5,
                                 zorder=1, label=label))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    verdict = (f"form closure: {_yes(report.form_closure.closed)}, force closure: "
               f"{_yes(report.force_closure.closed)}\nequilibrium: {_yes(eq.exists)}, weakly stable: "
               f"{_yes(report.weakly_stable)}, strongly stable: {_yes(report.strongly_stable)}")
    ax.set_title(f"{report.scene_name}\n{verdict}", fontsize=9)
    if sup.feasible:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=120)
    except (OSError, ValueError) as err:
        raise InputError(f"cannot write the plot to {str(path)!r}: {reason_from_exception(err)}") from err
    finally:
        plt.close(fig)


__all__ = [
    "plot_statics",
    "render",
    "statics_command",
    "statics_payload",
]
