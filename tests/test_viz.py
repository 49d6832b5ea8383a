"""Seeing it: the meshcat page in a real headless Chromium, the server, the plots and `frc view`.

The browser test drives Debian's Chromium over the DevTools protocol (a websocket on localhost,
spoken with tornado, which meshcat already depends on): it collects every uncaught exception
(``Runtime.exceptionThrown``), every ``console.error`` and every browser log entry of level
"error" (failed resource loads...), reads the animation the page loaded, and takes a screenshot
whose pixels are checked. Negative controls show each check can fail: a page that throws and
logs errors is caught, a blank page fails the "something was drawn" test.
"""

from __future__ import annotations

import asyncio
import base64
import io
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np
import pytest
import typer
from conftest import rod_scene
from frcontrol.cli.app import app as frc_app
from frcontrol.cli.view_cmd import view_command
from typer.testing import CliRunner

from frcontrol.errors import CoordinateNotFound, InputError
from frcontrol.modes import mode_label
from frcontrol.scene import load_scene
from frcontrol.simulation.trajectory import Trajectory
from frcontrol.viz import (
    OutputFileError,
    PortInUse,
    friction_cone_directions,
    link_visuals,
    plots,
    surface_lines,
    surface_segments,
    visual_outline,
)
from frcontrol.viz import meshcat_view as mv

# ------------------------------------------------------------------------------------ helpers


def rhex_trajectory(samples: int = 4, duration: float = 0.3) -> tuple:
    """rhex_flip with a short synthetic motion (the body pitches a little) and non-zero forces:
    large (40 N normal, 10 N tangential) at the touching contacts right of x = 0, small (5 N) at
    the other touching ones, none at the contacts in the air."""
    scene = load_scene("rhex_flip")
    times = np.linspace(0.0, duration, samples)
    q = np.repeat(scene.q[None, :], samples, axis=0)
    q[:, 2] = math.pi - np.linspace(0.0, 0.1, samples)
    q[:, 1] = scene.q[1] + np.linspace(0.0, 0.02, samples)
    points = np.array([scene.robot.contact_points_in_world(qi) for qi in q])
    k = len(scene.contacts)
    forces = np.zeros((samples, k, 2))
    right = points[0, :, 0] > 0
    touching = np.array([c.active for c in scene.contacts])
    forces[:, right & touching] = [40.0, 10.0]
    forces[:, ~right & touching] = [5.0, 0.0]
    trajectory = Trajectory(
        scene_name=scene.name, coordinates=scene.coordinate_names,
        contacts=tuple(c.name for c in scene.contacts), times=times, q=q, v=np.zeros_like(q),
        inputs=np.zeros((samples, scene.inputs.count)), input_names=scene.inputs.coordinates,
        contact_forces=forces, contact_points=points,
    )
    return scene, trajectory


def page_commands(page: str) -> list[dict]:
    """The meshcat commands embedded in a static page (base64 msgpack in data: URLs)."""
    import umsgpack

    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', page)
    return [umsgpack.unpackb(base64.b64decode(blob)) for blob in blobs]


def read_png(data_or_path) -> np.ndarray:
    """An RGB image as floats in [0, 1], shape (H, W, 3)."""
    import matplotlib.image

    source = io.BytesIO(data_or_path) if isinstance(data_or_path, bytes) else str(data_or_path)
    image = matplotlib.image.imread(source, format="png")
    return np.asarray(image, dtype=float)[..., :3]


def ink_fraction(image: np.ndarray) -> float:
    """Fraction of pixels that are not (nearly) white."""
    return float(np.mean(np.any(image < 0.95, axis=-1)))


# ------------------------------------------------------------------------ the plane mapping


