"""The per-state outputs: each joint reports its own variables, by the names of the one results table."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.dynamics.joint import DryContactJoint, FilmJoint, ShortBearingJoint
from solver.study.results import DERIVED_VARIABLES, STATE_VARIABLES, VARIABLES

R, B, C = 0.01, 0.02, 10e-6


@pytest.mark.parametrize("joint", [FilmJoint, ShortBearingJoint, DryContactJoint], ids=lambda j: j.__name__)
def test_every_joint_reports_variables_of_the_results_table(joint):
    """A joint's OUTPUTS are state variables of solver.study.results.VARIABLES (with units and a
    long name there), none of them one that the dataset derives."""
    assert joint.OUTPUTS and set(joint.OUTPUTS) <= set(STATE_VARIABLES)
    assert all(name in VARIABLES and name not in DERIVED_VARIABLES for name in joint.OUTPUTS)


@pytest.mark.parametrize(
    "joint",
    [
        ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=0.01),
        DryContactJoint(radius=R, clearance=C, stiffness=1e15),
    ],
    ids=lambda j: type(j).__name__,
)
def test_a_joint_reports_its_load_as_film_or_contact(joint):
    """At a state with load (eccentricity 0.8 c, squeeze; 1.1 c for the dry joint) the joint reports
    exactly its OUTPUTS: the short bearing's whole force as film load, its side flow positive; the dry
    joint's whole force as contact load."""
    ecc = np.array([0.0, (1.1 if isinstance(joint, DryContactJoint) else 0.8) * C])
    ecc_rate, omega_rel = np.array([0.0, 1e-4]), 10.0
    forces = joint.forces(ecc, ecc_rate, omega_rel, 0.0)
    outputs = joint.outputs(ecc, ecc_rate, omega_rel, 0.0, forces)
    assert set(outputs) == set(joint.OUTPUTS)
    load = math.hypot(*forces.force)
    assert load > 0
    if isinstance(joint, ShortBearingJoint):
        assert (outputs["F_hydro"], outputs["F_asperity"]) == (load, 0.0)
        assert outputs["side_flow"] == joint.side_flow(ecc, ecc_rate, omega_rel) > 0
    else:
        assert (outputs["F_hydro"], outputs["F_asperity"]) == (0.0, load)
