"""The library's front door: the main calls at the top level, light to import, every module's __all__."""

from __future__ import annotations

import importlib
import pkgutil
import subprocess
import sys

import pytest

import frcontrol
from frcontrol.scene import load_scene


def test_the_main_calls_are_at_the_top_level():
    from frcontrol.engine import analyze, solutions_at
    from frcontrol.planning.climb import plan_climb
    from frcontrol.planning.flip import plan_flip
    from frcontrol.simulation import simulate
    from frcontrol.statics import analyze_statics

    assert frcontrol.analyze is analyze and frcontrol.solutions_at is solutions_at
    assert frcontrol.analyze_statics is analyze_statics and frcontrol.simulate is simulate
    assert frcontrol.plan_flip is plan_flip and frcontrol.plan_climb is plan_climb
    assert set(frcontrol.__all__) <= set(dir(frcontrol))
    with pytest.raises(AttributeError, match="no attribute 'analyse'"):
        frcontrol.analyse  # noqa: B018


def test_import_frcontrol_stays_light(tmp_path):
    code = ("import sys, frcontrol\n"
            "heavy = [m for m in ('frcontrol.engine', 'frcontrol.planning.flip', 'scipy', 'matplotlib', "
            "'meshcat') if m in sys.modules]\n"
            "print(','.join(heavy))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                         timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "", out.stdout + out.stderr


def test_simulate_follows_the_scene_model():
    rigid = frcontrol.simulate(load_scene("rod_on_table"), None, 0.01, 0.005)
    compliant = frcontrol.simulate(load_scene("rod_on_table", overrides={"model.contact": "compliant"}),
                                   None, 0.01, 0.005)
    assert rigid.model == "rigid" and compliant.model == "compliant"


def every_module():
    names = ["frcontrol"]
    for info in pkgutil.walk_packages(frcontrol.__path__, "frcontrol."):
        if not info.name.endswith("__main__"):
            names.append(info.name)
    return names


@pytest.mark.parametrize("name", every_module())
def test_every_module_declares_what_it_exports(name):
    module = importlib.import_module(name)
    assert hasattr(module, "__all__"), f"{name} has no __all__"
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ names what it does not define: {missing}"


def _without_timings(doc):
    if isinstance(doc, dict):
        return {k: _without_timings(v) for k, v in doc.items() if k not in ("timings", "wall_time")}
    if isinstance(doc, list):
        return [_without_timings(v) for v in doc]
    return doc


@pytest.mark.parametrize("command", ["analyze", "statics", "simulate"])
def test_the_cli_json_is_the_result_to_dict(command):
    """The CLI has no JSON of its own: its document is the library result's to_dict()."""
    import json

    from frcontrol.cli.app import app
    from typer.testing import CliRunner

    scene = load_scene("box_on_slope")
    if command == "analyze":
        result = frcontrol.analyze(scene)
        want = result.to_dict([c.name for c in scene.contacts if not c.active])
        args = ["analyze", "box_on_slope"]
    elif command == "statics":
        want = frcontrol.analyze_statics(scene).to_dict()
        args = ["statics", "box_on_slope"]
    else:
        want = frcontrol.simulate_rigid(scene, None, 0.02, 0.001).to_dict(scene)
        args = ["simulate", "box_on_slope", "--duration", "0.02", "--dt", "0.001"]
    out = CliRunner().invoke(app, [*args, "--json"])
    assert out.exit_code == 0, out.stderr
    got = json.loads(out.stdout)
    assert _without_timings(got) == _without_timings(json.loads(json.dumps(want)))


def test_the_cli_and_the_package_load_no_pinocchio_until_a_command_runs(tmp_path):
    """`frc --help` imports the app and its commands only: not Pinocchio, NumPy or a planner; the
    scene and the model load on first use, as the same objects as from their modules."""
    code = ("import sys, frcontrol, frcontrol.cli.app\n"
            "heavy = [m for m in ('pinocchio', 'numpy', 'frcontrol.model', 'frcontrol.scene', 'scipy') "
            "if m in sys.modules]\n"
            "print(','.join(heavy))\n"
            "from frcontrol import Scene, load_scene\n"
            "import frcontrol.model, frcontrol.scene\n"
            "print(load_scene is frcontrol.scene.load_scene and Scene is frcontrol.scene.Scene "
            "and frcontrol.PlanarRobot is frcontrol.model.PlanarRobot)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["", "True"], out.stdout