def test_meshcat_from_plane_maps_up_to_up():
    np.testing.assert_allclose(mv.meshcat_from_plane([1.0, 2.0]), [1.0, 0.0, 2.0])
    np.testing.assert_allclose(mv.meshcat_from_plane([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0])  # up is up
    np.testing.assert_allclose(mv.meshcat_from_plane([0.0, 0.0, 1.0]), [0.0, -1.0, 0.0])  # viewer
    np.testing.assert_allclose(mv.meshcat_from_plane(np.ones((4, 5, 2))).shape, (4, 5, 3))
    rotation = mv.MESHCAT_FROM_PLANE[:3, :3]
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(rotation) == pytest.approx(1.0)  # a rotation: counter-clockwise stays so
    with pytest.raises(InputError, match=r"shape \(\.\.\., 2\)"):
        mv.meshcat_from_plane([1.0, 2.0, 3.0, 4.0])


# ------------------------------------------------------------------------ the static page


def test_html_holds_the_scene_and_the_animation(tmp_path):
    scene, trajectory = rhex_trajectory()
    path = mv.write_html(scene, trajectory, tmp_path / "rhex.html", fps=30)
    page = path.read_text(encoding="utf-8")
    assert 500_000 < len(page) < 3_000_000  # the viewer's JavaScript is inside
    assert "<script src" not in page and "http://" not in page.split("<script>")[0]
    commands = page_commands(page)
    by_path = {}
    for command in commands:
        by_path.setdefault(command["path"], []).append(command)
    objects = {c["path"] for c in commands if c["type"] == "set_object"}
    for link in scene.robot.link_names:
        assert f"/meshcat/frcontrol/robot/{link}/visual0" in objects
    for contact in scene.contacts:
        assert f"/meshcat/frcontrol/robot/{contact.point.link}/contact_{contact.name}" in objects
        assert f"/meshcat/frcontrol/forces/{contact.name}/shaft" in objects
        assert f"/meshcat/frcontrol/cones/{contact.name}/fan" in objects
    assert "/meshcat/frcontrol/surfaces/line0" in objects  # five contacts on one merged line
    assert "/meshcat/frcontrol/surfaces/line1" not in objects

    # The root node maps the plane to meshcat, centred at the drawing's middle.
    _, drawing = mv.scene_html(scene, trajectory)
    root = [c for c in by_path["/meshcat/frcontrol"] if c["type"] == "set_transform"][-1]
    np.testing.assert_allclose(np.reshape(root["matrix"], (4, 4)).T, drawing.root_transform, atol=1e-12)

    # The animation: one key per sample, at the sample's time, for every link and arrow.
    animations = [c for c in commands if c["type"] == "set_animation"]
    assert len(animations) == 1 and animations[0]["options"]["play"] is True
    clips = {a["path"]: a["clip"] for a in animations[0]["animations"]}
    body = clips["/meshcat/frcontrol/robot/body"]
    assert body["fps"] == 30
    tracks = {t["name"]: t for t in body["tracks"]}
    times = [key["time"] / body["fps"] for key in tracks[".position"]["keys"]]
    np.testing.assert_allclose(times, trajectory.times, atol=1e-12)
    positions = np.array([key["value"] for key in tracks[".position"]["keys"]])
    np.testing.assert_allclose(positions[:, :2], trajectory.q[:, :2], atol=1e-12)  # plane coordinates
    for contact in scene.contacts:
        assert f"/meshcat/frcontrol/forces/{contact.name}/shaft" in clips
    # Arrow length (shaft, then head): force_scale [m/N] times |f|, as the legend says.
    loaded = int(np.argmax(np.hypot(*trajectory.contact_forces[0].T)))  # a contact with a force
    name = scene.contacts[loaded].name
    shaft = {t["name"]: t for t in clips[f"/meshcat/frcontrol/forces/{name}/shaft"]["tracks"]}
    head = {t["name"]: t for t in clips[f"/meshcat/frcontrol/forces/{name}/head"]["tracks"]}
    shaft_length = shaft[".scale"]["keys"][0]["value"][1]
    head_middle = head[".position"]["keys"][0]["value"][1]
    total = shaft_length + 2 * (head_middle - shaft_length)
    force = np.hypot(*trajectory.contact_forces[0, loaded])
    assert force > 0
    assert total == pytest.approx(drawing.force_scale * force, rel=1e-9)
    assert f"{drawing.force_scale:.3g} m/N" in page


def test_still_scene_has_no_animation_and_modes_are_checked(tmp_path):
    scene = load_scene("snake_climb")
    page, drawing = mv.scene_html(scene)
    assert not drawing.animated
    commands = page_commands(page)
    assert not [c for c in commands if c["type"] == "set_animation"]
    assert {c["path"] for c in commands if c["type"] == "set_object"} >= {
        "/meshcat/frcontrol/surfaces/line0", "/meshcat/frcontrol/surfaces/line1"}  # two walls
    rhex, trajectory = rhex_trajectory()
    page, drawing = mv.scene_html(rhex, trajectory, modes=["FFFFF", "FFRFF", "SFRFF", "SSRLF"])
    objects = {c["path"] for c in page_commands(page) if c["type"] == "set_object"}
    assert "/meshcat/frcontrol/forces/front_toe_R/shaft" in objects
    assert "/meshcat/frcontrol/forces/front_toe_F/shaft" in objects
    assert "/meshcat/frcontrol/forces/rear_toe_L/shaft" not in objects
    with pytest.raises(InputError, match="one mode string per sample"):
        mv.scene_html(rhex, trajectory, modes=["FFFFF"])
    with pytest.raises(InputError, match="letters from S, L, R, F"):
        mv.scene_html(rhex, trajectory, modes=["FFFFX"] * 4)
    with pytest.raises(InputError, match="fps"):
        mv.scene_html(rhex, trajectory, fps=0)
    with pytest.raises(InputError, match="force_scale"):
        mv.scene_html(rhex, trajectory, force_scale=-1.0)


def test_trajectory_must_match_the_scene(tmp_path):
    rhex, trajectory = rhex_trajectory()
    with pytest.raises(InputError, match="coordinates"):
        mv.write_html(load_scene("snake_climb"), trajectory, tmp_path / "x.html")
    bad = Trajectory(**{**trajectory.__dict__, "times": trajectory.times[::-1].copy()})
    with pytest.raises(InputError, match="increase"):
        mv.check_trajectory(rhex, bad)
    bad = Trajectory(**{**trajectory.__dict__, "contact_forces": trajectory.contact_forces[:, :2]})
    with pytest.raises(InputError, match="contact_forces has shape"):
        mv.check_trajectory(rhex, bad)
    with pytest.raises(OutputFileError, match="cannot write"):
        mv.write_html(rhex, None, tmp_path / "no" / "such" / "folder.html")
    still = mv.trajectory_from_scene(rhex)
    mv.check_trajectory(rhex, still)
    assert still.q.shape == (1, len(rhex.coordinate_names)) and not np.any(still.contact_forces)


def test_thinning_keeps_first_and_last_sample():
    times = np.linspace(0.0, 1.0, 1001)
    kept = mv._frame_indices(times, 30.0)
    assert kept[0] == 0 and kept[-1] == 1000
    assert np.all(np.diff(times[kept]) >= 1 / 30 - 1e-12)
    assert 28 <= len(kept) <= 32


# -------------------------------------------------------------------------------- geometry


def test_surfaces_are_merged_and_cut_where_they_meet():
    rhex = load_scene("rhex_flip")
    lines = surface_lines([c.point for c in rhex.contacts])
    assert len(lines) == 1 and len(lines[0].contacts) == 5
    wedge = load_scene("disk_in_wedge")
    lines = surface_lines([c.point for c in wedge.contacts])
    assert len(lines) == 2
    segments = surface_segments(lines, [0.0, 0.1], 1.0)
    for (start, end), line in zip(segments, lines, strict=True):
        ends = [start, end]
        assert min(np.linalg.norm(p) for p in ends) < 1e-9  # each wall ends at the vertex
        assert max(p[1] for p in ends) > 0.5  # and rises from it
        assert abs(line.normal @ (start - line.point)) < 1e-12
    channel = surface_lines([c.point for c in load_scene("snake_climb").contacts])
    assert len(channel) == 2  # parallel walls: nothing cut
    for start, end in surface_segments(channel, [0.0, 0.5], 2.0):
        assert np.linalg.norm(end - start) == pytest.approx(4.0)


def test_friction_cone_opening_angle():
    e1, e2 = friction_cone_directions([0.0, 1.0], 0.5)
    for e in (e1, e2):
        assert np.linalg.norm(e) == pytest.approx(1.0)
        assert math.atan2(abs(e[0]), e[1]) == pytest.approx(math.atan(0.5))
    assert e1[0] < 0 < e2[0]  # t = (1, 0): first edge toward -t


def test_fallback_and_mesh_visuals(tmp_path, write_scene):
    (tmp_path / "tet.obj").write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\n"
                                      "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (tmp_path / "arm.urdf").write_text("""<?xml version="1.0"?>
<robot name="arm">
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0"
    izz="0.01"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0"
    izz="0.01"/></inertial>
    <visual><geometry><mesh filename="tet.obj" scale="2 2 2"/></geometry></visual></link>
  <link name="c"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0"
    izz="0.01"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
""")
    path = write_scene({
        "name": "arm", "robot": str(tmp_path / "arm.urdf"), "base": "planar",
        "state": {"q": [0.0, 0.0, 0.0, 0.0, 0.0]},
        "contacts": [{"name": "tip", "link": "c", "point": [0.0, -0.25], "normal": [0.0, 1.0],
                      "mu": 0.5, "surface_point": [0.2, -0.25]}],
    })
    scene = load_scene(path)
    visuals = link_visuals(scene.robot, [c.point for c in scene.contacts])
    (a,), (b,), (c,) = visuals["a"], visuals["b"], visuals["c"]
    assert a.fallback and a.size[0] == pytest.approx(0.3)  # to the child joint
    assert c.fallback and c.size[0] == pytest.approx(0.25)  # to the contact point
    np.testing.assert_allclose(visual_outline(c)[:, 1].min(), -0.25, atol=0.02)
    assert b.shape == "mesh" and not b.fallback
    np.testing.assert_allclose(np.ptp(visual_outline(b), axis=0), [0.2, 0.2])  # scale 2
    page, _ = mv.scene_html(scene)
    assert any(c["path"] == "/meshcat/frcontrol/robot/b/visual0" and
               c["object"]["geometries"][0]["type"] == "BufferGeometry"
               for c in page_commands(page) if c["type"] == "set_object")


# -------------------------------------------------------------------------------- servers


def test_serve_a_scene_and_refuse_a_taken_port():
    scene = load_scene("rhex_flip")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(PortInUse, match=f"port {port} on 127.0.0.1 is already in use") as info:
            mv.serve(scene, port=port)
        assert info.value.port == port
    with pytest.raises(InputError, match="port must be an integer"):
        mv.serve(scene, port=70_000)
    url = mv.serve(scene)
    try:
        assert url.startswith("http://127.0.0.1:") and url.endswith("/static/")
        with urllib.request.urlopen(url, timeout=READY_SECONDS) as response:
            assert response.status == 200 and b"meshcat" in response.read().lower()
    finally:
        mv.stop_server(url)
    with pytest.raises(OSError, match="[Cc]onnection refused"):
        urllib.request.urlopen(url, timeout=5)


def test_page_is_what_the_server_would_give():
    """The page recorder runs meshcat's own server code: same drawing, same bytes."""
    import meshcat

    class Tee:
        def __init__(self, *windows):
            self.windows = windows

        def send(self, command):
            for window in self.windows:
                window.send(command)

    scene, trajectory = rhex_trajectory()
    server = mv.start_server()
    try:
        recorder = mv._PageRecorder()
        vis = meshcat.Visualizer(window=Tee(recorder, server.visualizer().window))
        mv.draw(vis, scene, trajectory)
        assert recorder.get_scene() == server.static_html()
    finally:
        server.stop()


# ---------------------------------------------------------------------------------- plots


def test_plots_are_written_and_not_blank(tmp_path):
    scene, trajectory = rhex_trajectory()
    path = plots.plot_trajectory(trajectory, tmp_path / "traj.png", coordinates=("theta", "y"))
    image = read_png(path)
    assert image.shape[0] > 300 and image.shape[1] > 400 and ink_fraction(image) > 0.03
    with pytest.raises(CoordinateNotFound, match="'psi'"):
        plots.plot_trajectory(trajectory, tmp_path / "x.png", coordinates=("psi",))
    forces = trajectory.contact_forces[0]
    ax = plots.plot_scene(scene, tmp_path / "scene.png", contact_forces=forces)
    assert ink_fraction(read_png(tmp_path / "scene.png")) > 0.05
    # the surface, one outline per link visual, one friction cone per touching contact
    assert len(ax.patches) == 1 + len(scene.robot.link_names) + len(scene.active_contacts)
    with pytest.raises(OutputFileError, match="cannot write"):
        plots.plot_scene(scene, tmp_path / "scene.unknown-format")
    with pytest.raises(InputError, match="contact_forces must have shape"):
        plots.plot_scene(scene, contact_forces=np.zeros((2, 2)))
    square = (np.vstack([np.eye(2), -np.eye(2)]), np.ones(4))
    half = (np.array([[1.0, 1.0]]), np.array([0.0]))
    ax = plots.plot_polygons([square, half], tmp_path / "poly.png", labels=["F", "S"],
                             hatches=[None, "//"], panel=plots.PolygonPanel(box=(-2, 2, -2, 2)))
    assert ink_fraction(read_png(tmp_path / "poly.png")) > 0.05
    assert [t.get_text() for t in ax.texts] == ["F", "S"]
    with pytest.raises(InputError, match="unbounded"):
        plots.plot_polygons([half])


def test_polygon_from_halfplanes_against_qhull():
    from scipy.optimize import linprog
    from scipy.spatial import ConvexHull, HalfspaceIntersection

    box = (-3.0, 3.0, -3.0, 3.0)
    square = plots.polygon_from_halfplanes(np.vstack([np.eye(2), -np.eye(2)]), np.ones(4), box)
    assert len(square) == 4 and ConvexHull(square).volume == pytest.approx(4.0)
    assert len(plots.polygon_from_halfplanes([[1.0, 0.0], [-1.0, 0.0]], [0.0, -1.0], box)) == 0
    assert len(plots.polygon_from_halfplanes([[0.0, 0.0]], [-1.0], box)) == 0
    segment = plots.polygon_from_halfplanes([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]],
                                            [0.5, -0.5, 1.0, 1.0], box)
    np.testing.assert_allclose(sorted(map(tuple, segment)), [(0.5, -1.0), (0.5, 1.0)], atol=1e-9)
    with pytest.raises(InputError, match="box"):
        plots.polygon_from_halfplanes(np.eye(2), np.ones(2), (1.0, 0.0, 0.0, 1.0))

    rng = np.random.default_rng(7)
    box_rows = np.vstack([np.eye(2), -np.eye(2)])
    for _ in range(40):
        m = int(rng.integers(3, 9))
        A = rng.normal(size=(m, 2))
        b = rng.uniform(-0.5, 1.5, size=m)
        vertices = plots.polygon_from_halfplanes(A, b, box)
        full_A, full_b = np.vstack([A, box_rows]), np.concatenate([b, [3.0, 3.0, 3.0, 3.0]])
        # Chebyshev centre: the oracle needs an interior point.
        norms = np.linalg.norm(full_A, axis=1)
        lp = linprog([0, 0, -1], A_ub=np.column_stack([full_A, norms]), b_ub=full_b,
                     bounds=[(None, None), (None, None), (0, None)])
        if len(vertices):
            assert np.all(full_A @ vertices.T <= full_b[:, None] + 1e-9)
        if lp.status != 0 or lp.x[2] < 1e-6:
            assert len(vertices) < 3 or ConvexHull(vertices).volume < 1e-9
            continue
        oracle = HalfspaceIntersection(np.column_stack([full_A, -full_b]), lp.x[:2])
        assert ConvexHull(vertices).volume == pytest.approx(ConvexHull(oracle.intersections).volume,
                                                            rel=1e-9, abs=1e-12)


