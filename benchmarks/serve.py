"""Benchmark: the planning service under load, 200 concurrent ``POST /solutions`` for the rod.

Run from the repository root (with frcontrol and its ``serve`` extra installed)::

    python -m benchmarks.serve [--rounds 5] [--requests 200] [--workers 2]

Starts a real ``frc serve`` on a free port of 127.0.0.1 (loopback only), then, per round, sends
``--requests`` requests at once (httpx, one connection each) for the rod on the table at five
inputs, and times each answer and the round. Every answer is checked against the library's (the
same document ``frc analyze rod_on_table --input x=... --json`` prints as ``"solutions"``): a
wrong answer or a failed request stops the benchmark, so an error cannot look fast. Reported:
throughput [requests/s] (requests over the round's wall time), the median and p99 latency of a
request, each the median over the rounds; the latency of one request alone (one keep-alive
connection, median of 50); and, as the reference measured in the same run, the same work in this
process (scene, analysis, solutions; no HTTP, no worker), median of 50.

Writes ``benchmarks/results/serve.json`` and ``benchmarks/results/serve.png``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
INPUTS = [-1.0, -0.5, 0.0, 0.5, 1.0]
"""Inputs x [N] of the requests, in turn."""


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def expected_answers() -> dict[float, dict]:
    """The library's answer per input: ``{"solutions": [...], "input_units": {...}}``, as JSON carries it."""
    from frcontrol.answers import analysis_and_solutions, solutions_payload
    from frcontrol.jsonable import to_jsonable
    from frcontrol.scene import load_scene

    scene = load_scene("rod_on_table")
    out = {}
    for x in INPUTS:
        result, solutions = analysis_and_solutions(scene, {"x": x})
        answer = {"solutions": solutions_payload(result, solutions or []),
                  "input_units": scene.inputs.unit_map()}
        out[x] = json.loads(json.dumps(to_jsonable(answer)))
    return out


def in_process_median(runs: int = 50) -> float:
    """[s] The work of one request in this process: scene, analysis, solutions and their report."""
    from frcontrol.answers import analysis_and_solutions, solutions_payload
    from frcontrol.scene import load_scene

    times = []
    for i in range(runs + 1):
        start = time.perf_counter()
        scene = load_scene("rod_on_table")
        result, solutions = analysis_and_solutions(scene, {"x": INPUTS[i % len(INPUTS)]})
        solutions_payload(result, solutions or [])
        if i:
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def start_server(workers: int) -> tuple[subprocess.Popen, str]:
    """A real ``frc serve`` on a free loopback port, once it answers ``GET /health``."""
    import httpx

    port = free_port()
    process = subprocess.Popen([sys.executable, "-m", "frcontrol", "serve", "--port", str(port), "--workers",
                                str(workers), "--json", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise SystemExit(f"frc serve ended: {process.communicate()[1][-500:]}")
        try:
            if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                return process, url
        except httpx.TransportError:
            time.sleep(0.2)
    process.kill()
    raise SystemExit("frc serve did not answer within 120 s")


async def one_round(url: str, count: int, expected: dict[float, dict]) -> dict:
    """``count`` requests at once; their latencies [s] and the round's wall time [s], answers checked."""
    import httpx

    async def request(http: httpx.AsyncClient, i: int) -> float:
        x = INPUTS[i % len(INPUTS)]
        start = time.perf_counter()
        response = await http.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": x}})
        elapsed = time.perf_counter() - start
        if response.status_code != 200 or response.json() != expected[x]:
            raise SystemExit(f"request {i} (x = {x}): status {response.status_code}, a wrong or failed "
                             f"answer: {response.text[:300]}")
        return elapsed

    limits = httpx.Limits(max_connections=count)
    async with httpx.AsyncClient(base_url=url, timeout=120, limits=limits) as http:
        start = time.perf_counter()
        latencies = await asyncio.gather(*(request(http, i) for i in range(count)))
        wall = time.perf_counter() - start
    ordered = sorted(latencies)
    return {"wall_s": wall, "throughput_rps": count / wall, "median_s": statistics.median(ordered),
            "p99_s": ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))], "latencies_s": list(latencies)}


