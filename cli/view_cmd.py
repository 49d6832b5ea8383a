"""``frc view``: a scene's state as a meshcat page, a live meshcat viewer, or a 2-D picture."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from frcontrol.scene import load_scene

from .common import check_output_files, fail, handle_errors, note, print_json, serve_until_stopped, set_quiet
from .model_cmds import JsonOpt, SceneArg
from .options import QuietOpt, SetOpt, scene_overrides

HtmlOpt = Annotated[
    Path | None,
    typer.Option("--html", metavar="FILE",
                 help="Write a self-contained HTML page (meshcat) that shows the scene offline."),
]
ViewOpt = Annotated[
    bool,
    typer.Option("--view", help="Serve the scene on a local meshcat server and print its URL; serve "
                 "until Ctrl-C or SIGTERM, then shut the server down."),
]
PortOpt = Annotated[
    int | None,
    typer.Option("--port", min=1, max=65535,
                 help="Port of the --view server (default: the first free port from 7000)."),
]
PlotOpt = Annotated[
    Path | None,
    typer.Option("--plot", metavar="FILE", help="Write a 2-D picture of the scene (PNG, or PDF/SVG "
                 "by the file's suffix)."),
]


@handle_errors
def view_command(
    scene: SceneArg,
    html: HtmlOpt = None,
    view: ViewOpt = False,
    port: PortOpt = None,
    plot: PlotOpt = None,
    json: JsonOpt = False,
    sets: SetOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Show a scene's state: robot, contacts, surfaces and friction cones.

    With no --html, --plot or --view, writes SCENE_NAME.html (a self-contained meshcat page) in the
    current folder and says where.

    \b
    Examples:
      frc view rhex_flip
      frc view rhex_flip --plot rhex.png
      frc view rhex_flip --view --port 7000
    """
    set_quiet(quiet)
    if port is not None and not view:
        raise fail("--port needs --view")
    if html is None and plot is None and not view:
        html = Path(f"{Path(scene).stem}.html")
    check_output_files(plot=plot, html=html)
    loaded = load_scene(scene, overrides=scene_overrides(sets))
    written: dict[str, str | None] = {"html": None, "plot": None, "url": None}
    if html is not None:
        from frcontrol.viz.meshcat_view import write_html

        written["html"] = str(Path(write_html(loaded, None, html)).resolve())
        note(f"wrote {written['html']}", to_stderr=json)
    if plot is not None:
        from frcontrol.viz.plots import plot_scene

        plot_scene(loaded, plot)
        written["plot"] = str(plot)
        note(f"wrote {plot}", to_stderr=json)
    if view:
        from frcontrol.viz.meshcat_view import serve

        url = serve(loaded, None, port)
        written["url"] = url
        if json:
            print_json({"scene": loaded.name, **written})
        else:
            typer.echo(f"meshcat viewer: {url}")
        sys.stdout.flush()
        serve_until_stopped(url)
        return
    if json:
        print_json({"scene": loaded.name, **written})

__all__ = [
    "view_command",
]
