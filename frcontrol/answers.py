"""Each command's answer: one function per ``frc`` command, building the JSON its ``--json`` prints.

The command line and the planning service (``frc serve``) answer the same questions with the same
documents: a command parses its options, calls its ``*_answer`` function here and prints or writes
files; the command's endpoint calls the same function with the request's fields (the table in
docs/service.md). Where a default depends on the scene (``frc flip`` pumps on a scene whose inputs
all have drives), the rule lives here, once. These functions hold no I/O: progress is a callback,
files and rendering stay with the caller.

Two runs of one command differ only in :data:`RUN_DEPENDENT_KEYS` (wall-clock timings, and paths
on the machine that ran it, which the service never reveals).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import InputError

if TYPE_CHECKING:
    from .atlas import AtlasPlan
    from .engine import DynamicResponse, RigidSolution
    from .scene import Scene
    from .scene_source import SceneSource
    from .simulation.trajectory import Trajectory

CONTACT_MODELS = ("rigid", "compliant")
"""The contact models a simulation can run on (``frc simulate --model``)."""

RUN_DEPENDENT_KEYS = frozenset({"timings", "wall_time", "elapsed", "run", "folder", "file"})
"""The keys, at any depth, in which two answers to the same question may differ: wall-clock figures
[s] (``timings``, ``wall_time``, ``elapsed``), how an atlas ran (``run``: its executor and worker
count), and paths on the machine that answered (``folder`` of ``frc robots``, ``file`` of ``frc
validate``: the service names a scene, never a path). Everything else of a command's ``--json``
equals its endpoint's answer."""

DESCRIPTION_CHARS = 120
"""[characters] The longest description ``frc robots`` gives (the comment's first sentence, cut at a word)."""

Progress = Callable[[float, float], None]
"""Called with (done, total) as long work advances: simulated time [s], or phases, or points."""


class OptionConflict(InputError):
    """An option given without the one it needs: ``compliant`` without the pump, ``scale`` without ``cycles``.

    Attributes:
        field: the option given (a request's field, a command's option without its dashes).
    """

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        super().__init__(message)


@dataclass(frozen=True)
class Answer:
    """A command's answer: the document its ``--json`` prints and its endpoint returns.

    Attributes:
        kind: which answer it is: the command's name, or ``"pump"`` (``frc flip`` pumping) and
            ``"gait"`` (``frc climb --cycles``), whose documents have shapes of their own.
        document: the JSON document (NumPy values allowed: :func:`frcontrol.jsonable.to_jsonable`).
        result: the library's result the document was built from (a plan, a run, a report), which
            the command's figure is drawn from; None when there is none.
        trajectory: the simulated motion, for ``--html``, ``--out`` and the live view (None:
            nothing was simulated).
        modes: the contact mode of each sample of ``trajectory``, for the page (None: not recorded).
    """

    kind: str
    document: dict[str, Any]
    result: Any = None
    trajectory: Trajectory | None = None
    modes: tuple[str, ...] | None = None


def without_run_dependent(document: Any) -> Any:
    """``document`` without :data:`RUN_DEPENDENT_KEYS`, at any depth: what two answers must share."""
    if isinstance(document, dict):
        return {k: without_run_dependent(v) for k, v in document.items() if k not in RUN_DEPENDENT_KEYS}
    if isinstance(document, list):
        return [without_run_dependent(v) for v in document]
    return document


def analysis_and_solutions(
    scene: Scene, inputs: Mapping[str, float] | None, progress: Callable[[str], None] | None = None,
    stage: Callable[[str], None] | None = None,
) -> tuple[DynamicResponse, list[RigidSolution] | None]:
    """Every contact mode at the scene's state and, when ``inputs`` is given, every rigid solution there.

    Args:
        scene: the loaded scene.
        inputs: named input values [N or N m] (inputs not named are 0), or None for no solutions.
        progress: called with each mode's name (the scene's letters) as its evaluation starts.
        stage: called with each later stage's description as it starts (:func:`~frcontrol.engine.analyze`).

    Raises:
        InputError, CoordinateNotFound: see :func:`frcontrol.scene.parse_input_assignments`.
    """
    from .engine import analyze, solutions_at
    from .scene import parse_input_assignments

    result = analyze(scene, progress=progress, stage=stage)
    solutions = None if inputs is None else solutions_at(result, parse_input_assignments(scene, inputs))
    return result, solutions


