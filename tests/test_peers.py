"""The peer benchmark's helpers that need frcontrol alone (``benchmarks/peers.py``).

MuJoCo and Drake are not installed in CI (they are the ``peers`` extra): nothing here imports them,
and one test checks that the benchmark module imports without them.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
# The benchmarks live beside the package, not in it: the checkout goes LAST on the path, so that
# `frcontrol` stays the installed package, here and in every process the other tests spawn (they
# inherit this path; with the checkout first, a service or Dask worker imported the source tree's
# frcontrol, which has no frcontrol.robots, and failed in CI).
if str(REPO) not in sys.path:
    sys.path.append(str(REPO))

from benchmarks import peers  # noqa: E402
from benchmarks.trade import SCENARIOS, build_reference, force_error  # noqa: E402
from frcontrol.scene import load_scene  # noqa: E402

CLOSED_FORM_TOLERANCE = 1e-9
"""[N, or relative] Agreement of the reference forces with the closed forms (the URDFs' inertias are
given to 10 digits, e.g. 0.08333333333 for 1/12)."""

GEOMETRY_TOLERANCE = 1e-12
"""[m] Agreement of placed points (sphere centres, contact points) with their definition."""


def reference(name: str):
    scenario = next(s for s in SCENARIOS if s.name == name)
    return build_reference(scenario, load_scene(name))


def test_the_module_imports_without_mujoco_and_drake():
    code = ("import sys; sys.modules['mujoco'] = None; sys.modules['pydrake'] = None\n"
            "import benchmarks.peers\n"
            "assert 'mujoco' not in [m for m, v in sys.modules.items() if v is not None]")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_rod_reference_is_the_pivot_about_the_sticking_tip():
    # The tip sticks (mode F): the rod pivots about it, I_tip = I + m |r|^2, r = centre - tip.
    ref = reference("rod_on_table")
    scene = ref.scene
    body = peers.peer_body(scene)
    m, g, theta = body.mass, body.gravity, scene.q[2]
    r = 0.5 * np.array([math.cos(theta), math.sin(theta)])
    alpha = -m * g * r[0] / (body.inertia + m * r @ r)
    a_com = alpha * np.array([-r[1], r[0]])
    force = m * (a_com + np.array([0.0, g]))          # on the rod at the tip; n = (0, 1), t = (1, 0)
    assert ref.mode == "F"
    np.testing.assert_allclose(ref.forces, [force[1], force[0]], rtol=CLOSED_FORM_TOLERANCE)
    np.testing.assert_allclose(ref.dv[2], alpha, rtol=CLOSED_FORM_TOLERANCE)


def test_box_reference_is_the_static_equilibrium_on_the_slope():
    # Two corners w = 0.5 m either side of the centre, h = 0.25 m below it: sum lam_N = m g cos a,
    # sum lam_T = m g sin a, moments: lam_N,lower - lam_N,upper = (h / w) m g sin a.
    ref = reference("box_on_slope")
    body = peers.peer_body(ref.scene)
    n = body.contacts[0].normal
    a = math.atan2(-n[0], n[1])
    weight = body.mass * body.gravity
    lower = (weight * math.cos(a) + 0.5 * weight * math.sin(a)) / 2
    upper = weight * math.cos(a) - lower
    assert ref.mode == "FF"
    np.testing.assert_allclose(ref.forces[:2], [lower, upper], rtol=CLOSED_FORM_TOLERANCE)
    np.testing.assert_allclose(ref.forces[2:].sum(), weight * math.sin(a), rtol=CLOSED_FORM_TOLERANCE)


def test_force_error_is_relative_and_ignores_the_internal_forces():
    ref = reference("box_on_slope")
    norm = np.linalg.norm(ref.forces)
    assert force_error(ref, ref.forces) == 0.0
    squeeze = ref.forces + np.array([0.0, 0.0, 0.7, -0.7])   # one corner pulls, the other pushes more
    assert force_error(ref, squeeze) < CLOSED_FORM_TOLERANCE
    pushed = ref.forces + np.array([1e-3, 0.0, 0.0, 0.0])     # normal forces are determined
    assert force_error(ref, pushed) == pytest.approx(1e-3 / norm, rel=1e-9)
    slid = ref.forces + np.array([0.0, 0.0, 1e-3, 1e-3])      # so is the tangential sum
    assert force_error(ref, slid) == pytest.approx(math.sqrt(2) * 1e-3 / norm, rel=1e-9)
    rod = reference("rod_on_table")
    assert rod.internal.shape[1] == 0
    assert force_error(rod, rod.forces * 1.01) == pytest.approx(0.01, rel=1e-9)


@pytest.mark.parametrize("name, inertia", [("rod_on_table", 1 / 12), ("box_on_slope", (1.0 + 0.25) / 12)])
def test_peer_body_has_the_urdf_mass_properties(name, inertia):
    body = peers.peer_body(load_scene(name))
    assert body.mass == pytest.approx(1.0, rel=CLOSED_FORM_TOLERANCE)
    assert body.inertia == pytest.approx(inertia, rel=CLOSED_FORM_TOLERANCE)
    np.testing.assert_allclose(body.com_in_link, 0.0, atol=GEOMETRY_TOLERANCE)


@pytest.mark.parametrize("name", peers.PROBLEMS)
def test_contact_spheres_touch_the_surface_at_the_contact_points(name):
    scene = load_scene(name)
    body = peers.peer_body(scene)
    state = scene.state()
    assert len(body.contacts) == len(scene.active_contacts)
    for contact, source, point in zip(body.contacts, scene.active_contacts, state.contact_points,
                                      strict=True):
        n = contact.normal
        lowest = body.world_from_link(contact.sphere_centre_in_link) - peers.SPHERE_RADIUS * n
        np.testing.assert_allclose(lowest, contact.point_in_world - peers.INITIAL_PENETRATION * n,
                                   atol=GEOMETRY_TOLERANCE)
        assert float(n @ (contact.point_in_world - source.point.surface_point_in_world)) == pytest.approx(
            0.0, abs=GEOMETRY_TOLERANCE)
        np.testing.assert_allclose(contact.point_in_world, point, atol=scene.gap_tolerance)
        assert contact.mu == source.point.mu


def test_world_forces_are_projected_on_normal_and_tangent():
    body = peers.peer_body(load_scene("box_on_slope"))
    c0, c1 = body.contacts
    world = {0: 3.0 * c0.normal + 2.0 * c0.tangent, 1: 5.0 * c1.normal - 1.0 * c1.tangent}
    np.testing.assert_allclose(peers.contact_forces_from_world(body, world), [3.0, 5.0, 2.0, -1.0],
                               atol=1e-12)
    np.testing.assert_allclose(peers.contact_forces_from_world(body, {}), 0.0)


def test_tangential_speed_is_along_the_slope():
    body = peers.peer_body(load_scene("box_on_slope"))
    t, n = body.contacts[0].tangent, body.contacts[0].normal
    assert peers.tangential_speed(body, np.array([*(2e-3 * t), 0.0])) == pytest.approx(2e-3)
    assert peers.tangential_speed(body, np.array([*(4.0 * n), 0.0])) == pytest.approx(0.0, abs=1e-15)


def test_mujoco_model_text_holds_the_body_and_its_contacts():
    body = peers.peer_body(load_scene("box_on_slope"))
    root = ET.fromstring(peers.mujoco_xml(body, peers.MUJOCO_DEFAULTS))
    inertial = root.find("./worldbody/body/inertial")
    assert float(inertial.get("mass")) == body.mass
    assert [float(x) for x in inertial.get("diaginertia").split()] == [body.inertia] * 3
    spheres = root.findall("./worldbody/body/geom")
    assert [float(g.get("friction").split()[0]) for g in spheres] == [c.mu for c in body.contacts]
    planes = root.findall("./worldbody/geom")
    assert len(planes) == 1  # both corners on one slope
    n = body.contacts[0].normal
    np.testing.assert_allclose([float(x) for x in planes[0].get("zaxis").split()], [n[0], 0.0, n[1]])
    assert root.find("option").get("cone") == "elliptic"
    assert [j.get("type") for j in root.findall("./worldbody/body/joint")] == ["slide", "slide", "hinge"]


def test_readme_table_is_generated_from_the_committed_results():
    payload = json.loads((REPO / "benchmarks" / "results" / "peers.json").read_text())
    assert peers.readme_tables(payload) in (REPO / "docs" / "benchmarks.md").read_text()


@pytest.mark.parametrize("setting", [
    peers.COMPLIANT_DEFAULTS,
    peers.CompliantSetting("windowed", stiffness=1e5, rtol=1e-3, window=12.0),
    peers.CompliantSetting("euler", stiffness=1e5, integrator="euler", euler_fraction=0.5, window=2.0),
])
def test_frcontrols_compliant_points_run(setting):
    """The benchmark's own calls into frcontrol (not the peers'): each compliant setting simulates and
    reads finite forces at the active contacts, the tip's normal force pushing up."""
    found = peers.compliant_point(reference("rod_on_table"), setting, 1)
    assert found["valid"], found
    assert math.isfinite(found["error"]) and found["time"] > 0.0, found
    assert found["forces"][0] > 0.0, found