# -------------------------------------------------------------------------------- the CLI

runner = CliRunner()
view_app = typer.Typer()
view_app.command()(view_command)


def test_cli_view_writes_files_and_fails_cleanly(tmp_path, write_scene):
    result = runner.invoke(view_app, ["rhex_flip", "--html", str(tmp_path / "v.html"),
                                      "--plot", str(tmp_path / "v.png")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "v.html").stat().st_size > 500_000
    assert ink_fraction(read_png(tmp_path / "v.png")) > 0.05
    bad = write_scene(rod_scene(state={"q": [0.0, 0.453]}))
    for args, code, message in (
        ([str(tmp_path / "missing.toml"), "--html", str(tmp_path / "m.html")], 1, "no such file"),
        ([str(bad), "--html", str(tmp_path / "b.html")], 1, "state.q"),
        (["rhex_flip", "--html", str(tmp_path / "p.html"), "--port", "7000"], 2, "add --view"),
        (["rhex_flip", "--html", str(tmp_path / "no" / "dir.html")], 2, "cannot write"),
    ):
        result = runner.invoke(frc_app, ["view", *args])  # the real group: its one-line usage errors
        assert result.exit_code == code, (args, result.output)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("frc: error:") and message in lines[0], lines
        assert "Traceback" not in result.output


def test_cli_view_with_no_flag_writes_the_page_and_says_where(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(view_app, ["rhex_flip"])
    assert result.exit_code == 0, result.output
    page = tmp_path / "rhex_flip.html"
    assert page.stat().st_size > 500_000 and result.stdout.strip() == "wrote rhex_flip.html"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def port_is_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        return probe.connect_ex(("127.0.0.1", port)) != 0


READY_SECONDS = 120.0
"""[s] How long a test waits for another process (a server, the browser, a reloaded scene) to be
ready, polling: CI is a loaded 2-core machine, so this is generous; a ready process answers at once."""


def read_stdout_until(process: subprocess.Popen, ready):
    """Read ``process``'s stdout until ``ready(the text so far)`` gives a value (a condition that
    means ready: a whole JSON document, a URL), within :data:`READY_SECONDS`; return that value."""
    import queue
    import threading

    lines: queue.Queue = queue.Queue()

    def forward() -> None:
        for line in process.stdout:
            lines.put(line)
        lines.put("")  # the end of its output

    threading.Thread(target=forward, daemon=True).start()
    deadline = time.monotonic() + READY_SECONDS
    text = ""
    while True:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.0))
        except queue.Empty:
            raise AssertionError(f"not ready within {READY_SECONDS:g} s; stdout so far: {text!r}") from None
        assert line, f"frc exited ({process.wait()}) before it was ready; stdout: {text!r}"
        text += line
        value = ready(text)
        if value is not None:
            return value


