"""The result figures: no text collides with another, regions are bounded and say so, geometry and
force planes keep equal aspect, and the flip's white means what its legend says.

Overlaps are measured through matplotlib's text extents after the figure is laid out as it is
saved (:func:`frcontrol.viz.plots.text_overlaps`); negative controls show the check can fail.
"""

from __future__ import annotations

import numpy as np
import pytest

from frcontrol.engine import solutions_at
from frcontrol.modes import scene_mode
from frcontrol.planning.climb import plan_climb
from frcontrol.planning.flip import plan_flip
from frcontrol.planning.flip_loop import simulate_flip
from frcontrol.polytope import contains
from frcontrol.scene import load_scene, resolve_scene_path, shipped_robots_dir, shipped_scene_names
from frcontrol.statics import analyze_statics
from frcontrol.viz import figures
from frcontrol.viz.plots import PolygonPanel, new_figure, plot_polygons, save_figure, text_overlaps

ROBOTS = shipped_robots_dir()


BELLY_HIP_ANGLES = ("-2.6130290703247057", "-2.731582523254071")
"""[rad] hip_middle, hip_rear with both toes on the ground when the hips are on the belly face."""


@pytest.fixture(scope="module")
def flip(tmp_path_factory):
    """RHex's flip with its hips on the belly face (y = -0.065 m, the earlier model) and +-40 N m:
    its input box holds inputs with no rigid solution (white), overlapping modes (hatched) and
    small mode domains far from the largest (the zoom panel). The robot as built, hips on the
    mid-plane, has neither overlaps nor small domains within its 13.4 N m."""
    folder = tmp_path_factory.mktemp("belly")
    urdf = (ROBOTS / "rhex_planar.urdf").read_text()
    for x in ("0.2", "0.0", "-0.2"):
        hip = f'<origin xyz="{x} 0 0" rpy="0 0 0"/><axis'
        assert hip in urdf
        urdf = urdf.replace(hip, f'<origin xyz="{x} -0.065 0" rpy="0 0 0"/><axis')
    (folder / "rhex_belly.urdf").write_text(urdf)
    text = resolve_scene_path("rhex_flip").read_text()
    text = text.replace('robot = "rhex_planar.urdf"', f'robot = "{folder / "rhex_belly.urdf"}"')
    text = text.replace("-2.0935884416766974, -2.160839359350283", ", ".join(BELLY_HIP_ANGLES))
    text = text.replace("[-13.4, -13.4]", "[-40.0, -40.0]").replace("[13.4, 13.4]", "[40.0, 40.0]")
    (folder / "rhex_belly.toml").write_text(text)
    scene = load_scene(folder / "rhex_belly.toml")
    plan = plan_flip(scene)
    return scene, plan, simulate_flip(scene, plan=plan)


@pytest.fixture(scope="module")
def climb():
    return plan_climb(load_scene("snake_climb"))


# ------------------------------------------------------------------------ the check itself


def test_text_overlaps_catches_colliding_labels_and_crowded_ticks():
    figure = new_figure(figsize=(4, 3), layout="constrained")
    ax = figure.add_subplot()
    ax.annotate("first label", (0.5, 0.5))
    ax.annotate("second label", (0.52, 0.51))
    ax.annotate("far away", (0.05, 0.9))
    pairs = text_overlaps(figure)
    assert any("first label" in a and "second label" in b for a, b in pairs)
    assert not any("far away" in a or "far away" in b for a, b in pairs)

    crowded = new_figure(figsize=(3, 3), layout="constrained")
    ax = crowded.add_subplot()
    ax.set_xlim(-1000.0, 1000.0)
    ax.set_xticks(np.linspace(-1000, 1000, 21))
    assert any("xtick" in a and "xtick" in b for a, b in text_overlaps(crowded))

    covered = new_figure(figsize=(4, 3), layout="constrained")
    ax = covered.add_subplot()
    ax.plot([0, 1], [0, 1], label="a line with a long legend entry")
    ax.legend(loc="center")
    ax.annotate("under the legend", (0.45, 0.5))
    assert any("under the legend" in a and b == "its axes' legend" for a, b in text_overlaps(covered))


