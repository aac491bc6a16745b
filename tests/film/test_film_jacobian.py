"""The film's exact Jacobian (active set frozen) against central finite differences of full VI solves."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.film.bearing import Bearing, FilmModel, Kinematics

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0


@pytest.mark.serial
def test_jacobian_matches_finite_differences(film_differences):
    """The smooth rigid film with inlet none (with the max-gap inlet and its frame turn: the film kinds'
    rigid-smooth, tests/film/test_film_kinds.py). Central differences with steps 1e-4 c have truncation
    error ~1e-8 relative and the active set does not change over such a step, so the two agree to ~1e-6
    of the largest entry; tolerance 1e-5. The state mixes rotation of both surfaces and squeeze, so every
    term of the form contributes; the last column is the derivative with respect to the relative
    rotation speed."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    base = Kinematics(
        (0.5 * C * math.cos(1.0), 0.5 * C * math.sin(1.0)),
        (0.3 * C * OMEGA, -0.2 * C * OMEGA),
        OMEGA,
        0.3 * OMEGA,
    )
    steps = np.array([1e-4 * C] * 2 + [1e-4 * C * OMEGA] * 2 + [1e-4 * OMEGA])
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.08) as model:
        model.solve(base)
        J = model.jacobian().matrix
        J_fd = film_differences(model, base, steps)
    for row in range(4):  # forces and torques have different units: compare row by row
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-5 * scale, (row, J[row], J_fd[row])


@pytest.mark.serial
def test_global_kinematics_include_frame_rotation():
    """Kinematics.from_global: a journal fixed in a bushing frame that turns has zero eccentricity rate."""
    phi, omega_b = 0.7, 3.0
    e_b = np.array([2e-6, -1e-6])
    A = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    S = np.array([[0.0, -1.0], [1.0, 0.0]])
    e = A @ e_b
    kin = Kinematics.from_global(e, omega_b * S @ e, (0, 0), (0, 0), phi, omega_b, omega_b)
    assert np.allclose(kin.ecc, e_b, atol=1e-18)
    assert np.allclose(kin.ecc_rate, 0.0, atol=1e-15)


@pytest.mark.serial
def test_mixed_jacobian_matches_finite_differences(film_differences):
    """The same check with rough surfaces and asperity contact (h_min/sigma = 1.9): flow factors, the
    contact factor, shear-flow and shear-stress factors and the Greenwood-Tripp terms all depend on
    the eccentricity. Tolerance 1e-4: the steepest terms (asperity pressure) make the central
    differences' truncation error ~1e-6. The steps are small (3e-6 c) because the discrete VI's
    active set changes within 1e-5 c of this state: central differences across that kink miss the
    one-sided derivative by 2.5e-4."""
    from solver.film.surface import Surface

    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    base = Kinematics(
        (0.94 * C * math.cos(-1.2), 0.94 * C * math.sin(-1.2)),
        (0.05 * C * OMEGA, -0.1 * C * OMEGA),
        0.2 * OMEGA,
        -0.3 * OMEGA,
    )
    steps = np.array([3e-6 * C] * 2 + [3e-5 * C * OMEGA] * 2 + [3e-5 * OMEGA])
    with FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.08,
        roughness=surface.roughness(),
        contact=surface.contact(),
    ) as model:
        r0 = model.solve(base)
        assert r0.asperity_load > 0
        J = model.jacobian().matrix
        J_fd = film_differences(model, base, steps)
    for row in range(4):
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-4 * scale, (row, J[row], J_fd[row])
