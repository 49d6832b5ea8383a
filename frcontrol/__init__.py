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
from .model import ContactPoint, PlanarRobot, RobotState
from .scene import Contact, Inputs, Scene, load_scene

__version__ = "0.1.0"

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
    "load_scene",
]