def one_at_a_time(url: str, expected: dict[float, dict], runs: int = 50) -> float:
    """[s] The median latency of a request alone (one keep-alive connection), answers checked."""
    import httpx

    times = []
    with httpx.Client(base_url=url, timeout=120) as http:
        for i in range(runs):
            x = INPUTS[i % len(INPUTS)]
            start = time.perf_counter()
            response = http.post("/solutions", json={"scene": "rod_on_table", "inputs": {"x": x}})
            times.append(time.perf_counter() - start)
            if response.status_code != 200 or response.json() != expected[x]:
                raise SystemExit(f"x = {x}: status {response.status_code}: {response.text[:300]}")
    return statistics.median(times)


def run(rounds: int, count: int, workers: int) -> dict:
    """Every round against one server, after one warm-up round."""
    expected = expected_answers()
    reference = in_process_median()
    process, url = start_server(workers)
    try:
        asyncio.run(one_round(url, count, expected))  # warm-up
        results = [asyncio.run(one_round(url, count, expected)) for _ in range(rounds)]
        alone = one_at_a_time(url, expected)
    finally:
        process.send_signal(signal.SIGTERM)
        process.communicate(timeout=60)
    summary = {key: statistics.median(r[key] for r in results)
               for key in ("throughput_rps", "median_s", "p99_s", "wall_s")}
    return {"benchmark": "serve", "requests": count, "rounds": rounds, "workers": workers,
            "endpoint": "POST /solutions", "scene": "rod_on_table", "inputs_x": INPUTS,
            "in_process_median_s": reference, "one_at_a_time_median_s": alone, "summary": summary,
            "rounds_detail": [{k: v for k, v in r.items() if k != "latencies_s"} for r in results],
            "latencies_s": [r["latencies_s"] for r in results], "python": platform.python_version(),
            "machine": platform.machine(), "cpus": os.cpu_count(), "load_average_1min": os.getloadavg()[0],
            "date": time.strftime("%Y-%m-%d")}


def plot(result: dict, path: Path) -> None:
    """The latencies of every round (histogram) and each round's throughput."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 3.6))
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2, 1]})
    pooled = [1e3 * t for round_ in result["latencies_s"] for t in round_]
    left.hist(pooled, bins=40, color="#1f77b4")
    s = result["summary"]
    for value, label, colour in ((s["median_s"], "median", "k"), (s["p99_s"], "p99", "#d62728")):
        left.axvline(1e3 * value, color=colour, lw=1.5, label=f"{label} {1e3 * value:.0f} ms")
    left.set_xlabel("latency of a request [ms]")
    left.set_ylabel("requests")
    left.legend(fontsize=8)
    left.set_title(f"{result['requests']} concurrent POST /solutions (rod), {result['rounds']} rounds, "
                   f"{result['workers']} workers", fontsize=9)
    rates = [r["throughput_rps"] for r in result["rounds_detail"]]
    right.bar(range(1, len(rates) + 1), rates, color="#2ca02c")
    right.set_xlabel("round")
    right.set_ylabel("throughput [requests/s]")
    right.set_title(f"median {s['throughput_rps']:.0f} requests/s", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--requests", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    result = run(args.rounds, args.requests, args.workers)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "serve.json").write_text(json.dumps(result, indent=1))
    plot(result, RESULTS / "serve.png")
    s = result["summary"]
    print(f"{result['requests']} concurrent POST /solutions, {result['workers']} workers, "
          f"medians of {result['rounds']} rounds: {s['throughput_rps']:.0f} requests/s, latency median "
          f"{1e3 * s['median_s']:.0f} ms, p99 {1e3 * s['p99_s']:.0f} ms; one request alone "
          f"{1e3 * result['one_at_a_time_median_s']:.1f} ms; the same work in-process "
          f"{1e3 * result['in_process_median_s']:.2f} ms")


if __name__ == "__main__":
    main()
