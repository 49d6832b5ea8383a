"""Every shipped scene with two or more contacts, every contact's mu at 0 and each decade to 1e8.

The analysis and the solutions at an input (every input 0) either answer, with finite numbers, or
raise :class:`~frcontrol.errors.IllConditioned` naming the mode's system, its condition number and
the limit. Which points raise is pinned (``ILL_CONDITIONED``): a sliding mode's system grows as mu^2
in condition (the box's LL: 1.29 mu^2 once equilibrated, 2.6 mu under the best diagonal scaling
found), so between 1/ILL_CONDITIONED_BAND and 1/RANK_TOLERANCE its rank cannot be decided. A point
that starts to answer, or one that starts to fail, changes this table.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from frcontrol.answers import analysis_and_solutions
from frcontrol.errors import IllConditioned
from frcontrol.response import ILL_CONDITIONED_BAND
from frcontrol.scene import load_scene, shipped_scene_names

FRICTIONS = (0.0, *(10.0**k for k in range(9)))

SCENES = [name for name in shipped_scene_names() if len(load_scene(name).contacts) >= 2]

ILL_CONDITIONED = {
    ("box_on_ground", 1e4): "LL", ("box_on_ground", 1e8): "LR",
    ("box_on_slope", 1e4): "LL", ("box_on_slope", 1e8): "LR",
    ("disk_in_wedge", 1e8): "SL",
    ("peg_on_surface", 1e4): "LL", ("peg_on_surface", 1e7): "LF", ("peg_on_surface", 1e8): "LR",
    ("snake_climb", 1e5): "FLF", ("snake_climb", 1e6): "FLF",
    ("solo_standup", 1e4): "LLLL", ("solo_standup", 1e5): "LLSL", ("solo_standup", 1e6): "LLSL",
    ("solo_standup", 1e7): "LLSL", ("solo_standup", 1e8): "LLSF",
    ("table_on_ground", 1e4): "LL", ("table_on_ground", 1e7): "LF", ("table_on_ground", 1e8): "LR",
}
"""(scene, mu) -> the mode whose system is in the ill-conditioned band there."""


@pytest.mark.parametrize("name", SCENES)
def test_every_decade_of_friction_answers_or_names_the_ill_conditioned_system(name):
    contacts = [c.name for c in load_scene(name).contacts]
    for mu in FRICTIONS:
        scene = load_scene(name, overrides={f"contacts.{c}.mu": mu for c in contacts})
        inputs = dict.fromkeys(scene.inputs.coordinates, 0.0)
        if (name, mu) in ILL_CONDITIONED:
            mode = ILL_CONDITIONED[(name, mu)]
            with pytest.raises(IllConditioned) as raised:
                analysis_and_solutions(scene, inputs)
            error = raised.value
            assert error.matrix_name == f"the system of mode {mode}", (mu, error)
            assert error.tolerance == ILL_CONDITIONED_BAND
            assert math.isfinite(error.condition_number) and error.condition_number > 1 / error.tolerance
            assert f"{error.condition_number:.3g}" in str(error) and "1e+08" in str(error)
            continue
        result, solutions = analysis_and_solutions(scene, inputs)
        assert result.feasible_modes, (name, mu)
        for solution in solutions:
            for values in (solution.dv, solution.lambda_n, solution.lambda_t):
                assert np.all(np.isfinite(values)), (name, mu, solution.mode)