def wait_until(condition, what: str) -> None:
    """Poll ``condition()`` until it holds, failing after :data:`READY_SECONDS` with ``what``."""
    deadline = time.monotonic() + READY_SECONDS
    while not condition():
        assert time.monotonic() < deadline, f"{what} (within {READY_SECONDS:g} s)"
        time.sleep(0.1)


def replace_text(path: Path, text: str) -> None:
    """Write ``path`` at once (a new file renamed over it), as an editor saves: a watcher never
    reads it half written."""
    part = path.with_name(path.name + ".part")
    part.write_text(text)
    os.replace(part, path)


def stop_and_check_the_port(process: subprocess.Popen, port: int) -> None:
    """SIGTERM ends a serving `frc` with exit 0, and no server is left behind on its port."""
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=READY_SECONDS) == 0
    wait_until(lambda: port_is_free(port), f"a server was left behind on port {port}")


@pytest.mark.parametrize("at_once", [False, True])
def test_cli_view_serves_until_sigterm_then_stops_the_server(tmp_path, at_once):
    """As a user's script runs it: a real process, no terminal; SIGTERM ends it and its server,
    also when sent as soon as the URL is read (the ready line is printed once SIGTERM is caught)."""
    port = free_port()
    process = subprocess.Popen([sys.executable, "-m", "frcontrol", "view", "rhex_flip", "--view", "--port",
                                str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               cwd=tmp_path, stdin=subprocess.DEVNULL)
    try:
        url = read_stdout_until(process, lambda text: (found := re.search(
            r"meshcat viewer: (http://127\.0\.0\.1:\d+/static/)\n", text)) and found.group(1))
        assert f":{port}/" in url
        if not at_once:
            for _ in range(2):  # it answers, and keeps serving
                with urllib.request.urlopen(url, timeout=READY_SECONDS) as response:
                    assert response.status == 200
            assert process.poll() is None
        stop_and_check_the_port(process, port)
    finally:
        if process.poll() is None:
            process.kill()


def test_cli_view_watch_reloads_the_scene_and_survives_a_bad_edit(tmp_path, write_scene):
    """A real `frc view FILE --view --watch --html`: an edit of the file moves the robot in the
    served viewer and in the page; an edit that breaks the scene is one stderr line, and the
    viewer keeps the last good scene; SIGTERM ends it with its server."""
    import contextlib
    import threading

    from conftest import toml_text

    def rod_x(page: str) -> float:
        # NaN while the viewer redraws (the scene cleared, the rod not yet placed): the loops below
        # poll until their deadline, so a viewer that never places it still fails
        moves = [c for c in page_commands(page) if c["type"] == "set_transform"
                 and c["path"] == "/meshcat/frcontrol/robot/rod"]
        return float(np.reshape(moves[-1]["matrix"], (4, 4)).T[0, 3]) if moves else float("nan")

    path = write_scene(rod_scene(), "watched.toml")
    page_path = tmp_path / "watched.html"
    port = free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "frcontrol", "view", str(path), "--view", "--watch", "--json", "--port",
         str(port), "--html", str(page_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, stdin=subprocess.DEVNULL)
    errors: list[str] = []
    threading.Thread(target=lambda: errors.extend(process.stderr), daemon=True).start()

    def whole_document(text: str) -> dict | None:
        with contextlib.suppress(json.JSONDecodeError):
            return json.loads(text)
        return None

    try:
        document = read_stdout_until(process, whole_document)
        assert f":{port}/" in document["url"] and document["html"] == str(page_path.resolve())
        with contextlib.redirect_stdout(io.StringIO()):
            probe = mv._import_meshcat().Visualizer(zmq_url=document["zmq_url"])
        assert rod_x(probe.static_html()) == pytest.approx(0.0, abs=1e-12)
        assert rod_x(page_path.read_text()) == pytest.approx(0.0, abs=1e-12)

        # the file's size changes with each edit, so a watcher sees it even on a coarse clock
        replace_text(path, toml_text(rod_scene(state={"q": [0.25, 0.453, 2.007], "v": [0.0, 0.0, 0.0]})))
        wait_until(lambda: rod_x(probe.static_html()) == pytest.approx(0.25, abs=1e-12),
                   f"the viewer did not reload: {errors}")
        wait_until(lambda: rod_x(page_path.read_text()) == pytest.approx(0.25, abs=1e-12),
                   "the page was not rewritten")

        replace_text(path, toml_text(rod_scene()).replace("mu = ", "muu = "))
        wait_until(lambda: any("still watching" in e for e in errors) or process.poll() is not None,
                   f"no complaint about the bad edit: {errors}")
        assert process.poll() is None, errors
        complaint = next(e for e in errors if "still watching" in e)
        assert "muu" in complaint and "'mu'" in complaint and complaint.count("\n") == 1
        assert process.poll() is None
        assert rod_x(probe.static_html()) == pytest.approx(0.25, abs=1e-12)  # the last good scene
        probe.window.zmq_socket.close(linger=0)

        stop_and_check_the_port(process, port)
    finally:
        if process.poll() is None:
            process.kill()


def test_cli_view_refuses_a_taken_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = runner.invoke(view_app, ["rhex_flip", "--view", "--port", str(port)])
        assert result.exit_code == 1 and "already in use" in result.stderr


# ------------------------------------------------------------------ a real headless browser

CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    "--window-size=800,600", "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0",
]