def solutions_payload(result: DynamicResponse, solutions: list[RigidSolution]) -> list[dict[str, Any]]:
    """The ``"solutions"`` of ``frc analyze --input ... --json``: each solution with its stability."""
    from .modes import add_scene_modes
    from .stability import solution_report

    problem = result.problem
    reports = [solution_report(problem, s) for s in solutions]
    return add_scene_modes({"solutions": reports}, problem.scene_contacts or problem.contacts)["solutions"]


def analysis_payload(scene: Scene, result: DynamicResponse, solutions: list[RigidSolution] | None
                     ) -> dict[str, Any]:
    """The document ``frc analyze --json`` prints (with ``"solutions"`` when solutions were asked for)."""
    payload = result.to_dict([c.name for c in scene.contacts if not c.active])
    if solutions is not None:
        payload["solutions"] = solutions_payload(result, solutions)
    return payload


@dataclass(frozen=True)
class SimulationOptions:
    """The run ``frc simulate`` makes (its options; ``POST /simulate``'s request fields).

    Attributes:
        model: ``"rigid"`` or ``"compliant"``, or None for the scene's ``[model]`` contact.
        stiffness: [N/m] compliant contact stiffness (compliant model only).
        damping: [N s/m] compliant contact damping (compliant model only).
        duration: [s] simulated time.
        dt: [s] the rigid step; the compliant sample interval.
        integrator: the compliant model's integrator.
    """

    model: str | None = None
    stiffness: float | None = None
    damping: float | None = None
    duration: float = 1.0
    dt: float = 1e-3
    integrator: str = "radau"


def run_simulation(scene: Scene, inputs: Mapping[str, float],
                   options: SimulationOptions = SimulationOptions(), *,
                   progress: Callable[[float, float], None] | None = None) -> Trajectory:
    """The run ``frc simulate`` makes: on ``options.model`` (default: the scene's ``[model]`` contact).

    Args:
        scene: the loaded scene.
        inputs: constant named inputs [N or N m].
        options: the model, its contact parameters, the duration, the step and the integrator.
        progress: called with (simulated time [s], duration [s]) as the run advances.

    Raises:
        InputError: an unknown model, or stiffness or damping with the rigid model; see the simulators.
    """
    from .simulation.compliant import CompliantSettings, simulate_compliant
    from .simulation.model_table import model_options
    from .simulation.rigid import simulate_rigid

    model = options.model
    if model is not None and model not in CONTACT_MODELS:
        raise InputError(f"unknown contact model {model!r}; expected one of {', '.join(CONTACT_MODELS)}")
    chosen = model if model is not None else model_options(scene).contact
    if chosen == "rigid" and (options.stiffness is not None or options.damping is not None):
        raise InputError("--stiffness and --damping belong to the compliant model: add --model compliant")
    if chosen == "rigid":
        return simulate_rigid(scene, inputs, options.duration, options.dt, progress=progress)
    settings = CompliantSettings(integrator=options.integrator, stiffness=options.stiffness,
                                 damping=options.damping)
    return simulate_compliant(scene, inputs, options.duration, options.dt, settings=settings,
                              progress=progress)


def simulation_failure(trajectory: Trajectory) -> str | None:
    """Why a run did not complete (the line ``frc simulate`` exits 1 with), or None when it completed."""
    failure = trajectory.failure
    if failure is None:
        return None
    hint = f"; {failure.hint}" if failure.hint else ""
    return f"the simulation {trajectory.status} at t = {failure.time:.6g} s: {failure.reason}{hint}"


# --- what ships, the scene format, scene files ------------------------------------------------


def _leading_comment(path: Path, opener: str, closer: str = "") -> str:
    """The first sentence of a file's leading comment (a URDF's ``<!-- ... -->``, a scene's ``# ...``)."""
    words: list[str] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        text = line.strip()
        if text.startswith("<?xml") or (not text and not words):
            continue
        if not words and not text.startswith(opener):
            break
        if opener == "#" and not text.startswith("#"):
            break
        words.append(text.removeprefix(opener).strip())
        if closer and closer in text:
            break
    comment = " ".join(words).split(closer)[0] if closer else " ".join(words)
    sentence = comment.split(". ")[0].strip().rstrip(".")
    if len(sentence) <= DESCRIPTION_CHARS:
        return sentence
    return sentence[:DESCRIPTION_CHARS].rsplit(" ", 1)[0] + " ..."


