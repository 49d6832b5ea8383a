"""frcontrol: model-based control of frictionally constrained planar robots.

For a planar robot in contact, frcontrol answers: given the state and a control input, what can
happen? Every contact can Separate, slide Left, slide Right or stay Fixed; for every combination
(a contact mode) the rigid-body equations with Coulomb friction give the accelerations and forces as
an affine function of the inputs and of ambiguity variables, valid on a polytope of inputs.
"""

from .errors import (
    CoordinateNotFound,
    FrameNotFound,
    FrcontrolError,
    IllConditioned,
    ImpactState,
    InputError,
    RobotModelError,
    SceneError,
    SolverNotFound,
)

__version__ = "0.1.0"

# The scene, the model and the main calls, imported on first use so that ``import frcontrol`` stays
# light (Pinocchio, the engine, the planners and SciPy load only when asked for).
_LAZY = {
    "ContactPoint": "frcontrol.model",
    "PlanarRobot": "frcontrol.model",
    "RobotState": "frcontrol.model",
    "Contact": "frcontrol.scene",
    "Inputs": "frcontrol.scene",
    "Scene": "frcontrol.scene",
    "load_scene": "frcontrol.scene",
    "analyze": "frcontrol.engine",
    "solutions_at": "frcontrol.engine",
    "analyze_statics": "frcontrol.statics",
    "simulate": "frcontrol.simulation",
    "simulate_rigid": "frcontrol.simulation",
    "simulate_compliant": "frcontrol.simulation",
    "plan_flip": "frcontrol.planning.flip",
    "plan_climb": "frcontrol.planning.climb",
}


def __getattr__(name: str):
    """``frcontrol.load_scene``, ``frcontrol.analyze``... (the names of :data:`_LAZY`) on first use."""
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'frcontrol' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "Contact",
    "ContactPoint",
    "CoordinateNotFound",
    "FrameNotFound",
    "FrcontrolError",
    "IllConditioned",
    "ImpactState",
    "InputError",
    "Inputs",
    "PlanarRobot",
    "RobotModelError",
    "RobotState",
    "Scene",
    "SceneError",
    "SolverNotFound",
    "__version__",
    "analyze",
    "analyze_statics",
    "load_scene",
    "plan_climb",
    "plan_flip",
    "simulate",
    "simulate_compliant",
    "simulate_rigid",
    "solutions_at",
]
