"""A new viscosity changes constants of the film's forms, not the forms (issue 30, item 3)."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem

from solver.film.factory import make_film
from solver.film.spec import FilmSpec
from solver.film.surface import Surface
from solver.film.types import Bearing, Kinematics

R, C, OMEGA = 0.01, 10e-6, 200.0
MU1, MU2 = 0.01, 0.023
ROUGH = Surface(sigma_journal=0.3e-6, sigma_bushing=0.4e-6)
GROOVE = {"groove": "circumferential", "groove_width": 0.003, "supply_pressure": 2e5}


def _spec(viscosity: float, cavitation: str) -> FilmSpec:
    bearing = Bearing(
        radius=R,
        width=2 * R,
        clearance=C,
        viscosity=viscosity,
        cavitation_pressure=-0.5e5,
        inlet="none",
        **GROOVE,
    )
    return FilmSpec(
        bearing=bearing,
        omega_ref=OMEGA,
        mesh_size=0.12,
        roughness=ROUGH.roughness(),
        contact=ROUGH.contact(),
        cavitation=cavitation,
    )


def _answers(film) -> np.ndarray:
    kin = Kinematics(
        (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)), (0.1 * C * OMEGA, 0.0), OMEGA, 0.0
    )
    r = film.solve(kin)
    values = [
        *r.force,
        r.torque_journal,
        r.torque_bushing,
        r.p_max,
        r.side_flow,
        r.supply_flow,
        r.asperity_load,
    ]
    return np.concatenate([values, film.jacobian().matrix.ravel()])


@pytest.mark.serial
@pytest.mark.parametrize("cavitation", ["reynolds", "jfo"])
def test_set_viscosity_gives_the_film_built_at_that_viscosity(cavitation, monkeypatch):
    """A film built at mu1, solved, then set to mu2: the same forces, torques, flows and Jacobian as a
    film built at mu2 (1e-10 of each value: the same discrete problem, solved from another warm start
    to the solvers' tolerances), and no form is compiled for it (dolfinx.fem.form is not called)."""
    with make_film(_spec(MU2, cavitation), MPI.COMM_SELF) as film:
        reference = _answers(film)
    with make_film(_spec(MU1, cavitation), MPI.COMM_SELF) as film:
        _answers(film)  # (a warm start and a history at mu1)
        calls = []
        real = fem.form
        monkeypatch.setattr(fem, "form", lambda *a, **k: calls.append(1) or real(*a, **k))
        film.set_viscosity(MU2)
        answers = _answers(film)
    assert calls == []
    relative = np.abs(answers - reference) / np.maximum(np.abs(reference), 1e-300)
    assert np.all(relative <= 1e-10), relative.max()