def catalog() -> list[dict[str, str]]:
    """Every robot and scene a scene file can name: ``{"kind", "name", "description"}`` rows.

    The shipped URDFs (``robot = "rod.urdf"``), the example-robot-data robots when that package is
    installed (``robot = "example-robot-data:solo/solo12"``), and the shipped scenes.
    """
    from .errors import FrcontrolError
    from .plane import EXAMPLE_ROBOT_DATA_PREFIX, example_robot_data_robots
    from .scene import shipped_robots_dir

    root = shipped_robots_dir()
    rows = [{"kind": "robot", "name": p.name, "description": _leading_comment(p, "<!--", "-->")}
            for p in sorted(root.glob("*.urdf"))]
    try:
        extra = example_robot_data_robots()
    except FrcontrolError:  # example-robot-data not installed: nothing more a scene can name
        extra = {}
    bare = {path: name for name, path in extra.items() if "/" not in name}
    for name, path in extra.items():
        if "/" in name:
            alias = f" (also example-robot-data:{bare[path]})" if path in bare else ""
            rows.append({"kind": "robot", "name": EXAMPLE_ROBOT_DATA_PREFIX + name,
                         "description": f"{path.parent.parent.name}/{path.name} from the example-robot-data "
                                        f"package, a 3-D URDF made planar by the scene's [plane]{alias}"})
    rows += [{"kind": "scene", "name": p.stem, "description": _leading_comment(p, "#")}
             for p in sorted((root / "scenes").glob("*.toml"))]
    return rows


def robots_answer() -> Answer:
    """``frc robots --json`` (``GET /robots``): the shipped URDFs and scenes, and :func:`catalog`.

    The command adds ``"folder"``, where the shipped files are; the service reveals no paths.
    """
    from .scene import shipped_robots_dir

    root = shipped_robots_dir()
    return Answer("robots", {"robots": [p.name for p in sorted(root.glob("*.urdf"))],
                             "scenes": [p.stem for p in sorted((root / "scenes").glob("*.toml"))],
                             "catalog": catalog()})


def schema_answer() -> Answer:
    """``frc schema`` (``GET /schema``): the scene format as a JSON Schema (draft 2020-12)."""
    from .scene_schema import SCENE_SCHEMA

    return Answer("schema", dict(SCENE_SCHEMA))


def _source_problems(source: SceneSource) -> list[dict[str, str]]:
    """A scene sent as a name or as content: every schema problem, else the first the loader finds."""
    from .errors import SceneError
    from .scene import read_scene_document, scene_toml, shipped_robots_dir
    from .scene_schema import schema_problems
    from .scene_source import CONTENT_SOURCE

    try:
        if source.kind == "toml":
            document = scene_toml(source.text, CONTENT_SOURCE)
        elif source.kind == "json":
            document = json.loads(source.text)
        else:  # a file, or a shipped scene by its name (never looked up as a path)
            path = Path(source.text) if source.kind == "file" else (
                shipped_robots_dir() / "scenes" / f"{source.text}.toml")
            document = read_scene_document(path)
        problems = schema_problems(document)
        if problems:
            return [{"field": p.field, "reason": p.reason} for p in problems]
        source.load()
    except SceneError as err:
        return [{"field": err.field, "reason": err.reason}]
    return []


def validation_answer(scenes: Sequence[str | Path | SceneSource]) -> Answer:
    """``frc validate FILE... --json`` (``POST /validate``): every problem of each scene, none when valid.

    Args:
        scenes: scene files or shipped scenes' names, as ``frc validate`` takes them (a missing
            file is one of its problems), or scenes sent as :class:`~frcontrol.scene_source.SceneSource`.

    The document is ``{"valid", "files": [{"file", "valid", "problems": [{"field", "reason"}]}]}``;
    ``file`` is the file's path, or the name or label a scene was sent by.
    """
    from .errors import SceneError
    from .scene import resolve_scene_path, scene_problems

    reports = []
    for scene in scenes:
        if isinstance(scene, (str, Path)):
            problems = [{"field": p.field, "reason": p.reason} for p in scene_problems(scene)]
            try:
                shown = str(resolve_scene_path(scene))
            except SceneError:  # a missing file: one of its problems, already listed
                shown = str(scene)
        else:
            problems, shown = _source_problems(scene), scene.label
        reports.append({"file": shown, "valid": not problems, "problems": problems})
    return Answer("validate", {"valid": all(r["valid"] for r in reports), "files": reports})