def test_region_labels_skip_the_ones_that_would_collide(tmp_path):
    """Two tiny squares side by side and a big one: the big one's label is written, and of the
    tiny ones only what fits; no label collides."""
    def square(x, y, h):
        A = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
        return A, np.array([x + h, -(x - h), y + h, -(y - h)])

    ax = plot_polygons([square(0, 0, 5), square(8, 8, 0.05), square(8.1, 8.05, 0.05)],
                       labels=["BIG", "TINY1", "TINY2"], panel=PolygonPanel(box=(-10, 10, -10, 10)))
    written = [t.get_text() for t in ax.texts]
    assert "BIG" in written and not {"TINY1", "TINY2"} <= set(written)
    assert text_overlaps(ax.figure) == []
    save_figure(ax.figure, tmp_path / "labels.png")


# ---------------------------------------------------------------------------------- the flip


@pytest.mark.slow
def test_flip_figure_has_no_overlap_and_explains_every_colour(flip):
    scene, plan, result = flip
    for figure in (figures.flip_figure(result), figures.flip_figure(plan)):
        assert text_overlaps(figure) == []
        left = figure.axes[0]
        entries = [t.get_text() for t in left.get_legend().get_texts()]
        assert figures.NO_MODE_LABEL in entries and "two modes (ambiguous)" in entries
        assert left.get_aspect() == 1.0  # two torques in N m: one scale
        written = [t.get_text() for t in left.texts]
        # every mode over every scene contact (the form every output shows)
        assert scene_mode(plan.mode, plan.contacts, plan.scene_contacts) in written  # the plan's region
        modes = {scene_mode(m.mode, plan.contacts, plan.scene_contacts) for m in plan.analysis.feasible_modes}
        assert set(written) <= modes and all(w in entries for w in written)


def test_white_in_the_flip_figure_is_where_the_rigid_model_has_no_solution(flip):
    """The legend calls the white 'no mode: no rigid solution': inputs outside every feasible
    mode's T_c have no rigid solution, inputs inside have one (sampled over the input box)."""
    scene, plan, _ = flip
    analysis = plan.analysis
    names = analysis.problem.inputs
    rng = np.random.default_rng(3)
    outside = inside = 0
    for u in rng.uniform(analysis.problem.lower, analysis.problem.upper, size=(80, len(names))):
        covered = any(contains(mode.input_domain, u) for mode in analysis.feasible_modes)
        solutions = solutions_at(scene, dict(zip(names, u, strict=True)))
        assert covered == bool(solutions), (u, [s.mode for s in solutions])
        outside += not covered
        inside += covered
    assert outside > 10 and inside > 10  # both colours were sampled


# --------------------------------------------------------------------------------- the climb


def test_climb_figure_is_bounded_equal_aspect_and_has_no_overlap(climb):
    figure = figures.plot_climb(climb)
    assert text_overlaps(figure) == []
    lower, upper = climb.problem.box
    for i, ax in enumerate(figure.axes):
        assert ax.get_aspect() == 1.0
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        # the analysis box, which bounds the robust region, is inside the view with room around it
        assert x0 < lower[2 * i] and upper[2 * i] < x1 and y0 < lower[2 * i + 1] and upper[2 * i + 1] < y1
        for patch in ax.patches:
            vertices = patch.get_xy() if hasattr(patch, "get_xy") else None
            if isinstance(vertices, np.ndarray) and vertices.ndim == 2:
                assert np.all(vertices[:, 0] >= x0 - 1e-9) and np.all(vertices[:, 0] <= x1 + 1e-9)
    entries = [t.get_text() for t in figure.legends[0].get_texts()]
    assert "analysis box (cuts the region)" in entries


# ------------------------------------------------------------------------------- statics


STATICS_CASES = [(name, a) for name in shipped_scene_names() for a in (0.0, 2.0)]


