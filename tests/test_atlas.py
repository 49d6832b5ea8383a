"""frc atlas in one process: the grid plan, each point's columns against the library, bad points,
the JSON contract, the table files, resuming after an interruption, the map figure, the CLI's errors.

Real processes (the local pool, signals, killed workers) are in test_atlas_processes.py, Dask in
test_atlas_dask.py.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from frcontrol.cli.app import app
from typer.testing import CliRunner

import frcontrol
from frcontrol.atlas import AMBIGUITY, AtlasWorkers, Axis, build_atlas, parse_axis, read_table, run_atlas
from frcontrol.atlas.store import parts_folder, read_metadata
from frcontrol.errors import InputError, SceneError
from frcontrol.scene import load_scene
from frcontrol.stability import stability_of

runner = CliRunner()
ROD_AXES = ["state.q.theta=0.3:2.8:4", "contacts.tip.mu=0:2:3"]


def test_the_grid_is_a_plan_built_without_solving():
    plan = build_atlas("rod_on_table", ROD_AXES + ["input.x=-1:1:2"], inputs={"y": 1.0},
                       overrides={"state.v.x": -1.0})
    assert plan.shape == (4, 3, 2) and plan.size == 24
    assert [a.path for a in plan.axes] == ["state.q.theta", "contacts.tip.mu", "input.x"]
    np.testing.assert_array_equal(plan.axes[0].values, np.linspace(0.3, 2.8, 4))
    # the first axis is the outermost: index 1 moves the last axis, index 6 the first
    overrides, inputs = plan.point(1)
    assert overrides == {"state.v.x": -1.0, "state.q.theta": 0.3, "contacts.tip.mu": 0.0}
    assert inputs == {"y": 1.0, "x": 1.0}
    assert plan.point(6)[0]["state.q.theta"] == pytest.approx(0.3 + 2.5 / 3)
    covered = [k for c in range(plan.chunk_count) for k in plan.chunk_points(c)]
    assert covered == list(range(plan.size))
    # the chunks depend on the grid, not on who computes them; the fingerprint on every argument
    same = build_atlas("rod_on_table", ROD_AXES + ["input.x=-1:1:2"], inputs={"y": 1.0},
                       overrides={"state.v.x": -1.0})
    assert same.fingerprint == plan.fingerprint and same.chunk_size == plan.chunk_size
    for other in (build_atlas("rod_on_table", ROD_AXES + ["input.x=-1:1:3"], inputs={"y": 1.0},
                              overrides={"state.v.x": -1.0}),
                  build_atlas("rod_on_table", ROD_AXES + ["input.x=-1:1:2"], inputs={"y": 2.0},
                              overrides={"state.v.x": -1.0}),
                  build_atlas("rod_on_table", ROD_AXES + ["input.x=-1:1:2"], inputs={"y": 1.0},
                              overrides={"state.v.x": -1.0}, what="statics")):
        assert other.fingerprint != plan.fingerprint
    big = build_atlas("rod_on_table", ["state.q.theta=0.3:2.8:181", "contacts.tip.mu=0:2:101"])
    assert big.chunk_size == 64 and big.chunk_count == 286


def test_a_grid_value_is_numpys_linspace_to_the_bit_without_building_the_axis():
    rng = np.random.default_rng(24)
    axes = [Axis("x", 0.3, 2.8, 13), Axis("x", 0.0, 5e-324, 3), Axis("x", 1.0, 1.0, 4),
            Axis("x", 2.0, 3.0, 1), Axis("x", -0.0, 0.0, 3), Axis("x", -1e308, 1e307, 7)]
    for _ in range(300):
        start, stop = rng.normal(size=2) * 10.0 ** rng.integers(-12, 12, size=2)
        axes.append(Axis("x", float(start), float(stop), int(rng.integers(1, 3000))))
    for axis in axes:
        one_by_one = np.array([axis.value(i) for i in range(axis.count)])
        assert one_by_one.tobytes() == axis.values.tobytes()  # every bit, the sign of a zero too
        assert one_by_one[-1] == (axis.stop if axis.count > 1 else axis.start)
    # an axis of 10^12 values: numpy.linspace would need 7.3 TiB for one point
    plan = build_atlas("rod_on_table", ["input.x=-1:1:1000000000000"], max_points=10**12)
    last = plan.size - 1
    assert plan.point(0)[1]["x"] == -1.0 and plan.point(last)[1]["x"] == 1.0
    assert plan.point(last // 2)[1]["x"] == float(last // 2) * (2.0 / last) - 1.0
    with pytest.raises(InputError, match="has 1000000000000 values"):
        plan.axes[0].value(plan.size)


def test_a_grid_above_the_point_budget_is_refused_before_the_scene_is_read(tmp_path):
    from frcontrol.atlas import MAX_ATLAS_POINTS

    missing = str(tmp_path / "nothing.toml")  # never read: the budget is checked first
    huge = ["state.q.theta=0:1:1000000000", "contacts.tip.mu=0:2:1000000000"]
    budget = f"1000000000000000000 points .* budget of {MAX_ATLAS_POINTS} points"
    with pytest.raises(InputError, match=budget):
        build_atlas(missing, huge)
    with pytest.raises(InputError, match="budget of 5 points"):
        build_atlas(missing, ["gravity=1:2:6"], max_points=5)
    assert build_atlas("rod_on_table", ["gravity=1:2:6"], max_points=6).size == 6
    with pytest.raises(InputError, match="budget must be >= 1"):
        build_atlas("rod_on_table", ["gravity=1:2:6"], max_points=0)
    with pytest.raises(InputError, match="overflows"):
        parse_axis("gravity=-1e308:1e308:3")


@pytest.mark.parametrize("axis, error, text", [
    ("contacts.tipp.mu=0:1:3", SceneError, "did you mean 'tip'"),
    ("state.q.thet=0:1:3", SceneError, "did you mean 'state.q.theta'"),
    ("contacts.tip.muu=0:1:3", SceneError, "did you mean 'mu'"),
    ("input.thta=0:1:3", InputError, "did you mean input.theta"),
    ("gravity=0:1", InputError, "PATH=START:STOP:N"),
    ("gravity=0:1:0", InputError, "N must be >= 1"),
    ("gravity=0:nan:3", InputError, "finite"),
    ("gravity=a:1:3", InputError, "must be numbers"),
])
def test_a_bad_axis_is_a_typed_error_naming_the_nearest_path(axis, error, text):
    with pytest.raises(error, match=text):
        build_atlas("rod_on_table", [axis])


def test_conflicting_arguments_are_refused():
    with pytest.raises(InputError, match="given twice"):
        build_atlas("rod_on_table", ["gravity=1:2:2", "gravity=1:3:2"])
    with pytest.raises(InputError, match="also set by --set"):
        build_atlas("rod_on_table", ["gravity=1:2:2"], overrides={"gravity": 3.0})
    with pytest.raises(InputError, match="also given by --input"):
        build_atlas("rod_on_table", ["input.x=1:2:2"], inputs={"x": 3.0})
    with pytest.raises(InputError, match="unknown --what"):
        build_atlas("rod_on_table", ["gravity=1:2:2"], what="everything")
    with pytest.raises(InputError, match="at least one"):
        build_atlas("rod_on_table", [])
    assert parse_axis("input.x=-1:1:5") == Axis("input.x", -1.0, 1.0, 5)


def direct(scene_overrides, inputs):
    """What the library says at one point, without the atlas."""
    scene = load_scene("rod_on_table", overrides=scene_overrides)
    found = sorted(frcontrol.solutions_at(scene, inputs), key=lambda s: s.mode)
    from frcontrol.modes import ContactProblem

    problem = ContactProblem.from_scene(scene)
    stable = [None if (v := stability_of(problem, s).stable) is None else bool(v) for s in found]
    return scene, [s.mode for s in found], stable, found


def test_every_point_is_what_the_library_says_there():
    plan = build_atlas("rod_on_table", ROD_AXES + ["input.x=-3:3:2"], overrides={"state.v.x": -1.0})
    result = run_atlas(plan, where=AtlasWorkers(1))
    rows = result.rows
    counts = set()
    for k in range(plan.size):
        overrides, inputs = plan.point(k)
        scene, modes, stable, found = direct(overrides, inputs)
        # a varied pitch moves the tip: the table follows it (gap 0), as when the scene is loaded
        assert scene.contacts[0].active and abs(scene.contacts[0].gap) < 1e-12
        assert rows["error"][k] is None
        assert rows["count"][k] == len(modes) and rows["modes"][k] == modes and rows["stable"][k] == stable
        within = any(s.ambiguity_dim > 0 for s in found)
        assert rows["ambiguous"][k] == AMBIGUITY[int(len(found) > 1) + 2 * int(within)]
        counts.add(rows["count"][k])
    assert counts == {0, 1}  # sliding left, the rod has no rigid solution at some pitches and mu


def test_ambiguity_between_and_within_modes():
    # the rod on the table across an overlap of its modes S, R and F (between modes); the table's
    # legs share its load (within)
    rod = run_atlas(build_atlas("rod_on_table", ["input.x=48.0:49.6:3"],
                                inputs={"y": -49.3379, "theta": 24.0442}), where=AtlasWorkers(1))
    scene = load_scene("rod_on_table")
    for k, amb in enumerate(rod.rows["ambiguous"]):
        u = {"x": float(np.linspace(48.0, 49.6, 3)[k]), "y": -49.3379, "theta": 24.0442}
        found = frcontrol.solutions_at(scene, u)
        assert rod.rows["count"][k] == len(found)
        assert amb in (("between", "both") if len(found) > 1 else ("none", "within"))
    assert any(c > 1 for c in rod.rows["count"])
    table = run_atlas(build_atlas("table_on_ground", ["gravity=5:10:2"]), where=AtlasWorkers(1))
    assert set(table.rows["ambiguous"]) <= {"within", "both"} and table.rows["count"] == [1, 1]


def test_a_bad_point_records_its_error_and_the_sweep_goes_on():
    result = run_atlas(build_atlas("rod_on_table", ["contacts.tip.mu=-1:1:3", "input.x=-60:0:2"]),
                       where=AtlasWorkers(1))
    errors, counts = result.rows["error"], result.rows["count"]
    assert errors[0] == "rod_on_table: contacts.tip.mu: expected >= 0, got -1.0"  # the scene's name, the axis
    assert "got -1.0" in errors[1]
    assert "outside its limits" in errors[2] and errors[3] is None and counts[3] == 1
    assert counts[:3] == [None] * 3 and result.rows["modes"][0] is None


def test_statics_flip_and_climb_add_their_columns():
    statics = run_atlas(build_atlas("box_on_slope", ["contacts.lower.mu=0.1:0.6:2"], what="statics"),
                        where=AtlasWorkers(1))
    report = frcontrol.analyze_statics(load_scene("box_on_slope", overrides={"contacts.lower.mu": 0.6}))
    assert statics.rows["static_equilibrium"][1] is True is bool(report.equilibrium.exists)
    assert statics.rows["force_closure_margin"][1] == pytest.approx(report.force_closure.margin)
    flip = run_atlas(build_atlas("rhex_flip", ["contacts.front_corner.mu=0.2:0.8:2"], what="flip"),
                     where=AtlasWorkers(1))
    plan = frcontrol.plan_flip(load_scene("rhex_flip", overrides={"contacts.front_corner.mu": 0.8}))
    assert flip.rows["found"][1] is plan.found
    assert flip.rows["plan_mode"][1] == (plan.mode if plan.found else None)
    climb = run_atlas(build_atlas("snake_climb", ["gravity=9.81:9.81:1"], what="climb"),
                      where=AtlasWorkers(1))
    plan = frcontrol.plan_climb(load_scene("snake_climb"))
    assert climb.rows["found"] == [plan.found]
    assert climb.rows["max_disturbance_scale"][0] == pytest.approx(plan.max_disturbance_scale)


def invoke(*args):
    return runner.invoke(app, ["atlas", *args])


def test_the_json_contract(tmp_path):
    out = invoke("rod_on_table", "--vary", "state.q.theta=0.3:2.8:3", "--vary", "contacts.tip.mu=0:2:2",
                 "--set", "state.v.x=-1", "--json", "--workers", "1")
    assert out.exit_code == 0, out.stderr
    doc = json.loads(out.stdout)
    contract = {"scene", "what", "axes", "counts", "modes", "stable", "ambiguous", "errors", "timings"}
    assert contract <= set(doc)
    assert doc["scene"] == "rod_on_table" and doc["what"] == "solutions"
    assert [a["path"] for a in doc["axes"]] == ["state.q.theta", "contacts.tip.mu"]
    assert doc["axes"][0]["values"] == np.linspace(0.3, 2.8, 3).tolist()
    for key in ("counts", "modes", "stable", "ambiguous", "errors"):
        assert len(doc[key]) == 3 and all(len(row) == 2 for row in doc[key]), key
    assert all(isinstance(c, int) for row in doc["counts"] for c in row)
    assert all(isinstance(m, list) for row in doc["modes"] for m in row)


def test_npz_and_parquet_read_back_as_the_runs_rows(tmp_path):
    plan = build_atlas("rod_on_table", ["contacts.tip.mu=-0.5:2:3", "state.q.theta=0.3:2.8:4"],
                       overrides={"state.v.x": -1.0})
    for suffix in (".npz", ".parquet"):
        out = tmp_path / f"atlas{suffix}"
        result = run_atlas(plan, where=AtlasWorkers(1), out=out)
        assert not parts_folder(out).exists()
        table = read_table(out)
        assert list(table) == ["index", "contacts.tip.mu", "state.q.theta", "count", "modes", "stable",
                               "ambiguous", "error"]
        assert table["index"] == list(range(plan.size))
        assert table["contacts.tip.mu"] == np.repeat(np.linspace(-0.5, 2, 3), 4).tolist()
        for name in ("count", "modes", "stable", "ambiguous", "error"):
            assert table[name] == result.rows[name], (suffix, name)
        assert None in table["count"] and [] in table["modes"]  # an error point, a point with no solution
        assert read_metadata(out)["plan"]["fingerprint"] == plan.fingerprint


def test_parquet_has_real_nulls_booleans_lists_and_units(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    plan = build_atlas("box_on_slope", ["contacts.lower.mu=-0.2:0.6:3"], what="statics",
                       overrides={"gravity": 9.0})
    result = run_atlas(plan, where=AtlasWorkers(1), out=tmp_path / "box.parquet")
    table = pq.read_table(tmp_path / "box.parquet")
    schema = table.schema
    assert schema.field("count").type == pa.int64() and schema.field("modes").type == pa.list_(pa.string())
    assert schema.field("stable").type == pa.list_(pa.bool_())
    assert schema.field("static_equilibrium").type == pa.bool_()
    assert schema.field("force_closure_margin").type == pa.float64()
    assert schema.field("error").type == pa.string() and not schema.field("index").nullable
    bad = result.rows["error"].index(next(e for e in result.rows["error"] if e))  # mu < 0
    for name in ("count", "modes", "stable", "static_equilibrium", "force_closure_margin", "ambiguous"):
        assert table.column(name).null_count == 1 and table.column(name)[bad].as_py() is None, name
    assert table.column("error").null_count == plan.size - 1
    assert table.column("static_equilibrium").to_pylist() == result.rows["static_equilibrium"]
    assert schema.field("contacts.lower.mu").metadata == {b"unit": b"-"}
    assert schema.field("force_closure_margin").metadata == {b"unit": b"N or N m"}
    meta = json.loads(schema.metadata[b"frcontrol.atlas.metadata"])
    assert meta["set"] == {"gravity": 9.0} and meta["plan"]["fingerprint"] == plan.fingerprint
    assert meta["columns"]["count"] == {"type": "int64", "null": -1, "unit": "-"}
    assert json.loads(schema.metadata[b"frcontrol.atlas"])["fingerprint"] == plan.fingerprint


def test_npz_has_the_same_names_and_a_json_metadata_entry(tmp_path):
    plan = build_atlas("rod_on_table", ["input.x=-60:0:2", "gravity=5:10:2"], overrides={"state.v.x": -1.0})
    parquet, npz = tmp_path / "rod.parquet", tmp_path / "rod.npz"
    run_atlas(plan, where=AtlasWorkers(1), out=parquet)
    run_atlas(plan, where=AtlasWorkers(1), out=npz)
    import pyarrow.parquet as pq

    with np.load(npz) as data:
        arrays = {name: data[name] for name in data.files}
    assert set(arrays) == set(pq.read_schema(parquet).names) | {"atlas_metadata", "atlas_plan"}
    meta = json.loads(str(arrays["atlas_metadata"]))
    assert meta == read_metadata(parquet) and meta["set"] == {"state.v.x": -1.0}
    assert meta["columns"]["gravity"]["unit"] == "m/s^2" and meta["columns"]["input.x"]["count"] == 2
    assert arrays["count"].dtype == np.int64 and arrays["count"][0] == meta["columns"]["count"]["null"]
    assert arrays["error"][0].startswith("input x") or "outside its limits" in arrays["error"][0]


def test_an_interrupted_run_resumes_to_the_same_result(tmp_path):
    plan = build_atlas("rod_on_table", ROD_AXES, overrides={"state.v.x": -1.0}, chunk_size=2)
    whole = run_atlas(plan, where=AtlasWorkers(1))
    out = tmp_path / "rod.npz"
    seen = []

    def stop_after_three(done, total):  # Ctrl-C while the fourth chunk is reported
        seen.append(done)
        if len(seen) == 4:
            raise KeyboardInterrupt("stopped after three chunks")

    with pytest.raises(KeyboardInterrupt, match="stopped after three chunks"):
        run_atlas(plan, where=AtlasWorkers(1), out=out, progress=stop_after_three)
    assert not out.exists() and len(list(parts_folder(out).glob("chunk-*.json"))) == 3
    with pytest.raises(InputError, match="add --resume"):
        run_atlas(plan, where=AtlasWorkers(1), out=out)
    other = build_atlas("rod_on_table", ROD_AXES, overrides={"state.v.x": 1.0}, chunk_size=2)
    with pytest.raises(InputError, match="other arguments"):
        run_atlas(other, where=AtlasWorkers(1), out=out, resume=True)
    resumed = run_atlas(plan, where=AtlasWorkers(1), out=out, resume=True)
    assert resumed.run["resumed_chunks"] == 3 and resumed.run["computed_chunks"] == plan.chunk_count - 3
    assert resumed.rows == whole.rows
    assert read_table(out)["count"] == whole.rows["count"]
    with pytest.raises(InputError, match="needs --out"):
        run_atlas(plan, resume=True)


def test_the_map_has_one_colour_per_count_and_a_legend(tmp_path):
    from frcontrol.viz.atlas_figure import ERROR_LABEL, plot_atlas
    from frcontrol.viz.plots import text_overlaps

    doc = run_atlas(build_atlas("rod_on_table", ["contacts.tip.mu=-0.5:2:6", "state.q.theta=0.3:2.8:5"],
                                overrides={"state.v.x": -1.0}), where=AtlasWorkers(1)).to_dict()
    fig = plot_atlas(doc, tmp_path / "map.png")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["0 solutions", "1 solution", ERROR_LABEL]
    assert not text_overlaps(fig) and (tmp_path / "map.png").read_bytes()[:4] == b"\x89PNG"
    axes = ["gravity=5:10:2", "contacts.tip.mu=0:2:2", "input.x=0:1:2"]
    three = run_atlas(build_atlas("rod_on_table", axes), where=AtlasWorkers(1)).to_dict()
    for figure in ("ambiguous", "modes"):
        assert not text_overlaps(plot_atlas(three, figure=figure))
    assert "input.x = 0" in plot_atlas(three).axes[0].get_title()
    with pytest.raises(InputError, match="no such array"):
        plot_atlas(three, figure="nothing")


@pytest.mark.parametrize("args, code, text", [
    (["--vary", "contacts.tipp.mu=0:1:2"], 1, "did you mean 'tip'"),
    (["--vary", "gravity=1:2:2", "--out", "x.csv"], 2, "suffix must be one of .parquet, .npz"),
    (["--vary", "gravity=1:2:2", "--resume"], 2, "'--resume': it needs --out FILE"),
    (["--vary", "gravity=1:2:2", "--figure", "found"], 2, "not an array of --what solutions"),
    ([], 2, "--vary"),
    (["--vary", "gravity=1:2:2", "--what", "all"], 2, "--what"),
    (["--vary", "gravity=1:2:2", "--workers", "0"], 2, "--workers"),
    (["--vary", "state.q.theta=0:1:1000000000", "--vary", "contacts.tip.mu=0:2:3"], 1,
     "the grid has 3000000000 points (1000000000 x 3), more than the budget of 100000 points"),
    (["--vary", "gravity=1:2:3", "--max-points", "2"], 1, "budget of 2 points"),
    (["--vary", "gravity=1:2:3", "--max-points", "0"], 2, "--max-points"),
])
def test_cli_errors_are_one_line(args, code, text, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = invoke("rod_on_table", *args)
    assert out.exit_code == code, out.stderr
    assert text in out.stderr and out.stdout == ""
    if code == 1:
        assert out.stderr.startswith("frc: error: ") and out.stderr.count("\n") == 1


def test_max_points_raises_the_budget_and_its_help_gives_the_default():
    from frcontrol.atlas import MAX_ATLAS_POINTS

    out = invoke("rod_on_table", "--vary", "gravity=5:10:3", "--max-points", "3", "--json", "--workers", "1")
    assert out.exit_code == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["points"] == 3 and doc["max_points"] == 3  # the budget is reported with the result
    help_text = " ".join(invoke("--help").stdout.split())
    assert f"default: {MAX_ATLAS_POINTS}" in help_text


def test_the_command_offers_every_kind_of_the_library():
    from frcontrol.cli.atlas_cmd import WHATS as CLI_WHATS

    from frcontrol.atlas import WHATS

    assert CLI_WHATS == WHATS


def test_building_a_plan_loads_no_solver(tmp_path):
    import subprocess
    import sys

    code = ("import sys\nfrom frcontrol.atlas import build_atlas\n"
            "plan = build_atlas('rod_on_table', ['state.q.theta=0.3:2.8:181', 'contacts.tip.mu=0:2:101'])\n"
            "heavy = ('frcontrol.engine', 'frcontrol.solvers', 'scipy', 'distributed')\n"
            "print(plan.chunk_count, [m for m in heavy if m in sys.modules])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                         timeout=60)
    assert out.returncode == 0 and out.stdout.split(None, 1) == ["286", "[]\n"], out.stdout + out.stderr


def test_a_scene_given_as_content_sweeps_like_its_file_and_never_reads_a_path(tmp_path):
    from frcontrol.scene import shipped_robots_dir
    from frcontrol.scene_source import SceneSource

    toml = (shipped_robots_dir() / "scenes" / "rod_on_table.toml").read_text(encoding="utf-8")
    urdf = (shipped_robots_dir() / "rod.urdf").read_text(encoding="utf-8")
    sets = {"state.v.x": -1.0}
    by_file = run_atlas(build_atlas("rod_on_table", ROD_AXES, overrides=sets), where=AtlasWorkers(1))
    mine = SceneSource.content(toml=toml.replace('robot = "rod.urdf"', 'robot = "mine.urdf"'),
                               robots={"mine.urdf": urdf})
    plan = build_atlas(mine, ROD_AXES, overrides=sets)
    assert plan.scene == "scene" and plan.fingerprint != by_file.plan.fingerprint
    assert run_atlas(plan, where=AtlasWorkers(1)).rows == by_file.rows
    other = SceneSource.content(toml=toml, robots={"mine.urdf": urdf.replace("rod", "bar")})
    assert build_atlas(other, ROD_AXES, overrides=sets).fingerprint != plan.fingerprint  # URDF text counts
    (tmp_path / "rod.urdf").write_text(urdf, encoding="utf-8")  # a real file at the path named
    for robot in (str(tmp_path / "rod.urdf"), "../rod.urdf"):
        named = SceneSource.content(toml=toml.replace('robot = "rod.urdf"', f'robot = "{robot}"'))
        with pytest.raises(SceneError, match="is a path"):
            build_atlas(named, ROD_AXES)
    with pytest.raises(SceneError, match="is a path"):
        build_atlas(SceneSource.shipped("rod_on_table"), ROD_AXES,
                    overrides={"robot": str(tmp_path / "rod.urdf")})
    with pytest.raises(SceneError, match="did you mean 'rod_on_table'"):
        SceneSource.shipped("rod_on_tabel")
    with pytest.raises(SceneError, match="no shipped scene"):
        SceneSource.shipped(str(tmp_path / "rod.urdf"))