def validation_problems(document: Mapping[str, Any]) -> list[tuple[str | None, str]]:
    """Every problem of a :func:`validation_answer` document: ``(field, "FILE: FIELD: REASON")``.

    The line is what ``frc validate`` prints after ``frc: error:`` and what ``POST /validate``'s 422
    gives as a problem's ``msg``; ``field`` is None for a problem of the whole file.
    """
    lines: list[tuple[str | None, str]] = []
    for report in document["files"]:
        for problem in report["problems"]:
            where = f"{report['file']}: {problem['field']}: " if problem["field"] else f"{report['file']}: "
            lines.append((problem["field"] or None, where + problem["reason"]))
    return lines


# --- the model, the modes, statics, simulation --------------------------------------------------


def show_answer(scene: Scene) -> Answer:
    """``frc show --json`` (``POST /show``): the coordinates, M(q), h(q, v) and every contact's rows."""
    state = scene.robot.state(scene.q, scene.v)
    contacts = {}
    for i, contact in enumerate(scene.contacts):
        contacts[contact.name] = {
            "gap": state.gaps[i], "v_n": state.normal_velocities[i], "v_t": state.tangential_velocities[i],
            "jacobian_n": state.jacobian_normal[i], "jacobian_t": state.jacobian_tangent[i],
            "drift_n": state.drift_normal[i], "drift_t": state.drift_tangent[i], "active": contact.active,
            "point": state.contact_points[i],
        }
    return Answer("show", {
        "scene": scene.name, "coordinates": list(scene.coordinate_names), "q": scene.q, "v": scene.v,
        "mass_matrix": state.mass_matrix, "bias": state.bias, "contacts": contacts,
        "inputs": list(scene.inputs.coordinates), "gap_tolerance": scene.gap_tolerance,
    })


def analyze_answer(scene: Scene, inputs: Mapping[str, float] | None = None,
                   progress: Callable[[str], None] | None = None,
                   stage: Callable[[str], None] | None = None) -> Answer:
    """``frc analyze [--input ...] --json`` (``POST /analyze``): every mode; with ``inputs``, the solutions.

    Args:
        scene: the loaded scene.
        inputs: named input values [N or N m], or None for no solutions.
        progress: called with each mode's name (the scene's letters) as its evaluation starts.
        stage: called with each later stage's description as it starts (the overlaps).
    """
    result, solutions = analysis_and_solutions(scene, inputs, progress=progress, stage=stage)
    return Answer("analyze", analysis_payload(scene, result, solutions), result=result)


def solutions_answer(scene: Scene, inputs: Mapping[str, float]) -> Answer:
    """``POST /solutions``: ``"solutions"`` and ``"input_units"`` of ``frc analyze --input ... --json``."""
    result, solutions = analysis_and_solutions(scene, inputs)
    return Answer("solutions", {"solutions": solutions_payload(result, solutions or []),
                                "input_units": scene.inputs.unit_map()}, result=result)


def statics_answer(scene: Scene, inputs: Mapping[str, float] | None = None, *,
                   lateral_acceleration: float = 0.0, strong: bool = True) -> Answer:
    """``frc statics --json`` (``POST /statics``): closure, equilibrium, support region, stability.

    Args:
        scene: the loaded scene.
        inputs: named input values [N or N m] held at rest (inputs not named are 0).
        lateral_acceleration: [m/s^2] the sideways acceleration of the supports the support
            region allows for.
        strong: run the strong-stability test (the mode-domain engine).
    """
    from .statics import analyze_statics

    report = analyze_statics(scene, dict(inputs or {}), lateral_acceleration=lateral_acceleration,
                             strong=strong)
    return Answer("statics", report.to_dict(), result=report)


