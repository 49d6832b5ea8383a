"""The planning service (frc serve): answers equal the commands' --json; hostile input refused.

Against the app with httpx over real HTTP (the app served by uvicorn in a thread of the test, its
worker processes started by its lifespan), and against a real `frc serve` process on a free
loopback port: the flip planned through it, and 200 concurrent /solutions requests whose answers
equal `frc analyze --input ... --json`'s solutions. Only 127.0.0.1 is ever bound.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from frcontrol.cli.app import app as cli_app
from typer.testing import CliRunner

from frcontrol.answers import without_run_dependent
from frcontrol.scene import read_scene_document, shipped_robots_dir
from frcontrol.service import ServiceConfig, create_app
from frcontrol.service.models import SolutionsAnswer

runner = CliRunner()
ROD_TOML = (shipped_robots_dir() / "scenes" / "rod_on_table.toml").read_text(encoding="utf-8")
TOKEN = "s3cret-token-for-tests"


def cli_json(*args: str) -> dict:
    result = runner.invoke(cli_app, [*args, "--json"])
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


USAGE_ERROR = re.compile(
    r"^Invalid value(?: for '[^']+'(?: / '[^']+')?)?: (?P<message>.*) \(see 'frc [a-z]+ -h'\)$")


def cli_error(*args: str) -> str:
    """The CLI's one-line error, without its 'frc: error: ' prefix: bad input (exit 1) as it is, a
    bad option value (a usage error, exit 2) without the option's name and the help hint around it."""
    result = runner.invoke(cli_app, list(args))
    assert result.exit_code in (1, 2) and result.stdout == "", result.stderr
    line = result.stderr.strip()
    assert line.startswith("frc: error: ") and "\n" not in line
    message = line.removeprefix("frc: error: ")
    usage = USAGE_ERROR.match(message)
    assert (result.exit_code == 2) == (usage is not None), message
    return usage.group("message") if usage else message


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextmanager
def served(config: ServiceConfig, headers: dict[str, str] | None = None):
    """The app on a free loopback port (uvicorn in a thread), and an httpx client of it."""
    import uvicorn

    port = free_port()
    server = uvicorn.Server(uvicorn.Config(create_app(config), host="127.0.0.1", port=port,
                                           log_level="warning", lifespan="on"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 120
    while not server.started:
        assert thread.is_alive() and time.monotonic() < deadline, "the app did not start"
        time.sleep(0.05)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=120, headers=headers) as http:
            yield http
    finally:
        server.should_exit = True
        thread.join(60)


@pytest.fixture(scope="module")
def client():
    with served(ServiceConfig(workers=2, time_limit=60.0, max_body=200_000)) as http:
        yield http


@pytest.fixture(scope="module")
def strict_client():
    """One worker, a 2 s time limit, one job at a time, and a token."""
    config = ServiceConfig(workers=1, time_limit=2.0, max_jobs=1, token=TOKEN)
    with served(config, headers={"Authorization": f"Bearer {TOKEN}"}) as http:
        yield http


def test_info_endpoints(client):
    assert client.get("/health").json() == {"status": "ok", "workers": 2, "workers_configured": 2,
                                            "jobs_running": 0}
    import frcontrol

    assert client.get("/version").json() == {"frcontrol": frcontrol.__version__, "api": "1"}
    robots = cli_json("robots")
    robots.pop("folder")  # a path on this machine: the service reveals none
    assert client.get("/robots").json() == robots
    schema = client.get("/openapi.json").json()
    answer = schema["paths"]["/solutions"]["post"]["responses"]["200"]["content"]["application/json"]
    assert answer["schema"] == {"$ref": "#/components/schemas/SolutionsAnswer"}
    assert {"/analyze", "/solutions", "/statics", "/simulate", "/plan/flip", "/plan/climb", "/plan/standup",
            "/show", "/validate", "/schema", "/atlas", "/jobs/{job_id}", "/health", "/version",
            "/robots"} <= set(schema["paths"])
    assert schema["components"]["schemas"]["SolutionsRequest"]["additionalProperties"] is False
    assert client.get("/docs").status_code == 200


@pytest.mark.parametrize(("path", "body", "args"), [
    ("/analyze", {"scene": "disk_in_wedge", "inputs": {"y": 5.0}},
     ["analyze", "disk_in_wedge", "--input", "y=5"]),
    ("/analyze", {"scene": "rod_on_table", "set": {"contacts.tip.mu": 0.3}},
     ["analyze", "rod_on_table", "--set", "contacts.tip.mu=0.3"]),
    ("/statics", {"scene": "box_on_slope", "lateral_acceleration": 1.0},
     ["statics", "box_on_slope", "--lateral-acceleration", "1"]),
    ("/simulate", {"scene": "rod_on_table", "duration": 0.05, "inputs": {"x": 1.0}},
     ["simulate", "rod_on_table", "-T", "0.05", "--input", "x=1"]),
    ("/plan/climb", {"duration": 0.0}, ["climb", "--duration", "0"]),
])
def test_answers_equal_the_commands_json(client, path, body, args):
    response = client.post(path, json=body)
    assert response.status_code == 200, response.text
    assert without_run_dependent(response.json()) == without_run_dependent(cli_json(*args))


def test_solutions_equal_the_clis_and_a_scene_sent_as_content_equals_the_shipped_one(client):
    cli = cli_json("analyze", "rod_on_table", "--input", "x=-1")
    expected = cli["solutions"]
    assert expected, "the rod has a solution at x = -1"
    assert cli["input_units"] == {"x": "N", "y": "N", "theta": "N m"}
    by_name = client.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": -1.0}})
    assert by_name.status_code == 200
    assert by_name.json() == {"solutions": expected, "input_units": cli["input_units"]}
    SolutionsAnswer.model_validate(by_name.json())  # the documented response model holds it exactly
    by_toml = client.post("/solutions", json={"scene": {"toml": ROD_TOML}, "inputs": {"x": -1.0}})
    assert by_toml.json() == by_name.json()
    document = read_scene_document(shipped_robots_dir() / "scenes" / "rod_on_table.toml")
    urdf = (shipped_robots_dir() / "rod.urdf").read_text(encoding="utf-8")
    sent = {**document, "robot": "my_rod.urdf"}
    by_json = client.post("/solutions", json={"scene": {"json": sent, "robots": {"my_rod.urdf": urdf}},
                                              "inputs": {"x": -1.0}})
    assert by_json.status_code == 200, by_json.text
    assert by_json.json() == by_name.json()


def test_bad_input_is_a_422_with_the_clis_message_and_field_path(client):
    response = client.post("/analyze", json={"scene": "rod_on_table", "set": {"contacts.tip.muu": 0.5}})
    assert response.status_code == 422
    [problem] = response.json()["detail"]
    assert problem["loc"] == ["body", "set", "contacts.tip.muu"]
    assert problem["msg"] == cli_error("analyze", "rod_on_table", "--set", "contacts.tip.muu=0.5")
    response = client.post("/solutions", json={"scene": "rod_on_table", "inputs": {"nope": 1.0}})
    assert response.status_code == 422
    [problem] = response.json()["detail"]
    assert problem["loc"] == ["body", "inputs", "nope"]
    assert problem["msg"] == cli_error("analyze", "rod_on_table", "--input", "nope=1")
    response = client.post("/simulate", json={"scene": "rod_on_table", "stiffness": 1e6, "model": "rigid"})
    assert response.status_code == 422
    assert response.json()["detail"][0]["msg"] == cli_error("simulate", "rod_on_table", "--model", "rigid",
                                                            "--stiffness", "1e6")
    malformed = client.post("/analyze", json={"scene": {"toml": "robot = ["}})
    assert malformed.status_code == 422 and "malformed TOML" in malformed.json()["detail"][0]["msg"]
    invalid = client.post("/validate", json={"scene": {"toml": 'robot = "rod.urdf"'}})  # its document beside
    assert invalid.status_code == 422 and invalid.json()["valid"] is False, invalid.text
    assert {"loc": ["body", "scene", "state"], "msg": "scene: state: missing", "type": "SceneError"} in \
        invalid.json()["detail"]
    assert invalid.json()["files"][0]["problems"] == [{"field": "state", "reason": "missing"}]


@pytest.mark.parametrize(("body", "loc"), [
    ({"scene": "rod_on_table", "bogus": 1}, ["body", "bogus"]),
    ({"scene": "rod_on_table", "margin": 0.1}, ["body", "margin"]),  # /solutions has no margin
    ({"scene": {"toml": ROD_TOML, "extra": 1}}, ["body", "scene", "content", "extra"]),
])
def test_unknown_keys_are_refused(client, body, loc):
    response = client.post("/solutions", json=body)
    assert response.status_code == 422
    refused = [p["loc"] for p in response.json()["detail"] if p["type"] == "extra_forbidden"]
    assert refused == [loc]


@pytest.mark.parametrize("text", ['{"scene": "rod_on_table"', "[1, 2]", '"rod_on_table"', "",
                                  "[" * 50_000 + "]" * 50_000])
def test_malformed_json_and_other_bodies_are_422s(client, text):
    response = client.post("/solutions", content=text, headers={"content-type": "application/json"})
    assert response.status_code == 422 and response.json()["detail"][0]["loc"][0] == "body"


@pytest.mark.parametrize("text", [
    '{"scene": "rod_on_table", "inputs": {"x": NaN}}',
    '{"scene": "rod_on_table", "inputs": {"x": Infinity}}',
    '{"scene": "rod_on_table", "inputs": {"x": 1e999}}',
])
def test_nan_and_infinity_are_refused_naming_the_field(client, text):
    response = client.post("/solutions", content=text, headers={"content-type": "application/json"})
    assert response.status_code == 422
    assert response.json()["detail"][0]["loc"] == ["body", "inputs", "x"]
    nested = text.replace('"inputs": {"x"', '"set": {"gravity"')
    response = client.post("/analyze", content=nested, headers={"content-type": "application/json"})
    assert response.status_code == 422 and response.json()["detail"][0]["loc"] == ["body", "set", "gravity"]


def test_a_huge_body_is_a_413(client):
    response = client.post("/solutions", json={"scene": {"toml": ROD_TOML + "#" * 300_000}})
    assert response.status_code == 413
    assert "200000 bytes" in response.json()["detail"]
    chunked = client.post("/solutions", content=iter([b'{"scene": "', b"x" * 150_000, b"y" * 150_000]),
                          headers={"content-type": "application/json"})
    assert chunked.status_code == 413


@pytest.mark.parametrize(("body", "loc"), [
    ({"scene": "../../etc/passwd"}, ["body", "scene"]),
    ({"scene": "/etc/passwd"}, ["body", "scene"]),
    ({"scene": {"toml": ROD_TOML.replace('robot = "rod.urdf"', 'robot = "../../etc/passwd"')}},
     ["body", "scene", "robot"]),
    ({"scene": {"toml": ROD_TOML.replace('robot = "rod.urdf"', 'robot = "/etc/passwd"')}},
     ["body", "scene", "robot"]),
    ({"scene": "rod_on_table", "set": {"robot": "../../etc/passwd"}}, ["body", "set", "robot"]),
    ({"scene": "rod_on_table", "set": {"robot": "../rod.urdf"}}, ["body", "set", "robot"]),
])
def test_no_file_path_is_ever_read_from_a_request(client, body, loc):
    assert "rod.urdf" in ROD_TOML
    response = client.post("/analyze", json=body)
    assert response.status_code == 422, response.text
    [problem] = response.json()["detail"]
    assert problem["loc"] == loc and problem["type"] == "SceneError"
    assert "root:" not in response.text  # nothing of the file leaks into the answer


def test_urdf_names_sent_with_a_scene_must_be_bare(client):
    body = {"scene": {"toml": ROD_TOML, "robots": {"../../x.urdf": "<robot name='r'/>"}}}
    response = client.post("/analyze", json=body)
    assert response.status_code == 422 and "not a URDF file name" in response.text


def test_a_job_runs_reports_and_gives_the_endpoints_answer(client):
    started = client.post("/jobs/solutions", json={"scene": "rod_on_table", "inputs": {"x": -1.0}})
    assert started.status_code == 202
    job = started.json()
    assert job["state"] == "running" and job["kind"] == "solutions"
    while job["state"] == "running":
        time.sleep(0.1)
        job = client.get(f"/jobs/{job['id']}").json()
    assert job["state"] == "done" and job["progress"] == 1.0 and job["error"] is None
    expected = client.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": -1.0}}).json()
    assert job["result"] == expected
    refused = client.post("/jobs/analyze", json={"scene": "rod_on_table", "set": {"gravity": -1.0}}).json()
    while refused["state"] == "running":
        time.sleep(0.1)
        refused = client.get(f"/jobs/{refused['id']}").json()
    assert refused["state"] == "failed" and refused["result"] is None
    assert refused["error"]["detail"][0]["loc"] == ["body", "set", "gravity"]
    assert client.get("/jobs/nope").status_code == 404 and client.delete("/jobs/nope").status_code == 404


def test_a_flip_job_reports_its_progress(client):
    job = client.post("/jobs/plan/flip", json={"max_time": 0.3}).json()
    seen = set()
    while job["state"] == "running":
        time.sleep(0.05)
        job = client.get(f"/jobs/{job['id']}").json()
        seen.add(job["progress"])
    assert job["state"] == "done", job
    assert any(p is not None and 0 < p < 1 for p in seen), seen  # the simulation's progress
    assert job["result"]["found"] is True and job["result"]["simulation"]["simulated"] is True


# --- POST /atlas: frc atlas as a job ---------------------------------------------------------------

ATLAS_ARGS = ["rod_on_table", "--set", "state.v.x=-1", "--vary", "state.q.theta=0.3:2.8:5",
              "--vary", "contacts.tip.mu=-0.4:2:4", "--chunk-size", "4"]  # mu < 0: points with errors
ATLAS_BODY = {"scene": "rod_on_table", "set": {"state.v.x": -1}, "vary": ["state.q.theta=0.3:2.8:5",
              "contacts.tip.mu=-0.4:2:4"], "chunk_size": 4}


def finished(http: httpx.Client, job: dict, limit: float = 120.0) -> dict:
    """The job once it has ended (polled)."""
    deadline = time.monotonic() + limit
    while job["state"] == "running":
        assert time.monotonic() < deadline, job
        time.sleep(0.1)
        job = http.get(f"/jobs/{job['id']}").json()
    return job


@pytest.fixture(scope="module")
def atlas_job(client):
    """The finished job of ATLAS_BODY."""
    started = client.post("/atlas", json=ATLAS_BODY)
    assert started.status_code == 202, started.text
    assert started.json()["kind"] == "atlas"
    return finished(client, started.json())


@pytest.mark.slow
def test_an_atlas_job_answers_frc_atlas_json(atlas_job):
    job = atlas_job
    assert job["state"] == "done" and job["kind"] == "atlas" and job["error"] is None, job
    assert job["points_done"] == job["points_total"] == 20 and job["progress"] == 1.0
    expected = cli_json("atlas", *ATLAS_ARGS, "--workers", "2")  # the service's 2 workers, as a pool
    assert job["result"]["run"]["executor"] == "pool" and any(job["result"]["errors"][0])
    assert without_run_dependent(job["result"]) == without_run_dependent(expected)


@pytest.mark.slow
def test_an_atlas_scene_sent_as_content_equals_the_shipped_one(client, atlas_job):
    by_name = atlas_job["result"]
    document = read_scene_document(shipped_robots_dir() / "scenes" / "rod_on_table.toml")
    urdf = (shipped_robots_dir() / "rod.urdf").read_text(encoding="utf-8")
    bodies = [{**ATLAS_BODY, "scene": {"toml": ROD_TOML}},
              {**ATLAS_BODY, "scene": {"json": {**document, "robot": "my_rod.urdf"},
                                       "robots": {"my_rod.urdf": urdf}}}]
    started = [client.post("/atlas", json=body) for body in bodies]  # both at once (2 jobs allowed)
    assert [r.status_code for r in started] == [202, 202], [r.text for r in started]
    same = {k: v for k, v in by_name.items() if k not in ("scene", "fingerprint", "timings")}
    same["errors"] = [[e and e.replace("rod_on_table: ", "scene: ") for e in row] for row in same["errors"]]
    assert not any(str(shipped_robots_dir()) in e for row in by_name["errors"] for e in row if e)
    assert any(e for row in same["errors"] for e in row)  # messages name the scene as sent
    for response in started:
        result = finished(client, response.json())["result"]
        assert result["scene"] == "scene" and result["fingerprint"] != by_name["fingerprint"]
        assert {k: result[k] for k in same} == same


@pytest.mark.parametrize(("body", "loc", "args"), [
    ({"vary": ["contacts.tip.muu=0:1:3"]}, ["body", "vary", 0], ["--vary", "contacts.tip.muu=0:1:3"]),
    ({"vary": ["gravity=1:2:2", "state.q.thetaa=0:1:3"]}, ["body", "vary", 1],
     ["--vary", "gravity=1:2:2", "--vary", "state.q.thetaa=0:1:3"]),
    ({"vary": ["input.nope=0:1:3"]}, ["body", "vary", 0], ["--vary", "input.nope=0:1:3"]),
    ({"vary": ["contacts.tip.mu=a:1:3"]}, ["body", "vary", 0], ["--vary", "contacts.tip.mu=a:1:3"]),
    ({"vary": ["gravity=1:2:2"], "set": {"gravity": 3.0}}, ["body", "vary", 0],
     ["--vary", "gravity=1:2:2", "--set", "gravity=3"]),
    ({"vary": ["gravity=1:2:2"], "set": {"contacts.tip.muu": 1.0}}, ["body", "set", "contacts.tip.muu"],
     ["--vary", "gravity=1:2:2", "--set", "contacts.tip.muu=1"]),
    ({"vary": ["gravity=1:2:2"], "inputs": {"xx": 1.0}}, ["body", "inputs", "xx"],
     ["--vary", "gravity=1:2:2", "--input", "xx=1"]),
])
def test_bad_atlas_options_are_422s_with_the_clis_message(client, body, loc, args):
    response = client.post("/atlas", json={"scene": "rod_on_table", **body})
    assert response.status_code == 422, response.text
    [problem] = response.json()["detail"]
    assert problem["loc"] == loc
    cli = cli_error("atlas", "rod_on_table", *args, "--workers", "1")
    # the same message; the service names the option, which the CLI's usage line names before it
    assert problem["msg"] in (cli, f"{args[0]} {cli}")


@pytest.mark.parametrize(("body", "loc"), [
    ({"vary": ["state.q.theta=0:1:1000", "contacts.tip.mu=0:1:1000"]}, ["body", "vary"]),  # too many points
    ({"vary": []}, ["body", "vary"]),
    ({"vary": ["gravity=1:2:2"], "what": "everything"}, ["body", "what"]),
    ({"vary": ["gravity=1:2:2"], "workers": 8}, ["body", "workers"]),  # the service decides
    ({"vary": ["gravity=1:2:2"], "out": "/tmp/x.npz"}, ["body", "out"]),  # no files
    ({"vary": ["gravity=1:2:2"], "chunk_size": 0}, ["body", "chunk_size"]),
    ({"vary": ["gravity=1:2:2"], "scene": "../../etc/passwd"}, ["body", "scene"]),
    ({"vary": ["gravity=1:2:2"], "scene": {"toml": ROD_TOML.replace('robot = "rod.urdf"',
                                                                    'robot = "../../etc/passwd"')}},
     ["body", "scene", "robot"]),
    ({"vary": ["gravity=1:2:2"], "set": {"robot": "../rod.urdf"}}, ["body", "set", "robot"]),
])
def test_atlas_requests_the_service_refuses(client, body, loc):
    response = client.post("/atlas", json={"scene": "rod_on_table", **body})
    assert response.status_code == 422, response.text
    assert [p["loc"] for p in response.json()["detail"]] == [loc]
    assert "root:" not in response.text  # nothing of a file named in the request leaks


def atlas_workers() -> list:
    """The atlas pool's worker processes started by this process (an app served in a thread here)."""
    import multiprocessing

    from frcontrol.atlas.executors import WORKER_NAME

    return [p for p in multiprocessing.active_children() if p.name == WORKER_NAME]


@pytest.mark.slow
def test_an_atlas_job_reports_progress_and_stops_when_cancelled(client):
    # 90,000 statics points (most of a millisecond each): a minute of work, where a solutions atlas
    # of them takes about a second and could finish before its progress is seen three times
    body = {"scene": "rod_on_table", "set": {"state.v.x": -1}, "what": "statics",
            "vary": ["state.q.theta=0.3:2.8:300", "contacts.tip.mu=0:2:300"], "chunk_size": 16}
    job = client.post("/atlas", json=body).json()
    seen = []
    deadline = time.monotonic() + 120
    while len(set(seen)) < 3:  # the points done, seen growing
        assert job["state"] == "running" and time.monotonic() < deadline, job
        time.sleep(0.2)
        job = client.get(f"/jobs/{job['id']}").json()
        assert client.get("/health").json()["jobs_running"] == 1  # answered while the job runs
        if job["points_done"]:
            seen.append(job["points_done"])
    assert seen == sorted(seen) and job["points_total"] == 90_000
    assert len(atlas_workers()) == 2
    cancelled = client.delete(f"/jobs/{job['id']}").json()
    assert cancelled["state"] == "cancelled" and cancelled["result"] is None
    stopped_at = cancelled["points_done"]
    assert stopped_at < 90_000
    deadline = time.monotonic() + 30
    while atlas_workers():  # the job's workers are stopped
        assert time.monotonic() < deadline, atlas_workers()
        time.sleep(0.1)
    after = client.get(f"/jobs/{job['id']}").json()
    assert after["state"] == "cancelled" and after["points_done"] == stopped_at
    assert client.get("/health").json()["jobs_running"] == 0


@pytest.mark.slow
def test_an_atlas_chunk_past_the_time_limit_fails_its_job(strict_client):
    body = {"scene": "rod_on_table", "set": {"state.v.x": -1}, "what": "statics",
            "vary": ["state.q.theta=0.3:2.8:300", "contacts.tip.mu=0:2:300"], "chunk_size": 90000}
    # 90,000 statics points in one chunk: a minute of a worker's time (a solutions atlas of them
    # takes about a second, within the limit)
    job = strict_client.post("/atlas", json=body).json()
    assert strict_client.post("/atlas", json=body).status_code == 429  # one job at a time here
    job = finished(strict_client, job)
    assert job["state"] == "failed" and job["result"] is None, job
    [problem] = job["error"]["detail"]
    assert problem["loc"] == ["body", "chunk_size"] and problem["type"] == "ChunkTimeLimitExceeded"
    assert "time limit of 2 s per chunk" in problem["msg"] and "--out" not in problem["msg"]
    deadline = time.monotonic() + 30
    while atlas_workers():
        assert time.monotonic() < deadline
        time.sleep(0.1)


def test_a_token_is_needed_when_configured(strict_client):
    assert strict_client.get("/health").status_code == 200
    for headers in ({"Authorization": ""}, {"Authorization": "Bearer wrong"}, {"Authorization": TOKEN}):
        response = strict_client.get("/health", headers=headers)
        assert response.status_code == 401 and response.headers["www-authenticate"] == "Bearer"
        answer = strict_client.post("/solutions", json={"scene": "rod_on_table"}, headers=headers)
        assert answer.status_code == 401


SLOW = {"scene": "rod_on_table", "duration": 500.0, "dt": 1e-3}
"""A simulation far longer than the strict client's 2 s limit."""


@pytest.mark.slow
def test_a_slow_request_hits_its_time_limit_and_never_blocks_health(strict_client):
    answers = {}
    slow = threading.Thread(target=lambda: answers.update(slow=strict_client.post("/simulate", json=SLOW)))
    slow.start()
    time.sleep(0.3)  # let it reach the only worker
    health = strict_client.get("/health")
    assert health.status_code == 200 and slow.is_alive()  # answered while the worker is busy
    slow.join(60)
    response = answers["slow"]
    assert response.status_code == 504
    assert "time limit of 2 s" in response.json()["detail"]
    after = strict_client.post("/solutions", json={"scene": "rod_on_table"})  # a fresh worker answers
    assert after.status_code == 200 and "solutions" in after.json()


def test_a_job_can_be_cancelled_and_jobs_are_capped(strict_client):
    job = strict_client.post("/jobs/simulate", json=SLOW).json()
    assert job["state"] == "running"
    assert strict_client.post("/jobs/simulate", json=SLOW).status_code == 429
    assert strict_client.get("/health").json()["jobs_running"] == 1
    cancelled = strict_client.delete(f"/jobs/{job['id']}").json()
    assert cancelled["state"] == "cancelled" and cancelled["result"] is None
    assert strict_client.get(f"/jobs/{job['id']}").json()["state"] == "cancelled"
    assert strict_client.get("/health").json()["jobs_running"] == 0


# --- the command line -----------------------------------------------------------------------------

def test_serve_refuses_other_addresses_without_a_token_and_bad_token_files(tmp_path):
    assert "--token-file" in cli_error("serve", "--host", "0.0.0.0")
    empty = tmp_path / "token.txt"
    empty.write_text("\n")
    assert "first line is empty" in cli_error("serve", "--token-file", str(empty))
    assert "expected a readable file holding the token" in cli_error("serve", "--token-file",
                                                                     str(tmp_path / "missing.txt"))


def test_serve_prints_the_openapi_schema():
    schema = cli_json("serve", "--openapi")
    assert "/plan/flip" in schema["paths"] and schema["info"]["title"] == "frcontrol planning service"


# --- a real frc serve process --------------------------------------------------------------------

@contextmanager
def frc_serve(*options: str):
    """A real `frc serve` on a free loopback port (its URL), stopped with SIGTERM at the end."""
    with frc_serve_process(*options) as (url, _):
        yield url


@contextmanager
def frc_serve_process(*options: str):
    """A real `frc serve` on a free loopback port: its URL and its process, stopped with SIGTERM."""
    port = free_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen([sys.executable, "-m", "frcontrol", "serve", "--port", str(port), *options,
                                "--json", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=env, cwd=Path(__file__).parent)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while True:
        assert process.poll() is None, process.communicate()
        try:
            if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                break
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline, "frc serve did not answer within 120 s"
        time.sleep(0.2)
    try:
        yield url, process
    except BaseException:  # a failed test leaves no server behind (nor its workers)
        process.send_signal(signal.SIGTERM)
        try:
            process.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()
        raise
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert json.loads(out) == {"url": url, "docs": f"{url}/docs"}
    assert "Traceback" not in err


@pytest.fixture(scope="module")
def server():
    with frc_serve("--workers", "2") as url:
        yield url


@pytest.mark.slow
def test_a_real_server_plans_the_flip(server):
    response = httpx.post(f"{server}/plan/flip", json={}, timeout=120)
    assert response.status_code == 200, response.text
    answer = response.json()
    expected = cli_json("flip", "--max-time", "0")
    assert answer["found"] is True and answer["torques"] == expected["torques"]
    assert answer["simulation"]["flipped"] is True


LOAD = 200
INPUTS = [-1.0, -0.5, 0.0, 0.5, 1.0]


async def _load(url: str, count: int) -> list[httpx.Response]:
    limits = httpx.Limits(max_connections=count)
    async with httpx.AsyncClient(base_url=url, timeout=120, limits=limits) as http:
        return await asyncio.gather(*(
            http.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": INPUTS[i % len(INPUTS)]}})
            for i in range(count)))


@pytest.mark.slow
def test_200_concurrent_solutions_all_equal_the_clis(server):
    expected = {x: {key: cli_json("analyze", "rod_on_table", "--input", f"x={x}")[key]
                    for key in ("solutions", "input_units")} for x in INPUTS}
    responses = asyncio.run(_load(server, LOAD))
    assert len(responses) == LOAD
    assert [r.status_code for r in responses] == [200] * LOAD
    for i, response in enumerate(responses):
        assert response.json() == expected[INPUTS[i % len(INPUTS)]]
        SolutionsAnswer.model_validate(response.json())
    assert httpx.get(f"{server}/health").json()["status"] == "ok"


@pytest.mark.slow
def test_a_real_server_runs_atlas_jobs_on_a_dask_cluster():
    if os.environ.get("CI") != "true":
        pytest.importorskip("distributed", reason="Dask distributed is not installed (pip install "
                            "\".[test]\" installs it; CI runs this test)")
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, \
            frc_serve("--workers", "1", "--scheduler", cluster.scheduler_address) as url, \
            httpx.Client(base_url=url, timeout=120) as http:
        started = http.post("/atlas", json=ATLAS_BODY)
        assert started.status_code == 202, started.text
        job = finished(http, started.json())
    assert job["state"] == "done", job
    assert job["result"]["run"]["executor"] == "dask" and job["result"]["run"]["workers"] == 1
    expected = cli_json("atlas", *ATLAS_ARGS, "--workers", "1")
    assert without_run_dependent(job["result"]) == without_run_dependent(expected)  # "run" aside


# --- hostile input and bounded work, against a real frc serve ------------------------------------

def nested(depth: int) -> list:
    """A JSON array nested ``depth`` deep."""
    value: list = []
    for _ in range(depth):
        value = [value]
    return value


HOSTILE = [  # (path, body, loc of the refused field, what the message says)
    ("/analyze", {"scene": "rod_on_table", "set": {"gravity": nested(300)}}, ["body", "set", "gravity"],
     "deeper than 32"),
    ("/analyze", {"scene": {"json": {"robot": "rod.urdf", "contacts": nested(900)}}},
     ["body", "scene", "json", "contacts"], "deeper than 32"),
    ("/analyze", {"scene": {"toml": "a = " + "[" * 3000 + "]" * 3000}}, ["body", "scene"],
     "nests too deeply"),
    ("/analyze", {"scene": {"toml": ROD_TOML, "robots": {"a\x00.urdf": "<robot name='r'/>"}}},
     ["body", "scene", "content", "robots"], "not a URDF file name"),
    ("/analyze", {"scene": {"toml": ROD_TOML, "robots": {"\u00e9\x7f.urdf": "<robot name='r'/>"}}},
     ["body", "scene", "content", "robots"], "not a URDF file name"),
    ("/analyze", {"scene": "rod_on_table", "set": {"robot": "a\x00.urdf"}}, ["body", "set", "robot"],
     "rod_on_table: robot: no URDF"),
    ("/plan/climb", {"seed": -1}, ["body", "seed"], "greater than or equal to 0"),
    ("/simulate", {"scene": "rod_on_table", "duration": 1e9}, ["body", "duration"],
     "asks for 1e+12 samples; a simulation takes at most 1e+07 (MAX_SIMULATION_SAMPLES)"),
    ("/simulate", {"scene": "box_on_slope", "model": "compliant", "stiffness": 1e6, "duration": 1e6},
     ["body", "duration"], "asks for 1e+09 samples; a simulation takes at most 1e+07"),
    ("/simulate", {"scene": "box_on_slope", "model": "compliant", "stiffness": 1e6, "duration": 1e3},
     ["body", "duration"], "needs at least 1e+06 steps of at most max_step = 0.001 s for duration = 1000 s; "
                           "a run takes at most max_steps = 500000"),
    ("/simulate", {"scene": "rod_on_table", "duration": 7500.0, "dt": 1e-3}, ["body", "duration"],
     "1030 MiB of sampled arrays; a simulation takes at most 1024 MiB (MAX_TRAJECTORY_BYTES)"),
    ("/plan/flip", {"max_time": 1e9}, ["body", "max_time"], "MAX_SIMULATION_SAMPLES"),
    ("/solutions", {"scene": "rod_on_table", "inputs": {"x": "1.0"}}, ["body", "inputs", "x"],
     "valid number"),
    ("/solutions", {"scene": "rod_on_table", "inputs": {"x": True}}, ["body", "inputs", "x"],
     "valid number"),
    ("/plan/flip", {"dt": "0.001"}, ["body", "dt"], "valid number"),
    ("/analyze", {"scene": "rod_on_table", "set": {"gravity": 10**400}}, ["body", "set", "gravity"],
     "rod_on_table: gravity: expected a finite number, got an integer of 1329 bits"),
    ("/analyze", {"scene": "rod_on_table", "set": {"contacts.tip.mu": -1}},
     ["body", "set", "contacts.tip.mu"], "rod_on_table: contacts.tip.mu: expected >= 0, got -1"),
]


def client_port(response: httpx.Response) -> int:
    """The local port of the connection a response came on (the same port: the same connection)."""
    return response.extensions["network_stream"].get_extra_info("client_addr")[1]


def test_hostile_input_is_a_422_naming_the_field_and_the_connection_stays(server):
    with httpx.Client(base_url=server, timeout=120) as http:
        port = client_port(http.get("/health"))
        for path, body, loc, message in HOSTILE:
            response = http.post(path, content=json.dumps(body), headers={"content-type": "application/json"})
            assert response.status_code == 422, (path, body, response.text)
            assert response.headers["content-type"] == "application/json"
            problems = response.json()["detail"]
            assert loc in [p["loc"] for p in problems], (loc, problems)
            assert any(message in p["msg"] for p in problems), (message, problems)
            assert str(shipped_robots_dir()) not in response.text and "site-packages" not in response.text
            after = http.get("/health")  # the next request on the same keep-alive connection
            assert after.status_code == 200 and client_port(after) == port, (path, body)
        answered = http.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": -1.0}})
        assert answered.status_code == 200 and client_port(answered) == port


def test_the_cli_refuses_what_the_service_refuses_in_one_line():
    assert cli_error("climb", "--seed", "-1").endswith(">= 0, got -1")
    assert "MAX_SIMULATION_SAMPLES" in cli_error("simulate", "rod_on_table", "-T", "1e9")
    assert "MAX_STEPS" in cli_error("simulate", "box_on_slope", "--model", "compliant", "-T", "1e3")
    assert cli_error("analyze", "rod_on_table", "--set", "contacts.tip.mu=-1") == \
        "rod_on_table: contacts.tip.mu: expected >= 0, got -1"


def worker_pids(server_pid: int) -> list[int]:
    """The pids of a server's worker processes (its children started by multiprocessing's spawn)."""
    pids = []
    for task in Path(f"/proc/{server_pid}/task").iterdir():
        for child in (task / "children").read_text().split():
            cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
            if b"spawn_main" in cmdline and b"resource_tracker" not in cmdline:
                pids.append(int(child))
    return pids


def killed(pid: int) -> None:
    """Kill a process and wait until it has ended: reaped, or a zombie whose every thread has ended.

    (Its main thread shows as a zombie while its other threads, BLAS's, are still ending: until
    then its parent cannot see that it has ended.)
    """
    os.kill(pid, signal.SIGKILL)
    deadline = time.monotonic() + 60
    while True:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            threads = os.listdir(f"/proc/{pid}/task")
        except FileNotFoundError:
            return
        if state in ("Z", "X") and threads == [str(pid)]:
            return
        assert time.monotonic() < deadline, f"process {pid} did not end"
        time.sleep(0.05)


def healthy(http: httpx.Client, workers: int) -> dict:
    """``GET /health`` once it reports ``workers`` workers alive (polled)."""
    deadline = time.monotonic() + 120
    while (health := http.get("/health").json())["workers"] != workers:
        assert time.monotonic() < deadline, health
        time.sleep(0.1)
    return health


@pytest.mark.skipif(not Path("/proc/self/task").is_dir() and os.environ.get("CI") != "true",
                    reason="finding a server's workers reads /proc (Linux); in CI it must run")
def test_a_worker_dead_while_idle_costs_no_request_and_health_counts_the_living():
    with frc_serve_process("--workers", "1") as (url, process), \
            httpx.Client(base_url=url, timeout=120) as http:
        [worker] = worker_pids(process.pid)
        killed(worker)  # dies while idle: the next request goes to its successor
        answered = http.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": -1.0}})
        assert answered.status_code == 200, answered.text
        assert healthy(http, 1)["status"] == "ok"
        [successor] = worker_pids(process.pid)
        assert successor != worker
        killed(successor)
        assert http.get("/health").json() == {"status": "degraded", "workers": 0, "workers_configured": 1,
                                              "jobs_running": 0}
        assert healthy(http, 1) == {"status": "ok", "workers": 1, "workers_configured": 1, "jobs_running": 0}
        assert http.post("/solutions", json={"scene": "rod_on_table"}).status_code == 200


MEMORY_HUNGRY = {"scene": "rod_on_table", "duration": 10.0}
"""A run within the simulation caps whose answer needs far more than 8 MiB (its JSON alone is 2.5 MB)."""


def test_a_request_past_the_worker_memory_limit_is_a_507_and_its_worker_is_replaced():
    with frc_serve_process("--workers", "1", "--worker-memory", "8", "--max-result-bytes", "2048") \
            as (url, process), httpx.Client(base_url=url, timeout=120) as http:
        [worker] = worker_pids(process.pid)
        response = http.post("/simulate", json=MEMORY_HUNGRY)
        assert response.status_code == 507 and response.headers["content-type"] == "application/json"
        assert "--worker-memory" in response.json()["detail"]
        assert http.get("/health").json()["workers"] == 1
        assert worker_pids(process.pid) != [worker]  # replaced
        assert http.post("/solutions", json={"scene": "rod_on_table"}).status_code == 200
        job = finished(http, http.post("/jobs/simulate", json=MEMORY_HUNGRY).json())
        assert job["state"] == "failed" and "--worker-memory" in job["error"]["detail"], job


def test_finished_job_results_are_capped_in_bytes_oldest_dropped_first():
    with frc_serve("--workers", "1", "--max-result-bytes", "2048") as url, \
            httpx.Client(base_url=url, timeout=120) as http:
        large = finished(http, http.post("/jobs/analyze", json={"scene": "rhex_flip"}).json())
        assert large["state"] == "failed" and large["result"] is None
        assert "more than the service keeps (2048 bytes" in large["error"]["detail"]
        ids = [finished(http, http.post("/jobs/solutions", json={"scene": "rod_on_table",
                                                                  "inputs": {"x": -1.0}}).json())["id"]
               for _ in range(6)]
        kept = [http.get(f"/jobs/{job_id}") for job_id in ids]
        present = [r.status_code == 200 for r in kept]
        assert present[-1] and not present[0] and present == sorted(present), present  # the oldest go
        assert sum(len(json.dumps(r.json()["result"])) for r in kept if r.status_code == 200) <= 2048


def test_post_plan_answers_frc_plan_json(client):
    answer = client.post("/plan", json={"scene": "box_slide"})
    assert answer.status_code == 200, answer.text
    served_doc, cli_doc = answer.json(), cli_json("plan", "box_slide")
    served_doc.pop("timings"), cli_doc.pop("timings")
    assert served_doc == cli_doc
    assert served_doc["outcome"]["achieved"] is True
    refused = client.post("/plan", json={"scene": "rod_on_table"})  # no [task]
    assert refused.status_code == 422 and "task.phases" in refused.text


# --- frc serve for programs: the JSON line while it runs, logs on stderr, /docs offline ----------

class _Lines:
    """A pipe's lines as they come (a reader thread), to wait for one with a limit."""

    def __init__(self, stream) -> None:
        import queue

        self.queue: queue.Queue[str | None] = queue.Queue()
        self.seen: list[str] = []
        self.thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self.thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self.queue.put(line)
        self.queue.put(None)  # the pipe closed: the process ended

    def next(self, timeout: float) -> str | None:
        """The next line, or None once the pipe is closed; fails after ``timeout`` seconds."""
        import queue

        try:
            line = self.queue.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"no line within {timeout} s; so far: {''.join(self.seen)[-500:]}") from None
        if line is not None:
            self.seen.append(line)
        return line

    def until(self, found, timeout: float) -> str:
        """Lines until one for which ``found(line)`` holds; fails at the pipe's end or the limit."""
        deadline = time.monotonic() + timeout
        while True:
            line = self.next(max(deadline - time.monotonic(), 0.01))
            assert line is not None, f"ended first: {''.join(self.seen)[-500:]}"
            if found(line):
                return line

    def rest(self) -> str:
        """Everything after what was read, once the pipe is closed."""
        self.thread.join(timeout=60)
        assert not self.thread.is_alive()
        lines = []
        while (line := self.queue.get_nowait()) is not None:
            lines.append(line)
        return "".join(lines)


def _same_origin_links(page: str, base: str) -> list[str]:
    """Every src/href the page references, resolved against ``base``."""
    from html.parser import HTMLParser
    from urllib.parse import urljoin

    links: list[str] = []

    class Links(HTMLParser):
        def handle_starttag(self, tag, attrs):
            links.extend(urljoin(base, value) for name, value in attrs if name in ("src", "href") and value)

    Links().feed(page)
    return links


@pytest.mark.slow
def test_serve_json_prints_its_line_while_serving_logs_on_stderr_and_docs_offline():
    """The {"url", "docs"} line is read from a pipe while the service runs (no unbuffered mode):
    the line means ready, its URL answers; the access log reaches stderr, stdout holds the line
    alone; /docs and every script, style sheet and icon it names come from the service itself."""
    from urllib.parse import urlsplit

    port = free_port()
    buffered = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # a pipe, as programs see it
    process = subprocess.Popen([sys.executable, "-m", "frcontrol", "serve", "--port", str(port),
                                "--workers", "1", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=buffered, cwd=Path(__file__).parent)
    try:
        stdout, stderr = _Lines(process.stdout), _Lines(process.stderr)
        line = stdout.next(timeout=120)  # the line itself says the service listens
        assert line is not None and line.endswith("\n"), (line, process.poll())
        announced = json.loads(line)
        url = f"http://127.0.0.1:{port}"
        assert announced == {"url": url, "docs": f"{url}/docs"}
        with httpx.Client(timeout=60) as http:
            assert http.get(f"{url}/health").json()["status"] == "ok"
            stderr.until(lambda text: '"GET /health HTTP/1.1" 200' in text, timeout=60)  # the access log
            docs = http.get(announced["docs"])
            assert docs.status_code == 200 and "swagger-ui" in docs.text
            links = _same_origin_links(docs.text, announced["docs"])
            assert {"swagger-ui-bundle.js", "swagger-ui.css"} <= {link.rsplit("/", 1)[-1] for link in links}
            for link in links:
                assert urlsplit(link)[:2] == urlsplit(url)[:2], f"/docs loads {link} from elsewhere"
                assert http.get(link).status_code == 200, link
            assert "'/openapi.json'" in docs.text and http.get(f"{url}/openapi.json").status_code == 200
    finally:
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=60)
    assert process.returncode == 0
    assert stdout.rest() == ""  # the JSON line was all of stdout
    log = "".join(stderr.seen) + stderr.rest()
    assert '"GET /docs HTTP/1.1" 200' in log and "Traceback" not in log
