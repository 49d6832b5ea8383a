"""The JSON contract as a user's program meets it: real processes, real back-ends, every scene.

Every command that takes ``--json`` runs on every shipped scene as a subprocess of the installed
``frc``: with the default back-ends, and with each LP back-end forced through ``FRC_LP_SOLVER``
(DAQP, HiGHS, ProxSuite) on the commands that reach the LP door. When the exit code is 0, stdout
must hold exactly one JSON document; when it is 1 (a scene without the planner's task, say),
stdout must be empty and stderr one line. Nothing a solver back-end prints may reach either
stream: HiGHS 1.16 prints a banner from C when it is constructed.

The runs go through a thread pool (subprocesses, so both cores work) in one module fixture.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from conftest import one_error_line

from frcontrol.scene import shipped_scene_names

pytestmark = pytest.mark.slow  # every command on every scene, as subprocesses: minutes

SCENES = shipped_scene_names()
BACKENDS = ("daqp", "highs", "proxsuite")
PLANNER_SCENE = {"flip": "rhex_flip", "climb": "snake_climb", "standup": "solo_standup"}
PLANNER_SHORT = {"flip": ["--max-time", "0.05"], "climb": ["--duration", "0.02"],
                 "standup": ["--max-time", "0.02"]}
"""Each planner's short settings (they keep the run small)."""
PLANNER_SCENES = {"flip": ("rhex_flip", "rhex_flip_drives"), "climb": ("snake_climb",),
                  "standup": ("solo_standup", "solo_shift")}
"""The shipped scenes each planner runs on (the others lack its [task] fields; a stand-up is a task
whose first phase tracks the base's height y, as solo_shift's does)."""


def per_scene(scene: str) -> list[list[str]]:
    """The commands with --json on one scene (the planners' short settings keep the run small)."""
    return [
        ["show", scene],
        ["analyze", scene],
        ["statics", scene],
        ["simulate", scene, "--duration", "0.02", "--dt", "0.002"],
        ["validate", scene],
        ["flip", scene, "--max-time", "0.05"],
        ["climb", scene, "--duration", "0.02"],
        ["standup", scene, "--max-time", "0.02"],
        ["view", scene],  # no flag: writes SCENE.html in the run's folder, says so on stderr
    ]


def lp_commands(scene: str) -> list[list[str]]:
    """The commands on one scene whose answer goes through the LP door."""
    out = [["analyze", scene], ["statics", scene],  # the rigid stepper checks ambiguity with the engine
           ["simulate", scene, "--duration", "0.02", "--dt", "0.002"]]
    for command, planned in PLANNER_SCENE.items():
        # the stand-up runs on the default back-end only (time): its LPs are the flip's margin pieces
        # and one LP per piece through the same door
        if scene == planned and command != "standup":
            out.append([command, scene, *PLANNER_SHORT[command]])
    return out


FALLBACKS = [  # paths that reach HiGHS even with DAQP as the default (its second opinion)
    ["statics", "snake_climb", "--lateral-acceleration", "2"],
    ["climb", "--margin", "100"],
    ["analyze", "rod_on_table", "--input", "x=1", "--input", "theta=0.5"],
]
WHOLE = [["robots"], ["schema"]]  # commands that read no scene

RUNS: list[tuple[str | None, tuple[str, ...]]] = (
    [(None, tuple(args)) for scene in SCENES for args in per_scene(scene)]
    + [(backend, tuple(args)) for backend in BACKENDS for scene in SCENES for args in lp_commands(scene)]
    + [(None, tuple(args)) for args in FALLBACKS + WHOLE]
)


def frc_executable() -> list[str]:
    script = Path(sys.executable).with_name("frc")
    return [str(script)] if script.exists() else [sys.executable, "-m", "frcontrol"]


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("json")  # outside the source tree: the installed package runs

    def run(item):
        backend, args = item
        env = {k: v for k, v in os.environ.items() if k != "FRC_LP_SOLVER"}
        if backend is not None:
            env["FRC_LP_SOLVER"] = backend
        done = subprocess.run([*frc_executable(), *args, "--json"], capture_output=True, text=True,
                              cwd=folder, env=env, timeout=300)
        return item, done

    with ThreadPoolExecutor(max_workers=3) as pool:
        return dict(pool.map(run, RUNS))


def ids(item) -> str:
    backend, args = item
    return f"{backend or 'default'}:{' '.join(args)}"


@pytest.mark.parametrize("item", RUNS, ids=[ids(r) for r in RUNS])
def test_stdout_is_one_json_document_or_nothing(outcomes, item):
    done = outcomes[item]
    assert done.returncode in (0, 1), (done.returncode, done.stderr[-2000:])
    assert "Traceback" not in done.stderr
    assert "HiGHS" not in done.stdout + done.stderr, "a solver back-end wrote to stdout or stderr"
    if done.returncode == 0:
        json.loads(done.stdout)  # exactly one document: trailing text would raise
    else:
        assert done.stdout == "", done.stdout[:500]
        one_error_line(done.stderr)


def test_the_planners_run_on_their_scenes_and_refuse_the_others(outcomes):
    for scene in SCENES:
        for command in PLANNER_SCENE:
            args = (command, scene, *PLANNER_SHORT[command])
            done = outcomes[(None, args)]
            expected = 0 if scene in PLANNER_SCENES[command] else 1
            assert done.returncode == expected, (args, done.stderr)
            if expected:
                assert ": task." in done.stderr or ": disturbances" in done.stderr, done.stderr


def test_every_back_end_gives_the_same_analysis(outcomes):
    """The forced back-ends are really used and agree: the same feasible modes on every scene."""
    for scene in SCENES:
        feasible = {}
        for backend in BACKENDS:
            done = outcomes[(backend, ("analyze", scene))]
            assert done.returncode == 0, (backend, scene, done.stderr)
            feasible[backend] = sorted(m["mode"] for m in json.loads(done.stdout)["modes"] if m["feasible"])
        assert feasible["highs"] == feasible["daqp"] == feasible["proxsuite"], (scene, feasible)


def test_an_unknown_forced_back_end_is_one_line(tmp_path):
    env = {**os.environ, "FRC_LP_SOLVER": "cplex"}
    done = subprocess.run([*frc_executable(), "analyze", "rod_on_table", "--json"], capture_output=True,
                          text=True, cwd=tmp_path, env=env, timeout=120)
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.strip() == ("frc: error: solver 'cplex' (from FRC_LP_SOLVER) is not available; "
                                   "installed back-ends: daqp, highs, proxsuite")