def simulate_answer(scene: Scene, inputs: Mapping[str, float],
                    options: SimulationOptions = SimulationOptions(), *, every: int = 1,
                    progress: Progress | None = None) -> Answer:
    """``frc simulate --json`` (``POST /simulate``): :func:`run_simulation`'s run, every ``every``-th sample.

    A run that did not complete is an answer too: :func:`simulation_failure` of its trajectory says
    why (the command exits 1 with that line, the service answers 422).
    """
    trajectory = run_simulation(scene, inputs, options, progress=progress)
    return Answer("simulate", trajectory.to_dict(scene, every=every), result=trajectory,
                  trajectory=trajectory)


# --- the planners --------------------------------------------------------------------------------


def driven(scene: Scene) -> bool:
    """Every input of the scene has a DC-motor drive: then ``frc flip`` and ``/plan/flip`` pump by default."""
    return bool(scene.drives) and all(name in scene.drives for name in scene.inputs.coordinates)


def pumps(scene: Scene, pump: bool | None) -> bool:
    """Whether the flip pumps: as asked, or by default (None) when the scene is :func:`driven`."""
    return driven(scene) if pump is None else pump


@dataclass(frozen=True)
class FlipOptions:
    """The flip ``frc flip`` plans and runs (its options; ``POST /plan/flip``'s request fields).

    Attributes:
        margin: [N m] every phase's margin (None: each phase's own).
        max_time: [s] the longest simulated time (0: plan only; None: the task's ``max_time``).
        dt: [s] the simulation's step.
        replan_every: steps between two plans.
        pump: pump over several strokes (None: when the scene is :func:`driven`).
        compliant: with the pump, replay the run's inputs on the compliant model too.
    """

    margin: float | None = None
    max_time: float | None = None
    dt: float = 1e-3
    replan_every: int = 10
    pump: bool | None = None
    compliant: bool = False


def flip_answer(scene: Scene, options: FlipOptions, *, on_simulation: Callable[[], None] | None = None,
                progress: Progress | None = None) -> Answer:
    """``frc flip --json`` (``POST /plan/flip``): the flip task run by the planning core.

    With the pump (:func:`pumps`), the pumping run of :func:`frcontrol.planning.pump.pump_flip`
    (kind ``"pump"``); else the scene's task through :func:`frcontrol.planning.core.plan_task`
    (``frc plan``'s path, :func:`frcontrol.planning.flip_run.run_flip`), reported with the flip's
    keys and ``outcome`` and ``phases`` as ``frc plan`` has them (kind ``"flip"``).

    Args:
        scene: the scene (RHex on its back).
        options: the margin, the simulated time, the step, the re-planning period, the pump.
        on_simulation: called once when the simulation starts.
        progress: called with (simulated time, max_time) along the simulation.

    Raises:
        OptionConflict: ``compliant`` without the pump; see the planners.
    """
    margin, max_time, dt, replan_every = options.margin, options.max_time, options.dt, options.replan_every
    compliant = options.compliant
    if not pumps(scene, options.pump):
        if compliant:
            raise OptionConflict("compliant", "compliant replays the pumping run: it needs the pump (--pump, "
                                 "or a scene whose inputs all have drives)")
        from .planning.flip_run import flip_document, run_flip

        if on_simulation is not None and (max_time is None or max_time > 0):
            on_simulation()
        run = run_flip(scene, margin=margin, max_time=max_time, dt=dt, replan_every=replan_every,
                       progress=progress)
        trajectory = None if run.plan is None else run.plan.trajectory
        modes = None if trajectory is None or trajectory.modes is None else tuple(trajectory.modes)
        return Answer("flip", flip_document(run), result=run.flip, trajectory=trajectory, modes=modes)
    from .planning.pump import PumpResult, pump_flip, pump_payload

    if on_simulation is not None and (max_time is None or max_time > 0):
        on_simulation()
    plan, result = pump_flip(scene, margin=margin, max_time=max_time, dt=dt, replan_every=replan_every,
                             compliant=compliant, progress=progress)
    trajectory = result.trajectory if isinstance(result, PumpResult) else None
    modes = None if trajectory is None or trajectory.modes is None else tuple(trajectory.modes)
    document = pump_payload(scene, plan, result)
    return Answer("pump", document, result=result if trajectory is not None else None, trajectory=trajectory,
                  modes=modes)


