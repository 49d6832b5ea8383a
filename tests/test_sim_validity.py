"""Simulations say when they leave the model's validity (frcontrol.simulation.validity).

Real scenes and real simulators. A calm run has no warning; a violent run (constant hip
torques on RHex's nearly massless legs) warns of its speeds and its penetration; NaN and energy
from nowhere end a run as "diverged"; the CLI reports each on stderr, in the JSON, and by its exit
code.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import one_error_line
from frcontrol.cli.app import app
from typer.testing import CliRunner

from frcontrol.scene import load_scene
from frcontrol.simulation import simulate_compliant, simulate_rigid
from frcontrol.simulation.validity import (
    DIVERGENCE_FACTOR,
    ENERGY_TOLERANCE,
    SPEED_FACTOR,
    assess,
    validity_limits,
)

runner = CliRunner()
FREE_ROD = 'robot = "rod.urdf"\n[state]\nq = [0.0, 1.0, 0.3]\n[inputs]\ncoordinates = ["x"]\n'


CALM_INPUTS = {"rhex_flip": np.array([-1.0, -3.84])}
"""Inputs that hold a scene at rest where zero does not: RHex's hips in mode FFF (with no torque
its legs give way under the body)."""


@pytest.mark.parametrize("name", ["rod_on_table", "box_on_slope", "table_on_ground", "rhex_flip"])
@pytest.mark.parametrize("simulate", [simulate_rigid, simulate_compliant])
def test_a_calm_run_has_no_warning(name, simulate):
    trajectory = simulate(load_scene(name), CALM_INPUTS.get(name), 0.2, 0.002)
    assert trajectory.status == "completed" and trajectory.warnings == ()
    limits = trajectory.info["validity"]
    assert limits["max_speed"] > 0 and limits["max_penetration"] > 0


def test_the_limits_follow_the_scene():
    """L is the spread of the base origin and the contact points; speeds scale with sqrt(2 g L)."""
    scene = load_scene("rod_on_table")
    run = simulate_rigid(scene, None, 0.01, 0.001)
    limits = validity_limits(scene, run, stiffness=None, dt=0.001)
    assert limits.length == pytest.approx(0.5, rel=1e-9)  # centre to tip of the 1 m rod
    assert limits.max_speed == pytest.approx(SPEED_FACTOR * np.sqrt(2 * 9.81 * 0.5), rel=1e-12)
    soft = validity_limits(scene, run, stiffness=1e4, dt=0.001)
    stiff = validity_limits(scene, run, stiffness=1e6, dt=0.001)
    assert soft.max_penetration > 50 * stiff.max_penetration  # F / k, plus the gap tolerance


@pytest.mark.slow
def test_constant_torques_on_massless_legs_are_reported():
    """Hips beyond 10^4 rad/s, toes striking at hundreds of m/s, centimetres deep: the legs at the
    simulator's default rotor inertia (1e-4 kg m^2; rhex_flip's own 2e-3 keeps them slower)."""
    scene = load_scene("rhex_flip", overrides={"model.armature": 1e-4})
    run = simulate_compliant(scene, {"hip_middle": 10.0, "hip_rear": 10.0}, 0.5, 0.001)
    kinds = {w.kind for w in run.warnings}
    assert run.status == "completed"  # the energy is the inputs' work: no blow-up
    assert {"speed", "penetration"} <= kinds
    assert "energy" not in kinds
    work = run.info["input_work"][-1]
    energy = run.info["energy"] + run.info["elastic_energy"]
    # where the energy went: the inputs did the work (contacts and dampers dissipated some of it)
    assert 0.5 * work < energy[-1] - energy[0] <= (1 + ENERGY_TOLERANCE) * work
    speed = next(w for w in run.warnings if w.kind == "speed")
    assert speed.time < 0.05 and "m/s" in speed.detail


def test_nan_ends_the_run_as_diverged_where_it_happened():
    scene = load_scene("rod_on_table")
    run = simulate_rigid(scene, None, 0.05, 0.001)
    q = run.q.copy()
    q[20, 1] = np.nan
    broken = assess(scene, replace(run, q=q, warnings=()), energy=run.info["energy"],
                    penetration=run.info["max_penetration"], stiffness=None, dt=0.001)
    assert broken.status == "diverged"
    assert broken.failure.time == pytest.approx(run.times[20])
    assert "NaN" in broken.failure.reason and broken.failure.hint
    assert len(broken.times) == 20 and np.all(np.isfinite(broken.q))


def test_energy_from_nowhere_warns_then_diverges():
    scene = load_scene("box_on_slope")
    run = simulate_rigid(scene, None, 0.05, 0.001)
    energy = run.info["energy"].copy()
    scale = validity_limits(scene, run, stiffness=None, dt=0.001).energy_scale

    def check(extra):
        return assess(scene, replace(run, warnings=()), energy=energy + extra,
                      penetration=run.info["max_penetration"], stiffness=None, dt=0.001)

    ramp = np.linspace(0.0, 1.0, len(energy))
    warned = check(0.5 * scale * ramp)  # half of m g L, from no input
    assert warned.status == "completed"
    assert [w.kind for w in warned.warnings] == ["energy"]
    blown = check(2 * DIVERGENCE_FACTOR * (abs(energy[0]) + scale) * ramp)
    assert blown.status == "diverged" and "blow-up" in blown.failure.reason
    assert check(0.0 * ramp).warnings == ()


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy's overflow, which the run reports
def test_a_run_that_overflows_diverges_on_both_models(write_scene):
    """A push so large that the state overflows (rigid) or a speed passes the compliant model's
    divergence bound within the first step."""
    path = write_scene(FREE_ROD)
    for simulate, push in ((simulate_rigid, 1e306), (simulate_compliant, 1e30)):
        run = simulate(load_scene(path), {"x": push}, 0.05, 0.001)
        assert run.status == "diverged", simulate.__name__
        assert run.failure.hint


def test_the_cli_exits_1_on_divergence_with_one_line(write_scene):
    path = write_scene(FREE_ROD)
    for model, push in (("rigid", "1e306"), ("compliant", "1e30")):
        result = runner.invoke(app, ["simulate", str(path), "--model", model, "--input", f"x={push}",
                                     "--duration", "0.05", "--json"])
        assert result.exit_code == 1 and result.stdout == ""
        line = one_error_line(result.stderr)
        assert "diverged at t = " in line and "try a smaller --dt" in line


def test_the_cli_reports_warnings_in_the_json_and_on_stderr():
    result = runner.invoke(app, ["simulate", "rhex_flip", "--model", "compliant", "--duration", "0.1",
                                 "--input", "hip_middle=10", "--input", "hip_rear=10", "--json",
                                 "--set", "model.armature=1e-4",  # the simulator's default: fast legs
                                 "--quiet"])  # no progress lines on a loaded machine: warnings only
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert doc["summary"]["status"] == "completed" and doc["summary"]["validity"]["max_speed"] > 0
    kinds = [w["kind"] for w in doc["warnings"]]
    assert "speed" in kinds and all(set(w) == {"time", "kind", "detail"} for w in doc["warnings"])
    lines = result.stderr.strip().splitlines()
    assert len(lines) == len(doc["warnings"]) and all(line.startswith("frc: warning: t = ") for line in lines)
    calm = runner.invoke(app, ["simulate", "rod_on_table", "--duration", "0.05", "--json", "--quiet"])
    assert calm.exit_code == 0 and json.loads(calm.stdout)["warnings"] == [] and calm.stderr == ""


def test_status_and_failure_are_typed_fields_that_agree():
    """A run's status is a field, never a dict entry; a completed run has no failure, others have one."""
    from frcontrol.errors import InputError
    from frcontrol.simulation.trajectory import SimulationFailure

    run = simulate_rigid(load_scene("rod_on_table"), None, 0.01, 0.001)
    assert run.completed and run.failure is None and run.model == "rigid"
    assert not {"status", "failure", "model", "modes"} & set(run.info)
    with pytest.raises(InputError, match="must not carry a failure"):
        replace(run, failure=SimulationFailure(0.0, "nothing"))
    with pytest.raises(InputError, match="must carry a failure"):
        replace(run, status="failed")
    with pytest.raises(InputError, match="status must be one of"):
        replace(run, status="done")
    failed = replace(run, status="failed", failure=SimulationFailure(0.005, "why", ""))
    summary = failed.to_dict()["summary"]
    assert summary["status"] == "failed" and summary["failure"] == {"time": 0.005, "reason": "why"}


def test_a_diverged_run_cuts_the_nested_series_too():
    """The contact zones' series (nested in info) end where the run does, like the samples."""
    scene = load_scene("peg_on_surface")
    run = simulate_compliant(scene, None, 0.01, 0.001)
    assert run.info["zones"], "the scene has contact zones"
    q = run.q.copy()
    q[5, 0] = np.nan
    broken = assess(scene, replace(run, q=q, warnings=()), energy=run.info["energy"],
                    penetration=run.info["max_penetration"], stiffness=None, dt=0.001)
    assert broken.status == "diverged" and len(broken.times) == 5
    for zone in broken.info["zones"].values():
        assert len(zone["deformation"]) == len(zone["force"]) == 5