@pytest.mark.parametrize(("name", "lateral"), STATICS_CASES)
def test_statics_figures_have_no_overlap_and_say_what_is_cut(name, lateral, tmp_path):
    scene = load_scene(name)
    report = analyze_statics(scene, lateral_acceleration=lateral)
    figure = figures.plot_statics(scene, report, tmp_path / f"{name}.png")
    assert text_overlaps(figure) == []
    ax = figure.axes[0]
    assert ax.get_aspect() == 1.0
    x0, x1 = ax.get_xlim()
    support = report.support
    legend = ax.get_legend()
    if support.feasible:
        entries = [t.get_text() for t in legend.get_texts()]
        interval = next(e for e in entries if e.startswith("support interval"))
        assert ("unbounded" in interval) == (not np.isfinite(support.x_min) or not np.isfinite(support.x_max))
        bar = next(line for line in ax.get_lines() if line.get_label() == interval)
        assert x0 <= min(bar.get_xdata()) and max(bar.get_xdata()) <= x1  # cut at the view
        if not support.bounded and lateral and support.region is not None and report.support.feasible:
            assert any("cut at the view" in e for e in entries if e.startswith("support region"))


@pytest.mark.parametrize(("name", "lateral", "whole"),
                         [("snake_climb", 2.0, True), ("box_on_slope", 1.0, False)])
def test_a_support_region_covering_the_whole_view_is_a_tint_not_a_flood(name, lateral, whole):
    """The snake braced in its channel may stand anywhere in the view: its region is a faint tint
    that the legend explains, not dots over the drawing; a region that ends in the view is hatched."""
    scene = load_scene(name)
    report = analyze_statics(scene, lateral_acceleration=lateral)
    ax = figures.plot_statics(scene, report).axes[0]
    region = next(p for p in ax.patches if p.get_label().startswith("support region"))
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    A, b = report.support.region.A, report.support.region.b
    assert bool(np.all(A @ corners.T <= b[:, None] + 1e-9)) == whole  # the oracle: the region itself
    assert ("covers all of it" in region.get_label()) == whole
    assert (not region.get_hatch()) == whole
    assert (region.get_alpha() is not None and region.get_alpha() < 0.1) == whole


@pytest.mark.slow
def test_the_flip_figure_zooms_on_the_small_domains_and_labels_them(flip):
    """RHex's smaller mode domains sit within a few N m of zero torque in a +-40 N m box: a second
    panel frames every one of them (checked against their vertices), at equal aspect, and labels
    more modes than the whole box can."""
    from frcontrol.viz.plots import polygon_from_halfplanes

    scene, plan, result = flip
    window = figures.flip_zoom_window(plan)
    assert window is not None
    problem = plan.analysis.problem
    through = np.array([plan.torques[n] for n in problem.inputs])
    boxes = {}
    for mode in plan.analysis.feasible_modes:
        if mode.inputs_full_dimensional:
            A, b = figures.input_slice(mode.feasible_input_domain, (0, 1), through)
            v = polygon_from_halfplanes(A, b, (-50.0, 50.0, -50.0, 50.0))
            boxes[scene_mode(mode.mode, plan.contacts, plan.scene_contacts)] = (v.min(axis=0), v.max(axis=0))
    largest = max(boxes, key=lambda name: np.prod(boxes[name][1] - boxes[name][0]))
    for name, (low, high) in boxes.items():
        if name != largest:
            assert window[0] < low[0] and high[0] < window[1] and window[2] < low[1] and high[1] < window[3]
    span = problem.upper - problem.lower
    assert window[1] - window[0] < 0.5 * span[0] and window[3] - window[2] < 0.5 * span[1]  # a real zoom
    for figure in (figures.flip_figure(result), figures.flip_figure(plan)):
        main, zoom = figure.axes[0], figure.axes[1]
        assert zoom.get_xlim() == pytest.approx(window[:2]) and zoom.get_ylim() == pytest.approx(window[2:])
        assert zoom.get_aspect() == 1.0 and text_overlaps(figure) == []
        in_main = {t.get_text() for t in main.texts}
        in_zoom = {t.get_text() for t in zoom.texts}
        assert in_zoom <= set(boxes) and len(in_main | in_zoom) > len(in_main)


@pytest.mark.parametrize("name", shipped_scene_names())
def test_scene_pictures_have_no_overlap_and_equal_aspect(name):
    """`frc view SCENE --plot`: the contacts' names, ticks and title never collide; x and y in metres
    share one scale."""
    from frcontrol.viz.plots import plot_scene

    ax = plot_scene(load_scene(name))
    assert text_overlaps(ax.figure) == []
    assert ax.get_aspect() == 1.0
    contacts = {c.name for c in load_scene(name).contacts}
    assert contacts <= {t.get_text() for t in ax.texts}