def climb_answer(scene: Scene, *, margin: float | None = None, duration: float | None = None,
                 seed: int | None = None, cycles: int | None = None, scale: float | None = None,
                 on_simulation: Callable[[], None] | None = None, progress: Progress | None = None) -> Answer:
    """``frc climb [--cycles N] --json`` (``POST /plan/climb``): the climb as the scene's task, or the gait.

    Without ``cycles``: the scene's task run as ``frc plan`` runs it
    (:func:`frcontrol.planning.core.plan_task`), its document with the climb's keys
    (:func:`frcontrol.planning.climb_check.climb_document`; kind ``"climb"``). With ``cycles``: the
    scene's gait task (:func:`frcontrol.planning.gait_run.gait_scene`, ``repeat = cycles``) run as
    ``frc plan`` runs it, its document with the gait's keys (:func:`~frcontrol.planning.gait_run.gait_keys`;
    kind ``"gait"``).

    Args:
        scene: the scene with ``[[disturbances]]`` and a task given as phases whose first phase is
            the brace (and ``[task] gait`` or ``upper_brace_contacts`` for the gait).
        margin: [N m or N] every phase's margin (the gait's robustness radius); None: the task's
            (the gait's default).
        duration: [s] the climb's longest simulated time (None: the task's ``max_time``); not used
            by the gait.
        seed: seed of the gait's sampled disturbances (an integer >= 0; None: 0); the climb's run
            samples none.
        cycles: the gait's number of cycles (>= 1), or None for the climb.
        scale: the disturbance scale of the gait's simulation (None: the gait's default).
        on_simulation: called once when the gait's run (its planning first) starts.
        progress: called with (simulated time, max_time) along the run.

    Raises:
        InputError: a seed that is not an integer >= 0; OptionConflict: ``scale`` or ``seed``
            without ``cycles`` (both before any planning); see the planners.
    """
    from .simulation.inputs import check_seed

    if cycles is None:
        for name, value in (("scale", scale), ("seed", seed)):
            if value is not None:
                raise OptionConflict(name, f"{name} sets the gait's simulated disturbances: it needs cycles "
                                     "(--cycles N); the climb's run is its task's rigid run")
        from .planning.climb_check import climb_document
        from .planning.core import plan_task

        result = plan_task(scene, max_time=duration, margin=margin, progress=progress)
        trajectory = result.trajectory
        return Answer("climb", climb_document(scene, result), result=result, trajectory=trajectory,
                      modes=None if trajectory.modes is None else tuple(trajectory.modes))
    from .planning.gait_run import gait_keys, gait_scene

    gait = gait_scene(scene, cycles=cycles, seed=check_seed(0 if seed is None else seed), scale=scale,
                      margin=margin)
    if on_simulation is not None:
        on_simulation()
    return short_name_answer("gait", gait, lambda run: gait_keys(gait, run), progress=progress)


def standup_answer(scene: Scene, *, duration: float | None = None, dt: float = 2e-3, replan_every: int = 10,
                   margin: float | None = None, progress: Progress | None = None) -> Answer:
    """``frc standup --json`` (``POST /plan/standup``): a short name for ``frc plan`` on a stand-up task.

    Args:
        scene: a scene whose task is a stand-up (:func:`frcontrol.planning.standup.standup_task`), or
            gives the stand-up's former keys (``feet``, ``stand_height``).
        duration: [s] the longest simulated time (default: the task's ``max_time``; 0: the first
            plan only).
        dt: [s] the rigid step.
        replan_every: steps between two plans.
        margin: [N m] every plan's margin (default: the phase's own).
        progress: called with (simulated time, duration) along the run.

    Raises:
        SceneError: the task is no stand-up; InputError: a bad step, time or margin.
    """
    from .planning.standup import judge_standup, stand_up_as_phases, standup_task

    scene = stand_up_as_phases(scene)
    stand = standup_task(scene)  # before the run: a scene that is no stand-up is refused at once
    def legacy(run: Any) -> dict[str, Any]:
        return judge_standup(scene, run, stand).legacy_keys(scene)

    return short_name_answer("standup", scene, legacy, dt=dt, replan_every=replan_every, max_time=duration,
                             margin=margin, progress=progress)


