"""The film solve distributed over the world communicator equals the same solve on one rank.

Reference: the serial solve (MPI.COMM_SELF) on each rank. The distributed solve is the same discrete
problem partitioned differently, so the forces may differ only by the solver tolerance
(SNES rtol 1e-10): the tolerance 1e-8 relative leaves two orders of margin.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.film.bearing import Bearing, FilmModel, Kinematics

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0


# an axial oil groove at 3 bar: its Dirichlet dofs and the supply flow across the partition
GROOVE = {
    "supply_pressure": 3e5,
    "groove": "axial",
    "groove_angle": 2.0,
    "groove_arc": math.radians(40),
    "groove_length": 1.2 * R,
}


@pytest.mark.mpi
@pytest.mark.parametrize(
    "inlet, supply",
    [("max-gap", {}), ("none", {}), ("none", GROOVE)],
    ids=["max-gap", "none", "axial-groove"],
)
def test_distributed_force_equals_serial(comm, inlet, supply):
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet=inlet, **supply)
    kin = Kinematics((0.3 * C, -0.6 * C), (0.2 * C * OMEGA, 0.1 * C * OMEGA), OMEGA, -0.2 * OMEGA)
    results = []
    for c in (comm, MPI.COMM_SELF):
        with FilmModel(bearing, c, omega_ref=OMEGA, mesh_size=0.08) as model:
            results.append(model.solve(kin))
    world, serial = results
    assert np.allclose(world.force, serial.force, rtol=1e-8, atol=1e-8 * serial.load)
    for name in ("torque_journal", "torque_bushing", "p_max", "side_flow", "supply_flow"):
        assert getattr(world, name) == pytest.approx(getattr(serial, name), rel=1e-8), name
    assert (world.supply_flow > 0) == bool(supply)
    assert math.isfinite(world.load) and world.load > 0
