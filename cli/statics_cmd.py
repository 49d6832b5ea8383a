"""``frc statics``: form and force closure, static equilibrium, support region, weak/strong stability."""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.table import Table

from . import common, options
from .common import console

HtmlOpt = options.html_option("the body at rest with its equilibrium contact forces")
PlotOpt = options.plot_option("the body, its contacts, friction cones and equilibrium forces, and "
                              "the support interval and region")
LateralOpt = Annotated[
    float,
    typer.Option("--lateral-acceleration", callback=options.in_range(low=0.0, unit="[m/s^2]"),
                 help="[m/s^2] planar support region: stay at rest while the supports accelerate "
                      "sideways by up to this (0: the vertical strip)."),
]
WeakOnlyOpt = Annotated[
    bool,
    typer.Option("--no-strong", help="Skip the strong-stability test (the mode-domain engine)."),
]


@common.handle_errors
def statics_command(
    scene: options.SceneArg,
    json: options.JsonOpt = False,
    plot: PlotOpt = None,
    html: HtmlOpt = None,
    inputs: options.InputOpt = None,
    lateral_acceleration: LateralOpt = 0.0,
    no_strong: WeakOnlyOpt = False,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Form and force closure, static equilibrium, support region, weak and strong stability at rest.

    \b
    Examples:
      frc statics box_on_slope
      frc statics snake_climb --lateral-acceleration 2 --plot statics.png
      frc statics disk_in_wedge --html disk.html
    """
    common.set_quiet(quiet)
    from frcontrol.answers import statics_answer

    loaded = options.load_scene_with_overrides(scene, sets)
    answer = statics_answer(loaded, options.parse_inputs(inputs), lateral_acceleration=lateral_acceleration,
                            strong=not no_strong)
    report = answer.result
    if plot is not None:  # the files first: a failure leaves no answer on stdout
        from frcontrol.viz.figures import plot_statics

        plot_statics(loaded, report, plot)
    if html is not None:
        from frcontrol.viz.meshcat_view import trajectory_from_scene, write_html

        equilibrium = report.equilibrium
        forces = ({} if equilibrium.lambda_n is None else
                  {name: (equilibrium.lambda_n[i], equilibrium.lambda_t[i])
                   for i, name in enumerate(report.body.contact_names)})
        write_html(loaded, trajectory_from_scene(loaded, forces), html)
    common.answer(answer.document, render, json=json)
    for written in (plot, html):
        if written is not None:
            common.note(f"wrote {written}", to_stderr=json)


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
                     (f"moving: {common.named_modes(strong['moving_modes'], payload['contacts'], payload)}"
                      if strong["moving_modes"] else
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


__all__ = [
    "render",
    "statics_command",
]