def short_name_answer(kind: str, scene: Scene, legacy: Callable[[Any], Mapping[str, Any]],
                      **options: Any) -> Answer:
    """The answer of a short name for ``frc plan`` (``frc standup``): the task run, and its legacy keys.

    The command's options are mapped onto :func:`plan_answer`'s (``options``: ``dt``,
    ``replan_every``, ``max_time``, ``margin``, ``compliant``, ``progress``) and the scene's task is
    run exactly as ``frc plan`` runs it; ``legacy`` reads the keys the command documented before
    (from the :class:`~frcontrol.planning.core.PlanResult`), and they are merged into ``frc plan``'s
    document by :func:`frcontrol.planning.core.report.with_legacy_keys` (``phases`` and ``outcome``
    stay ``frc plan``'s).

    Args:
        kind: the command's name (the answer's ``kind``).
        scene: the scene.
        legacy: the command's own keys, from the run.
        options: :func:`plan_answer`'s keywords.
    """
    from .planning.core.report import with_legacy_keys

    answer = plan_answer(scene, **options)
    return Answer(kind, with_legacy_keys(answer.document, legacy(answer.result)), result=answer.result,
                  trajectory=answer.trajectory, modes=answer.modes)


def plan_answer(scene: Scene, *, dt: float = 1e-3, replan_every: int = 10, max_time: float | None = None,
                margin: float | None = None, compliant: bool = False, cycles: int | None = None,
                progress: Progress | None = None) -> Answer:
    """``frc plan --json`` (``POST /plan``): the scene's task run.

    Args:
        scene: a scene whose ``[task]`` is given as ``[[task.phases]]``.
        dt: [s] the rigid step.
        replan_every: steps between two plans.
        max_time: [s] the longest simulated time (default: the task's ``max_time``).
        margin: [input units] every phase's margin (default: each phase's own).
        compliant: replay the applied inputs on the compliant model too.
        cycles: run the scene's gait this many times (``[task.gait]``), or its task's phases
            (``repeat``); None: the task as given
            (:func:`frcontrol.planning.gait_run.cycled_scene`).
        progress: called with (simulated time, max_time) along the run.

    Raises:
        SceneError: the scene has no task given as phases; InputError: a bad step, time or margin.
    """
    from .planning.core import plan_task

    if cycles is not None:
        from .planning.gait_run import cycled_scene

        scene = cycled_scene(scene, cycles)
    result = plan_task(scene, dt=dt, replan_every=replan_every, max_time=max_time, margin=margin,
                       compliant=compliant, progress=progress)
    trajectory = result.trajectory
    return Answer("plan", result.to_dict(scene), result=result, trajectory=trajectory,
                  modes=None if trajectory.modes is None else tuple(trajectory.modes))


def atlas_answer(plan: AtlasPlan, **run: Any) -> Answer:
    """``frc atlas --json`` (``POST /atlas``'s job result): the sweep of ``plan``.

    Args:
        plan: from :func:`frcontrol.atlas.build_atlas`.
        run: how it runs, as :func:`frcontrol.atlas.run_atlas` takes it (``where``, ``out``,
            ``resume``, ``progress``, ``stop``): the document's ``run``.
    """
    from .atlas import run_atlas

    result = run_atlas(plan, **run)
    return Answer("atlas", result.to_dict(), result=result)


__all__ = [
    "Answer",
    "CONTACT_MODELS",
    "FlipOptions",
    "SimulationOptions",
    "OptionConflict",
    "DESCRIPTION_CHARS",
    "Progress",
    "RUN_DEPENDENT_KEYS",
    "analysis_and_solutions",
    "analysis_payload",
    "analyze_answer",
    "atlas_answer",
    "catalog",
    "climb_answer",
    "driven",
    "flip_answer",
    "plan_answer",
    "pumps",
    "robots_answer",
    "run_simulation",
    "schema_answer",
    "short_name_answer",
    "show_answer",
    "simulate_answer",
    "simulation_failure",
    "solutions_answer",
    "solutions_payload",
    "standup_answer",
    "statics_answer",
    "validation_answer",
    "validation_problems",
    "without_run_dependent",
]
