"""``frc view``: a scene's state as a meshcat page, a live meshcat viewer, or a 2-D picture."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from frcontrol.errors import FrcontrolError

if TYPE_CHECKING:  # the scene module loads when the command runs, not for --help
    from frcontrol.scene import Scene

from . import common, options

HtmlOpt = options.html_option("the scene")
ViewOpt = options.view_option("the scene")

WatchOpt = Annotated[
    bool,
    typer.Option("--watch", help="Reload the scene when its file (or its robot's URDF) changes: redraw "
                 "the --view server and rewrite --html. A scene that no longer loads is reported on "
                 "stderr and the last good one stays. Runs until Ctrl-C or SIGTERM."),
]
PlotOpt = options.plot_option("a 2-D picture of the scene")


@common.handle_errors
def view_command(
    scene: options.SceneArg,
    html: HtmlOpt = None,
    view: ViewOpt = False,
    port: options.PortOpt = None,
    plot: PlotOpt = None,
    watch: WatchOpt = False,
    json: options.JsonOpt = False,
    sets: options.SetOpt = None,
    quiet: options.QuietOpt = False,
) -> None:
    """Show a scene's state: robot, contacts, surfaces and friction cones.

    With no --html, --plot or --view, writes SCENE_NAME.html (a self-contained meshcat page) in the
    current folder and says where.

    \b
    Examples:
      frc view rhex_flip
      frc view rhex_flip --plot rhex.png
      frc view rhex_flip --view --port 7000
      frc view my_scene.toml --view --watch
    """
    common.set_quiet(quiet)
    common.check_port(view=view, port=port)
    if html is None and plot is None and not view:
        html = Path(f"{Path(scene).stem}.html")
        options.check_output_path("--html", html)
    overrides = options.scene_overrides(sets)
    from frcontrol.scene import load_scene

    loaded = load_scene(scene, overrides=overrides)
    written: dict[str, str | None] = {"html": None, "plot": None, "url": None, "zmq_url": None}

    def show(current: Scene) -> None:
        """Write the files asked for, and draw into the server if one runs."""
        if html is not None:
            from frcontrol.viz.meshcat_view import write_html

            written["html"] = str(Path(write_html(current, None, html)).resolve())  # the JSON's: absolute
            common.note(f"wrote {html}", to_stderr=json)  # the line: the path as given
        if plot is not None:
            from frcontrol.viz.plots import plot_scene

            plot_scene(current, plot)
            written["plot"] = str(plot)
            common.note(f"wrote {plot}", to_stderr=json)
        if written["url"] is not None:
            from frcontrol.viz.meshcat_view import redraw

            redraw(written["url"], current)

    # the watched files' stamps are taken before anything is shown: an edit made once the command
    # says it is ready is always seen
    tick = _watcher(scene, overrides, loaded, show) if watch else None
    show(loaded)
    if view:
        from frcontrol.viz.meshcat_view import serve, server_at

        written["url"] = url = serve(loaded, None, port)
        written["zmq_url"] = server_at(url).zmq_url

    def announce() -> None:
        """The ready line: the JSON document, or the viewer's URL."""
        if json:
            common.print_json({"scene": loaded.name, **written})
        elif view:
            typer.echo(f"meshcat viewer: {written['url']}")
        sys.stdout.flush()
        if watch and not view:
            common.note("watching; Ctrl-C (or SIGTERM) stops", to_stderr=True)

    if view:
        common.serve_until_stopped(str(written["url"]), tick, announce)
    elif watch:
        common.wait_until_stopped(tick, announce)
    else:
        announce()


def _watcher(scene: str, overrides: dict | None, loaded: Scene, show: Callable[[Scene], None]
             ) -> Callable[[], None]:
    """A tick that reloads the scene and shows it again when its file or its URDF changes."""

    def files_of(current: Scene) -> list[Path]:
        return [Path(current.path), Path(current.robot.urdf_path)]

    def stamp(paths: list[Path]) -> tuple:
        out = []
        for path in paths:
            try:
                info = path.stat()
                out.append((info.st_mtime_ns, info.st_size))
            except OSError:
                out.append(None)
        return tuple(out)

    watched = {"files": files_of(loaded)}
    watched["stamp"] = stamp(watched["files"])

    def tick() -> None:
        now = stamp(watched["files"])
        if now == watched["stamp"]:
            return
        watched["stamp"] = now
        from frcontrol.scene import load_scene

        try:
            current = load_scene(scene, overrides=overrides)
            show(current)
        except FrcontrolError as err:
            sys.stderr.write(f"frc: error: {err} (still watching)\n")
            return
        # the stamp stays the one taken before the load: an edit made while the scene was read or
        # drawn differs from it, and the next tick reloads (stamping again here would miss it)
        files = files_of(current)
        if files != watched["files"]:  # another URDF: watched from now on
            watched["files"], watched["stamp"] = files, stamp(files)
        common.note(f"reloaded {current.path}", to_stderr=True)

    return tick


__all__ = [
    "view_command",
]
