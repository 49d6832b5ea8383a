"""One contract: every ``frc`` command that computes has an endpoint, and both give the same document.

The registered Typer commands and the FastAPI routes are read from the applications themselves: a
command without an endpoint, or an endpoint without a command, fails unless the service's tables
(``COMMANDS_WITHOUT_ENDPOINT``, ``ENDPOINTS_WITHOUT_COMMAND``) say why. Then, for each shipped
scene a command applies to (a planner only on scenes with its ``[task]``), the command's ``--json``
(in-process, Typer's CliRunner) equals the endpoint's answer (the service's worker function,
:func:`frcontrol.service.work.execute`, in-process; the GET routes' own functions),
without :data:`frcontrol.answers.RUN_DEPENDENT_KEYS`. Options the command and the endpoint share
have the same defaults.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer
from conftest import one_error_line
from fastapi.routing import APIRoute
from frcontrol.cli.app import app as cli_app
from typer.testing import CliRunner

from frcontrol.answers import RUN_DEPENDENT_KEYS, without_run_dependent
from frcontrol.scene import read_scene_document, shipped_robots_dir, shipped_scene_names
from frcontrol.service import ServiceConfig, create_app
from frcontrol.service.api import (
    COMMAND_ENDPOINTS,
    COMMANDS_WITHOUT_ENDPOINT,
    ENDPOINTS,
    ENDPOINTS_WITHOUT_COMMAND,
)
from frcontrol.service.work import REQUESTS, execute

runner = CliRunner()

CLI_ONLY_OPTIONS = {
    "*": {"json", "html", "out", "view", "port", "plot", "quiet", "sets", "inputs", "json_output"},
    "atlas": {"figure", "workers", "scheduler", "resume", "max_points"},
}
"""Options of a command that its endpoint has no field for: files written on the caller's machine, a
live view, the terminal's output, the machine's workers (the service has its own, ``frc serve
--workers``) and the point budget (the service's is fixed); ``--set`` and ``--input`` are the
request's ``set`` and ``inputs``, a mapping instead of repeated ``NAME=VALUE``."""

FIELD_OF_OPTION = {("flip", "duration"): "max_time", ("plan", "duration"): "max_time",
                   ("validate", "files"): "scene"}
"""Options whose request field has another name: ``--duration`` of the flip and the task is the field
``max_time`` (the options' former name), and a request validates one scene where the command takes
several files."""

SLOW_CASES = {"gait"}
"""The cases over ~5 s on an idle 2-core machine (marked slow: they still run in CI)."""


def registered_commands() -> set[str]:
    return set(typer.main.get_command(cli_app).commands)


def schema_routes() -> set[str]:
    """Every path the service answers on and documents (its pages and schema aside)."""
    app = create_app(ServiceConfig(workers=1))  # not started: no worker process
    return {r.path for r in app.routes if isinstance(r, APIRoute) and r.include_in_schema}


def test_every_command_has_an_endpoint_and_every_endpoint_a_command():
    commands, paths = registered_commands(), schema_routes()
    assert commands == set(COMMAND_ENDPOINTS) | set(COMMANDS_WITHOUT_ENDPOINT), (
        "a command needs an endpoint (COMMAND_ENDPOINTS) or a reason in COMMANDS_WITHOUT_ENDPOINT: "
        f"{sorted(commands ^ (set(COMMAND_ENDPOINTS) | set(COMMANDS_WITHOUT_ENDPOINT)))}")
    assert not set(COMMAND_ENDPOINTS) & set(COMMANDS_WITHOUT_ENDPOINT)
    endpoints = set(COMMAND_ENDPOINTS.values())
    assert endpoints <= paths, f"endpoints not served: {sorted(endpoints - paths)}"
    jobs = {p for p in paths if p.startswith("/jobs/") and p.removeprefix("/jobs") in paths}
    others = paths - endpoints - jobs
    assert others == set(ENDPOINTS_WITHOUT_COMMAND), (
        "an endpoint needs a command (COMMAND_ENDPOINTS) or a reason in ENDPOINTS_WITHOUT_COMMAND: "
        f"{sorted(others ^ set(ENDPOINTS_WITHOUT_COMMAND))}")
    assert all(reason for reason in {**COMMANDS_WITHOUT_ENDPOINT, **ENDPOINTS_WITHOUT_COMMAND}.values())


def test_the_service_documentation_lists_every_endpoint():
    page = (Path(__file__).parent.parent / "docs" / "service.md").read_text(encoding="utf-8")
    for command, path in COMMAND_ENDPOINTS.items():
        assert f"| `frc {command}" in page and f" {path}`" in page, (command, path)
    for key in RUN_DEPENDENT_KEYS:
        assert f"`{key}`" in page, key


def _kind(path: str) -> str | None:
    """The worker's name for a work endpoint's path; None for the routes the server answers itself."""
    return next((kind for kind, (p, _, _) in ENDPOINTS.items() if p == path), None)


@pytest.mark.parametrize("command", sorted(set(COMMAND_ENDPOINTS) - {"robots", "schema"}))
def test_a_command_and_its_endpoint_have_the_same_options_and_defaults(command):
    request = REQUESTS[_kind(COMMAND_ENDPOINTS[command]) or command]
    fields = request.model_fields
    skipped = CLI_ONLY_OPTIONS["*"] | CLI_ONLY_OPTIONS.get(command, set())
    compared = 0
    for param in typer.main.get_command(cli_app).commands[command].params:
        if param.name in skipped or getattr(param, "hidden", False):
            continue
        name = FIELD_OF_OPTION.get((command, param.name), param.name)
        assert name in fields, f"frc {command}'s {param.name} has no field in {request.__name__}"
        field = fields[name]
        if param.required or field.is_required():
            assert param.required == field.is_required(), (command, name)
        else:
            assert field.default == param.default, (command, name, field.default, param.default)
        compared += 1
    assert compared >= 1


def _cli_json(args: list[str]) -> dict[str, Any]:
    result = runner.invoke(cli_app, [*args, "--json", "--quiet"])
    assert result.exit_code == 0, (args, result.stderr)
    return json.loads(result.stdout)


def _served(path: str, body: dict[str, Any]) -> dict[str, Any]:
    kind = _kind(path)
    if kind is None:  # answered by the server's process: robots, schema (the route's own function)
        [route] = [r for r in create_app(ServiceConfig(workers=1)).routes
                   if isinstance(r, APIRoute) and r.path == path and "GET" in r.methods]
        return json.loads(json.dumps(asyncio.run(route.endpoint())))
    reply = json.loads(execute(kind, json.dumps(body)))
    assert reply["status"] == 200, (path, body, reply)
    return reply["answer"]


def _scene_cases(name: str) -> Iterator[tuple[str, list[str], dict[str, Any]]]:
    """(case, command line, request body) of every command that applies to the scene ``name``."""
    document = read_scene_document(shipped_robots_dir() / "scenes" / f"{name}.toml")
    task = document.get("task", {})
    inputs = document.get("inputs", {}).get("coordinates", [])
    given = {inputs[0]: 1.0} if inputs else {}
    yield "show", ["show", name], {"scene": name}
    yield "validate", ["validate", name], {"scene": name}
    yield "analyze", ["analyze", name, *[f"--input={k}=1" for k in given]], {"scene": name, "inputs": given}
    yield "statics", ["statics", name], {"scene": name}
    yield "simulate", ["simulate", name, "-T", "0.01", "--every", "3"], {"scene": name, "duration": 0.01,
                                                                        "every": 3}
    if "body_contacts" in task or name in ("rhex_flip", "rhex_flip_drives"):  # their tasks are flips
        yield "flip", ["flip", name, "-T", "0.02"], {"scene": name, "max_time": 0.02}
    if "disturbances" in document and ("head_link" in task or "gait" in task):  # the climb's task
        yield "climb", ["climb", name, "--duration", "0.01"], {"scene": name, "duration": 0.01}
    if "upper_brace_contacts" in task or "gait" in task:
        yield "gait", ["climb", name, "--cycles", "1"], {"scene": name, "cycles": 1}
    phases = task.get("phases", [{}])
    if "y" in phases[0].get("track", {}).get("coordinates", {}):  # a stand-up: frc plan's short name
        yield "standup", ["standup", name, "--duration", "0.02"], {"scene": name, "duration": 0.02}
    if "phases" in task:
        yield "plan", ["plan", name, "-T", "0.02"], {"scene": name, "max_time": 0.02}


ENDPOINT_OF_CASE = {**COMMAND_ENDPOINTS, "gait": COMMAND_ENDPOINTS["climb"]}


def _cases() -> list[Any]:
    cases = [pytest.param("robots", ["robots"], {}, id="robots"),
             pytest.param("schema", ["schema"], {}, id="schema")]
    for name in shipped_scene_names():
        for case, args, body in _scene_cases(name):
            marks = [pytest.mark.slow] if case in SLOW_CASES else []
            cases.append(pytest.param(case, args, body, id=f"{case}-{name}", marks=marks))
    return cases


@pytest.mark.parametrize(("case", "args", "body"), _cases())
def test_the_endpoint_answers_what_the_command_prints(case, args, body):
    served = _served(ENDPOINT_OF_CASE[case], body)
    printed = _cli_json(args)
    assert without_run_dependent(served) == without_run_dependent(printed)
    if case == "flip":  # one rule on both sides: the pumping run on a scene whose inputs all have drives
        assert ("pump" in served) == (body["scene"] == "rhex_flip_drives")


@pytest.mark.parametrize(("args", "kind", "body", "field"), [
    (["flip", "rhex_flip", "--compliant", "-T", "0"], "flip", {"compliant": True, "max_time": 0.0},
     "compliant"),
    (["climb", "--duration", "0"], "climb", {"scale": 0.1, "duration": 0.0}, "scale"),
])
def test_an_option_without_the_one_it_needs_is_refused_alike(args, kind, body, field):
    reply = json.loads(execute(kind, json.dumps(body)))
    assert reply["status"] == 422
    [problem] = reply["detail"]
    assert problem["loc"] == ["body", field]
    result = runner.invoke(cli_app, args if kind == "flip" else [*args, "--scale", "0.1"])
    assert result.exit_code == 2 and result.stdout == ""  # an option that needs another: usage
    assert field in one_error_line(result.stderr)


def test_a_scene_with_problems_is_refused_alike_by_the_command_and_the_endpoint(tmp_path):
    """``frc validate`` exits 1 with a line per problem; ``POST /validate`` answers 422 with an item per
    problem (the line without ``frc: error:``), and both carry the same document."""
    toml = 'robot = "rod.urdf"\n[contacts.tip]\nlink = "rod"\npoint = [0.0, 0.0]\nmuu = 0.5\n'
    (tmp_path / "rod.urdf").write_text((shipped_robots_dir() / "rod.urdf").read_text(encoding="utf-8"))
    (tmp_path / "broken.toml").write_text(toml)
    reply = json.loads(execute("validate", json.dumps({"scene": {"toml": toml}})))
    result = runner.invoke(cli_app, ["validate", str(tmp_path / "broken.toml"), "--json"])
    assert reply["status"] == 422 and result.exit_code == 1, (reply, result.stderr)
    served = {key: value for key, value in reply.items() if key not in ("status", "detail")}
    assert without_run_dependent(served) == without_run_dependent(json.loads(result.stdout))
    assert served["valid"] is False
    assert {"field": "state", "reason": "missing"} in served["files"][0]["problems"]
    shown = f"frc: error: {tmp_path / 'broken.toml'}: "
    lines = [line.removeprefix(shown) for line in result.stderr.splitlines()]
    assert [item["msg"].removeprefix("scene: ") for item in reply["detail"]] == lines and len(lines) >= 2
    assert ["body", "scene", "state"] in [item["loc"] for item in reply["detail"]]
    assert {item["type"] for item in reply["detail"]} == {"SceneError"}
    valid = json.loads(execute("validate", json.dumps({"scene": "rod_on_table"})))
    assert valid["status"] == 200 and valid["answer"]["valid"] is True


def test_every_planner_and_driven_scenes_are_compared():
    """The cases reach every command with an endpoint, the pump (driven scene) and the gait."""
    cases = {(case, args[1] if len(args) > 1 else "") for case, args, _ in
             (p.values for p in _cases())}
    reached = {case for case, _ in cases}
    assert set(COMMAND_ENDPOINTS) - {"atlas"} <= reached, set(COMMAND_ENDPOINTS) - reached
    assert {("flip", "rhex_flip_drives"), ("gait", "snake_climb"), ("standup", "solo_standup")} <= cases


def test_the_atlas_job_answers_what_frc_atlas_prints():
    """``POST /atlas``'s job result (checked by the worker, run as the server's thread runs it)."""
    import time

    from frcontrol.service.atlas_job import atlas_work
    from frcontrol.service.pool import Job
    from frcontrol.service.work import scene_source

    body = {"scene": "rod_on_table", "vary": ["input.x=-1:1:3"], "set": {"state.v.x": -1.0}}
    checked = json.loads(execute("atlas", json.dumps(body)))  # as POST /atlas gets it from a worker
    assert checked["status"] == 200, checked
    plan = checked["answer"]
    job = Job(id="contract", kind="atlas", started=time.monotonic())
    reply = atlas_work(plan, scene_source("rod_on_table"), workers=1, scheduler=None,
                       chunk_time_limit=120.0)(job, lambda: False)
    assert reply["status"] == 200, reply
    printed = _cli_json(["atlas", "rod_on_table", "--vary", "input.x=-1:1:3", "--set", "state.v.x=-1",
                         "--workers", "1"])
    assert without_run_dependent(reply["answer"]) == without_run_dependent(printed)