COUNT_MESHCAT_COMMANDS = """(() => {
  // Before the page's scripts: count the drawing commands its meshcat viewer applies (a page
  // file's come from fetch() promises, a served viewer's over its websocket).
  let current;
  window.frcCommandsApplied = 0;
  Object.defineProperty(window, "viewer", {configurable: true, get: () => current, set(value) {
    current = value;
    const apply = value.handle_command_bytearray.bind(value);
    value.handle_command_bytearray = (bytes) => {
      const out = apply(bytes);
      window.frcCommandsApplied += 1;
      return out;
    };
  }});
})();"""


def meshcat_commands(page: str) -> int:
    """How many drawing commands a meshcat page (``static_html()``) holds: as many as a served
    viewer sends a browser that connects."""
    return page.count('fetch("data:application/octet-binary;base64,')


def find_chromium() -> str | None:
    """Chromium or Chrome: $FRC_CHROMIUM, else the first on PATH."""
    explicit = os.environ.get("FRC_CHROMIUM")
    if explicit:
        return explicit
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        found = shutil.which(name)
        if found:
            return found
    return None


class HeadlessChromium:
    """One headless Chromium, pages loaded and inspected over the DevTools protocol."""

    def __init__(self, executable: str) -> None:
        self.profile = tempfile.mkdtemp(prefix="frc-chromium-")
        self.process = subprocess.Popen(
            [executable, *CHROMIUM_FLAGS, f"--user-data-dir={self.profile}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        self.port = 0
        deadline = time.monotonic() + READY_SECONDS
        while not self._answers():
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.close()
                raise RuntimeError(f"chromium did not answer on its DevTools port within {READY_SECONDS:g} s")
            time.sleep(0.1)

    def _answers(self) -> bool:
        """Whether the DevTools port is known (its file written whole: the port, then the browser's
        path) and answers a real request."""
        try:
            port, path = (Path(self.profile) / "DevToolsActivePort").read_text().split("\n")[:2]
            with urllib.request.urlopen(f"http://127.0.0.1:{int(port)}/json/version", timeout=10) as response:
                if not path.startswith("/devtools/browser/") or "Browser" not in json.load(response):
                    return False
        except (OSError, ValueError):  # not written yet, half written, or not listening yet
            return False
        self.port = int(port)
        return True

    def close(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=READY_SECONDS)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(timeout=READY_SECONDS)
        shutil.rmtree(self.profile, ignore_errors=True)

    def load(self, url: str, expression: str | None = None, commands: int | None = None
             ) -> tuple[bytes, list[str], object]:
        """Open ``url`` in a new tab, let it render (and finish a meshcat animation).

        The page counts as drawn once it has loaded and its meshcat viewer has applied ``commands``
        drawing commands (None: as many as a page file holds; a served viewer's come over its
        websocket after the page loads), and its animation has finished.

        Returns:
            (screenshot PNG, JavaScript errors, the value of ``expression`` evaluated at the end).
        """
        if commands is None:
            local = urllib.parse.urlparse(url)
            commands = 0 if local.scheme != "file" else meshcat_commands(
                Path(urllib.request.url2pathname(local.path)).read_text(encoding="utf-8"))
        return asyncio.run(self._load(url, expression, commands))

    async def _load(self, url: str, expression: str | None, commands: int
                    ) -> tuple[bytes, list[str], object]:
        from tornado.websocket import websocket_connect

        request = urllib.request.Request(f"http://127.0.0.1:{self.port}/json/new?about:blank", method="PUT")
        with urllib.request.urlopen(request, timeout=READY_SECONDS) as response:
            target = json.load(response)
        connection = await websocket_connect(target["webSocketDebuggerUrl"], max_message_size=1 << 26)
        errors: list[str] = []
        events: set[str] = set()
        ids = iter(range(1, 1 << 30))

        def record(message: dict) -> None:
            method, params = message.get("method"), message.get("params", {})
            if method == "Runtime.exceptionThrown":
                details = params["exceptionDetails"]
                errors.append("uncaught: " + str(details.get("exception", {}).get("description")
                                                 or details.get("text")))
            elif method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                errors.append("console.error: " + " ".join(
                    str(a.get("value", a.get("description", ""))) for a in params["args"]))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                entry = params["entry"]
                # A page served over HTTP asks for /favicon.ico, which meshcat's server lacks.
                if not entry.get("url", "").endswith("/favicon.ico"):
                    errors.append(f"log: {entry['text']} {entry.get('url', '')}".rstrip())
            elif method:
                events.add(method)

        async def call(method: str, **params):
            number = next(ids)
            connection.write_message(json.dumps({"id": number, "method": method, "params": params}))
            while True:
                raw = await asyncio.wait_for(connection.read_message(), timeout=READY_SECONDS)
                if raw is None:
                    raise RuntimeError("the DevTools connection closed")
                message = json.loads(raw)
                record(message)
                if message.get("id") == number:
                    if "error" in message:
                        raise RuntimeError(f"{method}: {message['error']}")
                    return message["result"]

        async def evaluate(source: str):
            result = await call("Runtime.evaluate", expression=source, awaitPromise=True,
                                returnByValue=True)
            return result["result"].get("value")

        async def loaded() -> bool:
            await evaluate("1")  # reads the events that came meanwhile
            return "Page.loadEventFired" in events

        async def wait_for(condition, what: str) -> None:
            while not await condition():
                if time.monotonic() > deadline:
                    raise RuntimeError(f"{url}: {what} within {READY_SECONDS:g} s; errors: {errors}")
                await asyncio.sleep(0.05)

        try:
            for domain in ("Runtime", "Log", "Page"):
                await call(f"{domain}.enable")
            await call("Page.addScriptToEvaluateOnNewDocument", source=COUNT_MESHCAT_COMMANDS)
            await call("Page.navigate", url=url)
            deadline = time.monotonic() + READY_SECONDS
            await wait_for(loaded, "the page did not load")
            await wait_for(lambda: evaluate(f"window.frcCommandsApplied >= {commands}"),
                           f"the viewer did not apply its {commands} drawing commands")
            await wait_for(lambda: evaluate("typeof viewer === 'undefined' || !viewer.animator.playing"),
                           "the animation did not finish")
            await evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
            value = await evaluate(expression) if expression else None
            shot = await call("Page.captureScreenshot", format="png")
        finally:
            connection.close()
            with urllib.request.urlopen(f"http://127.0.0.1:{self.port}/json/close/{target['id']}",
                                        timeout=READY_SECONDS):
                pass
        return base64.b64decode(shot["data"]), errors, value


@pytest.fixture(scope="module")
def chromium():
    executable = find_chromium()
    if executable is None:
        why = ("chromium is not installed: apt-get install chromium (Debian), or set "
               "FRC_CHROMIUM to a Chromium/Chrome executable")
        if os.environ.get("CI") == "true":  # CI installs it (.ci/run): there, a missing browser fails
            pytest.fail(f"in CI the browser test must run, but {why}")
        pytest.skip(f"{why} (outside CI only)")
    browser = HeadlessChromium(executable)
    yield browser
    browser.close()


@pytest.mark.parametrize(("ci", "outcome"), [("true", "1 error"), ("false", "1 skipped")])
def test_without_chromium_the_browser_tests_fail_in_ci_and_skip_elsewhere(tmp_path, ci, outcome):
    """CI must run the browser tests: there a missing Chromium is an error, elsewhere a skip that
    says why (a PATH with no browser on it, in a pytest of its own)."""
    env = {**os.environ, "PATH": str(tmp_path), "CI": ci}
    env.pop("FRC_CHROMIUM", None)
    target = f"{Path(__file__).name}::test_browser_checks_catch_errors_and_blank_pages"
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", target],
                         cwd=Path(__file__).parent, env=env, capture_output=True, text=True, timeout=300)
    assert outcome in run.stdout, run.stdout[-2000:]
    reason = "in CI the browser test must run" if ci == "true" else "chromium is not installed"
    assert reason in run.stdout
    assert "browser tests (real Chromium):" in run.stdout


CAPTION_ROWS = 85
"""Screenshot rows taken by the page's caption and controls (and meshcat's control bar)."""


def drawn(image: np.ndarray, top: int = CAPTION_ROWS) -> np.ndarray:
    """Pixels (below the page's caption and meshcat's control bar) that are not white."""
    return np.any(image[top:] < 0.9, axis=-1)


def test_page_renders_in_chromium_without_errors(chromium, tmp_path):
    scene, trajectory = rhex_trajectory()
    path = mv.write_html(scene, trajectory, tmp_path / "rhex_flip.html")
    png, errors, animation = chromium.load(
        path.as_uri(), "[viewer.animator.duration, viewer.animator.actions.length]")
    (tmp_path / "rhex_flip.png").write_bytes(png)
    assert errors == []
    assert animation[0] == pytest.approx(trajectory.duration, rel=1e-6)  # loaded and played
    assert animation[1] >= len(scene.robot.link_names)
    image = read_png(png)
    height, width = image.shape[:2]
    assert (height, width) >= (400, 700)
    mask = drawn(image)
    assert not mask[-12:].any(), "the stage is not white (meshcat's own background?)"
    assert mask.mean() > 0.03, "the scene was not drawn"
    # The ground slab is wider than the view: its rows are (almost) fully inked.
    ground_rows = np.nonzero(mask.mean(axis=1) > 0.95)[0]
    assert len(ground_rows) >= 3
    # The robot is framed: it neither fills the view nor touches its sides.
    robot = mask.copy()
    robot[ground_rows] = False
    columns = np.nonzero(robot.any(axis=0))[0]
    assert 0.4 * width < columns.max() - columns.min() < width - 10
    # Up looks up: the force arrows (red) stand above the ground; +x is to the right: the
    # large forces are on the contacts right of x = 0 (the middle of the drawing).
    pixels = image[CAPTION_ROWS:]
    red = (pixels[..., 0] > 0.6) & (pixels[..., 1] < 0.35) & (pixels[..., 2] < 0.35)
    rows, cols = np.nonzero(red)
    assert len(rows) > 200
    assert rows.mean() < ground_rows.mean()
    assert cols.mean() > width / 2


def test_browser_checks_catch_errors_and_blank_pages(chromium, tmp_path):
    """Negative controls: the same checks fail on a broken page and on a blank one."""
    broken = tmp_path / "broken.html"
    broken.write_text("<!DOCTYPE html><html><body><script>console.error('drawn wrong');"
                      "undefinedFunction();</script><script>Promise.reject(new Error('no fetch'));"
                      "</script><img src='missing.png'></body></html>")
    _, errors, _ = chromium.load(broken.as_uri())
    text = "\n".join(errors)
    assert "undefinedFunction is not defined" in text
    assert "no fetch" in text  # an unhandled rejection, as a failed fetch() in a meshcat page
    assert "drawn wrong" in text
    assert "ERR_FILE_NOT_FOUND" in text
    blank = tmp_path / "blank.html"
    blank.write_text("<!DOCTYPE html><html><body></body></html>")
    png, errors, _ = chromium.load(blank.as_uri())
    assert errors == []
    assert drawn(read_png(png)).mean() < 0.001


def test_served_viewer_draws_in_chromium(chromium):
    scene, trajectory = rhex_trajectory()
    url = mv.serve(scene, trajectory)
    try:
        commands = meshcat_commands(mv.server_at(url).static_html())
        png, errors, animation = chromium.load(url, "viewer.animator.duration", commands)
    finally:
        mv.stop_server(url)
    assert errors == []
    assert animation == pytest.approx(trajectory.duration, rel=1e-6)
    assert drawn(read_png(png)).mean() > 0.03


@pytest.fixture(scope="module")
def flip_page(tmp_path_factory):
    """The page of the real flip (planned and simulated): the body ends upright, right of its start."""
    from frcontrol.planning.flip import plan_flip
    from frcontrol.planning.flip_loop import simulate_flip

    scene = load_scene("rhex_flip")
    result = simulate_flip(scene, plan=plan_flip(scene))
    assert result.flipped
    page, drawing = mv.scene_html(scene, result.trajectory)
    path = tmp_path_factory.mktemp("flip") / "flip.html"
    path.write_text(page, encoding="utf-8")
    return scene, result.trajectory, drawing, path


def robot_box(image: np.ndarray) -> tuple[float, float, float, float]:
    """(left, right, top, bottom) [px] of what is drawn below the caption, the ground rows left out."""
    mask = drawn(image)
    ground = mask.mean(axis=1) > 0.95
    mask[ground] = False
    rows, columns = np.nonzero(mask)
    return (columns.min(), columns.max(), rows.min() + CAPTION_ROWS, rows.max() + CAPTION_ROWS)


SEEK = """(async () => {
  const frames = () => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
  const slider = document.getElementById("frcontrol-time");
  slider.value = %r;
  slider.dispatchEvent(new Event("input"));
  await frames();
  const body = viewer.scene_tree.find(["meshcat", "frcontrol", "robot", "body"]).object;
  const seen = {x: body.position.x, y: body.position.y, angle: body.rotation.z,
                text: document.getElementById("frcontrol-readout").textContent,
                playingAfterSeek: viewer.animator.playing, max: parseFloat(slider.max)};
  %s
  return seen;
})()"""


@pytest.mark.parametrize("moment", ["end", "middle"])
def test_the_page_frames_the_robot_in_the_centre(chromium, flip_page, moment):
    """The camera follows the robot: at the end of the flip (body upright, 0.3 m right of its
    start) and halfway, the robot's box on screen is centred in the view below the caption."""
    scene, trajectory, drawing, path = flip_page
    seek = None if moment == "end" else SEEK % (float((drawing.times[-1] - drawing.times[0]) / 2), "")
    png, errors, _ = chromium.load(path.as_uri(), seek)
    assert errors == []
    image = read_png(png)
    height, width = image.shape[:2]
    left, right, top, bottom = robot_box(image)
    view_top = mv.CAPTION_FRACTION * height
    assert abs((left + right) / 2 - width / 2) < 0.1 * width, (left, right, width)
    assert abs((top + bottom) / 2 - (view_top + height) / 2) < 0.12 * height, (top, bottom, height)
    assert right - left < 0.9 * width and bottom - top < 0.9 * (height - view_top)
    assert drawing.centers[-1, 0] - drawing.centers[0, 0] > 0.1  # the robot did move right


def test_the_page_has_play_pause_a_time_slider_and_shows_time_and_mode(chromium, flip_page):
    """Seeking with the slider poses the robot as the trajectory's sample at that time, and the
    text shows that time and that sample's contact mode; the button plays and pauses."""
    scene, trajectory, drawing, path = flip_page
    j = len(drawing.samples) // 2
    t = float(drawing.times[j] - drawing.times[0])
    # the mixer barely advances (meshcat's Animations > timeScale): two frames may take longer than
    # the rest of the flip, which would end the animation before it is read
    clicks = """const button = document.getElementById("frcontrol-play");
  viewer.animator.mixer.timeScale = 1e-6;
  button.click(); await frames();
  seen.playingAfterClick = viewer.animator.playing; seen.label = button.textContent;
  button.click(); await frames();
  seen.playingAfterSecondClick = viewer.animator.playing;"""
    _, errors, seen = chromium.load(path.as_uri(), SEEK % (t, clicks))
    assert errors == []
    origin, angle = scene.robot.link_poses(trajectory.q[drawing.samples[j]])["body"]
    assert seen["x"] == pytest.approx(origin[0], abs=1e-5)
    assert seen["y"] == pytest.approx(origin[1], abs=1e-5)
    assert math.cos(seen["angle"] - angle) == pytest.approx(1.0, abs=1e-8)
    mode = trajectory.modes[drawing.samples[j]]
    assert drawing.sample_modes[j] == mode
    assert f"t = {drawing.times[j]:.3f} s of {drawing.times[-1]:.3f} s" in seen["text"]
    assert seen["text"].endswith(f"mode {mode_label(mode, trajectory.contacts)}")  # names beside letters
    assert seen["max"] == pytest.approx(drawing.times[-1] - drawing.times[0])
    assert not seen["playingAfterSeek"]
    assert seen["playingAfterClick"] and seen["label"] == "pause"
    assert not seen["playingAfterSecondClick"]


def test_the_still_page_of_frc_view_frames_the_robot_in_the_centre(chromium, tmp_path, monkeypatch):
    """`frc view rhex_flip` (no flag): the page it writes shows RHex in the middle of the view below
    the caption, not off to one side, and fills neither the width nor the height."""
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(view_app, ["rhex_flip", "-q"])
    assert result.exit_code == 0, result.stderr
    png, errors, _ = chromium.load((tmp_path / "rhex_flip.html").as_uri())
    assert errors == []
    image = read_png(png)
    height, width = image.shape[:2]
    left, right, top, bottom = robot_box(image)
    view_top = mv.CAPTION_FRACTION * height
    assert abs((left + right) / 2 - width / 2) < 0.1 * width, (left, right, width)
    assert abs((top + bottom) / 2 - (view_top + height) / 2) < 0.12 * height, (top, bottom, height)
    assert right - left < width - 10 and bottom - top < 0.9 * (height - view_top)
