"""Each command's answer: the library calls behind a command and the JSON its ``--json`` prints.

The command line (``frc analyze``, ``frc simulate``, ``frc flip``, ``frc climb``...) and the planning
service (``frc serve``) answer the same questions with the same documents: both call these
functions, so a service answer is the command's ``--json`` built from the same ``to_dict()``. They
hold no I/O: progress is a callback, files and rendering stay with the caller.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .errors import InputError

if TYPE_CHECKING:
    from .engine import DynamicResponse, RigidSolution
    from .planning.climb import ClimbPlan, ClimbResult
    from .planning.core import PlanResult
    from .planning.flip import FlipPlan, FlipResult
    from .planning.gait import GaitPlan, GaitResult
    from .scene import Scene
    from .simulation.trajectory import Trajectory

CONTACT_MODELS = ("rigid", "compliant")
"""The contact models a simulation can run on (``frc simulate --model``)."""


def analysis_and_solutions(
    scene: Scene, inputs: Mapping[str, float] | None, progress: Callable[[str], None] | None = None
) -> tuple[DynamicResponse, list[RigidSolution] | None]:
    """Every contact mode at the scene's state and, when ``inputs`` is given, every rigid solution there.

    Args:
        scene: the loaded scene.
        inputs: named input values [N or N m] (inputs not named are 0), or None for no solutions.
        progress: called with each mode's name as its evaluation starts.

    Raises:
        InputError, CoordinateNotFound: see :func:`frcontrol.scene.parse_input_assignments`.
    """
    from .engine import analyze, solutions_at
    from .scene import parse_input_assignments

    result = analyze(scene, progress=progress)
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


def run_simulation(scene: Scene, inputs: Mapping[str, float], *, model: str | None = None,
                   stiffness: float | None = None, damping: float | None = None, duration: float = 1.0,
                   dt: float = 1e-3, integrator: str = "radau",
                   progress: Callable[[float, float], None] | None = None) -> Trajectory:
    """The run ``frc simulate`` makes: on ``model`` (default: the scene's ``[model]`` contact).

    Args:
        scene: the loaded scene.
        inputs: constant named inputs [N or N m].
        model: ``"rigid"`` or ``"compliant"``, or None for the scene's choice.
        stiffness: [N/m] compliant contact stiffness (compliant model only).
        damping: [N s/m] compliant contact damping (compliant model only).
        duration: [s] simulated time.
        dt: [s] the rigid step; the compliant sample interval.
        integrator: the compliant model's integrator.
        progress: called with (simulated time [s], duration [s]) as the run advances.

    Raises:
        InputError: an unknown model, or stiffness or damping with the rigid model; see the simulators.
    """
    from .simulation.compliant import simulate_compliant
    from .simulation.model_table import model_options
    from .simulation.rigid import simulate_rigid

    if model is not None and model not in CONTACT_MODELS:
        raise InputError(f"unknown contact model {model!r}; expected one of {', '.join(CONTACT_MODELS)}")
    chosen = model if model is not None else model_options(scene).contact
    if chosen == "rigid" and (stiffness is not None or damping is not None):
        raise InputError("--stiffness and --damping belong to the compliant model: add --model compliant")
    if chosen == "rigid":
        return simulate_rigid(scene, inputs, duration, dt, progress=progress)
    return simulate_compliant(scene, inputs, duration, dt, integrator=integrator,
                              stiffness=stiffness, damping=damping, progress=progress)


def simulation_failure(trajectory: Trajectory) -> str | None:
    """Why a run did not complete (the line ``frc simulate`` exits 1 with), or None when it completed."""
    failure = trajectory.failure
    if failure is None:
        return None
    hint = f"; {failure.hint}" if failure.hint else ""
    return f"the simulation {trajectory.status} at t = {failure.time:.6g} s: {failure.reason}{hint}"


def plan_and_fly(scene: Scene, *, margin: float, max_time: float, dt: float, replan_every: int,
                 on_simulation: Callable[[], None] | None = None,
                 progress: Callable[[float, float], None] | None = None
                 ) -> tuple[FlipPlan, FlipResult | None]:
    """``frc flip``'s work: the plan and, when one is found and ``max_time`` > 0, the closed loop.

    Args:
        scene: the scene (RHex on its back).
        margin: [N m] distance kept from every input where another mode holds.
        max_time: [s] the longest simulated time (0: plan only).
        dt: [s] the simulation's step.
        replan_every: steps between two plans.
        on_simulation: called once when the simulation starts.
        progress: called with (simulated time, max_time) along the simulation.
    """
    from .planning.flip import plan_flip, simulate_flip

    plan = plan_flip(scene, margin=margin)
    if not plan.found or max_time <= 0:
        return plan, None
    if on_simulation is not None:
        on_simulation()
    return plan, simulate_flip(scene, dt=dt, max_time=max_time, replan_every=replan_every, margin=margin,
                               plan=plan, progress=progress)


def plan_and_climb(scene: Scene, *, margin: float, duration: float, seed: int,
                   on_simulation: Callable[[], None] | None = None,
                   progress: Callable[[float, float], None] | None = None
                   ) -> tuple[ClimbPlan, ClimbResult | None]:
    """``frc climb``'s work: the plan and, when one is found and ``duration`` > 0, the simulated check.

    Args:
        scene: the scene with ``[[disturbances]]``.
        margin: [N m or N] the robustness radius in the lifted (u, d) space.
        duration: [s] simulated time under sampled disturbances (0: plan only).
        seed: seed of the sampled disturbances.
        on_simulation: called once when the simulation starts.
        progress: called with (simulated time, duration) along the simulation.

    Raises:
        InputError: a seed that is not an integer >= 0 (before any planning); see the planner.
    """
    from .planning.climb import plan_climb, simulate_climb
    from .simulation.inputs import check_seed

    check_seed(seed)
    plan = plan_climb(scene, margin=margin)
    if not plan.found or duration <= 0:
        return plan, None
    if on_simulation is not None:
        on_simulation()
    return plan, simulate_climb(scene, plan, duration=duration, seed=seed, progress=progress)


def plan_and_gait(scene: Scene, *, cycles: int, margin: float, seed: int, scale: float | None = None,
                  on_simulation: Callable[[], None] | None = None,
                  progress: Callable[[int, int], None] | None = None) -> tuple[GaitPlan, GaitResult]:
    """``frc climb --cycles N``'s work: the gait's plan, then its rigid simulation.

    Args:
        scene: the scene with ``[[disturbances]]`` and ``[task] upper_brace_contacts``.
        cycles: number of cycles (>= 1).
        margin: [N m or N] the robustness radius in the lifted (u, d) space.
        seed: seed of the sampled disturbances.
        scale: the disturbance scale of the simulation (None: the gait's default).
        on_simulation: called once when the simulation starts.
        progress: called with (phases done, phases) along the simulation.

    Raises:
        InputError: a seed that is not an integer >= 0 (before any planning); see the planner.
    """
    from .planning.gait import plan_gait, simulate_gait
    from .simulation.inputs import check_seed

    check_seed(seed)
    plan = plan_gait(scene, cycles, margin=margin)
    if on_simulation is not None:
        on_simulation()
    return plan, simulate_gait(plan, seed=seed, scale=scale, progress=progress)


def plan_task_answer(scene: Scene, *, dt: float = 1e-3, replan_every: int = 10, max_time: float | None = None,
                     margin: float | None = None, compliant: bool = False,
                     progress: Callable[[float, float], None] | None = None
                     ) -> tuple[PlanResult, dict[str, Any]]:
    """``frc plan``'s and ``POST /plan``'s work: the scene's task run, and its ``--json`` document.

    Args:
        scene: a scene whose ``[task]`` is given as ``[[task.phases]]``.
        dt: [s] the rigid step.
        replan_every: steps between two plans.
        max_time: [s] the longest simulated time (default: the task's ``max_time``).
        margin: [input units] every phase's margin (default: each phase's own).
        compliant: replay the applied inputs on the compliant model too.
        progress: called with (simulated time, max_time) along the run.

    Raises:
        SceneError: the scene has no task given as phases; InputError: a bad step, time or margin.
    """
    from .planning.core import plan_task

    result = plan_task(scene, dt=dt, replan_every=replan_every, max_time=max_time, margin=margin,
                       compliant=compliant, progress=progress)
    return result, result.to_dict(scene)


__all__ = [
    "CONTACT_MODELS",
    "analysis_and_solutions",
    "analysis_payload",
    "plan_and_climb",
    "plan_and_fly",
    "plan_and_gait",
    "plan_task_answer",
    "run_simulation",
    "simulation_failure",
    "solutions_payload",
]
