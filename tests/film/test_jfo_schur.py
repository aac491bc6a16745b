"""The mass-conserving film on a modal elastic bushing (solver.film.cavitation_jfo.JFORows with a few modes):
its Newton systems by the Schur complement of the film block (solver.film.coupled_lu.SchurLU) against
an LU of the whole coupled matrix (MUMPS, the method before it), and its exact Jacobian at the solution
against central differences of the solves."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.bushings import ModalCompliance
from solver.film.coupled_lu import _zeroed
from solver.film.ehd import ModalBorder, ScaledBorder, as_array
from solver.film.surface import Surface

pytestmark = pytest.mark.serial

R, B, C, MU, OMEGA = 0.01, 0.02, 1e-5, 0.01, 200.0
MODES = 24
ROUGH = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
#: a steady state at t = 0 (from the full film), then states 50 us apart, squeezing and turning, each a
#: warm start from the one before, with the film fraction's rate from the committed states
STATES = [(0.0, Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0))] + [
    (5e-5 * k, Kinematics((5e-6 + 3e-7 * k, 3e-6 + 4e-7 * k), (0.01, 0.004), OMEGA, 30.0)) for k in (1, 2, 3)
]


def _eye_jfo(eye) -> FilmModel:
    """The coarse FE eye (``MODES`` modes), rough with asperity contact, JFO, flooded edges."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, cavitation_pressure=-0.5e5, inlet="none")
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.1,
        cavitation="jfo",
        roughness=ROUGH.roughness(),
        contact=ROUGH.contact(),
        elastic=ModalCompliance(eye, MODES),
    )


def _outputs(r) -> np.ndarray:
    return np.array([*r.force, r.torque_journal, r.torque_bushing])


def test_schur_complement_gives_the_whole_lu_iterates(coarse_eye):
    """From the full film to a ruptured steady state (10 Newton iterations, the partition moving), then
    along committed transient states (4 each): the same Newton iterations, the same u and q to 1e-9 of
    their largest values (the same linear systems, solved in another order: measured 1e-14), and the
    same film Jacobian to 1e-8 of each row's largest entry (measured 1e-10). Both ways of solving the
    Schur system are taken: with the complement of its own factorisation and by GMRES preconditioned
    with an earlier one (to 1e-12, so the iterates do not change)."""
    from solver.film.coupled_lu import DampedLU, SchurLU

    runs = []
    for whole in (False, True):
        with _eye_jfo(coarse_eye) as model:
            block = model.solver.ehd.block
            assert isinstance(block.lu, SchurLU)
            if whole:
                block.use_whole_lu()
                assert isinstance(block.lu, DampedLU)
            out = []
            for t, state in STATES:
                result = model.solve(state, t)
                assert 0.2 < result.cavitated_area_ratio < 0.8  # (the film ruptures: both partitions)
                out.append((result.iterations, model.history_state(), model.jacobian().matrix))
                model.commit_history(model.history_state(), t)
            if not whole:
                counts = (block.lu.n_formed, block.lu.n_krylov)
                assert counts[0] >= 2 and counts[1] > 0, counts
            runs.append(out)
    for (its, x, J), (its_ref, x_ref, J_ref) in zip(*runs):
        n = len(x) - MODES
        assert its == its_ref
        assert np.abs(x[:n] - x_ref[:n]).max() <= 1e-9 * np.abs(x_ref[:n]).max()
        assert np.abs(x[n:] - x_ref[n:]).max() <= 1e-9 * np.abs(x_ref[n:]).max()
        assert np.all(np.abs(J - J_ref) <= 1e-8 * np.abs(J_ref).max(axis=1, keepdims=True))


def test_jacobian_at_the_solution_matches_finite_differences(coarse_eye):
    """The transient, ruptured state after a committed steady one: the film's exact Jacobian (the coupled
    Jacobian's blocks at the solution, factorised by SchurLU, and the JFO forms' kinematic derivatives)
    against central differences of solves that each start from the solution (so the solve's tolerance,
    1e-10 of the flux, does not enter the difference; steps 1e-10 m, 1e-5 m/s, 1e-2 rad/s keep the
    partition), to 1e-5 of each row's largest entry (measured 4e-11 for the forces, 3e-7 for the
    torques)."""
    with _eye_jfo(coarse_eye) as model:
        (t0, steady), (t1, state) = STATES[:2]
        model.solve(steady, t0)
        model.commit_history(model.history_state(), t0)
        model.solve(state, t1)
        J = model.jacobian().matrix
        solution = model.history_state()
        x0 = np.array([*state.ecc, *state.ecc_rate, state.omega_journal - state.omega_bushing])

        def outputs(x):
            model.start_from(solution)
            kin = Kinematics((x[0], x[1]), (x[2], x[3]), x[4] + state.omega_bushing, state.omega_bushing)
            return _outputs(model.solve(kin, t1))

        J_fd = np.zeros((4, 5))
        for k, step in enumerate((1e-10, 1e-10, 1e-5, 1e-5, 1e-2)):
            e = np.zeros(5)
            e[k] = step
            J_fd[:, k] = (outputs(x0 + e) - outputs(x0 - e)) / (2 * step)
    for row in range(4):  # forces and torques have different units: row by row
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-5 * scale, (row, J[row], J_fd[row])


def test_borders_kept_as_factors_equal_their_products():
    """The borders SchurLU reads as factors (solver.film.ehd.ModalBorder: diag(rows) M Phi; ScaledBorder:
    J diag(scale)) against their dense products formed directly, on a vector and a block of vectors, with
    the active set's rows (columns) zeroed as SchurLU zeroes them: equal to 1e-13 of the largest entry (a
    different order of the same sums)."""
    rng = np.random.default_rng(7)
    n, m = 60, 9
    M = scipy.sparse.random(n, n, density=0.1, format="csr", random_state=3) + scipy.sparse.identity(n)
    Phi, J = rng.standard_normal((n, m)), rng.standard_normal((m, n))
    rows, scale = (rng.random(n) > 0.1).astype(float), rng.random(n)
    active = np.array([2, 17, 40])
    B_dense = rows[:, None] * (M.toarray() @ Phi)
    B_dense[active] = 0.0
    C_dense = J * scale[None, :]
    C_dense[:, active] = 0.0
    B = _zeroed(ModalBorder(rows, M, Phi), active, axis=0)
    C = _zeroed(ScaledBorder(J, scale), active, axis=1)
    v, V, y, Y = (
        rng.standard_normal(m),
        rng.standard_normal((m, 4)),
        rng.standard_normal(n),
        rng.standard_normal((n, 4)),
    )
    for lazy, dense, x in ((B, B_dense, v), (B, B_dense, V), (C, C_dense, y), (C, C_dense, Y)):
        assert np.abs(lazy @ x - dense @ x).max() <= 1e-13 * np.abs(dense @ x).max()
    for lazy, dense in ((B, B_dense), (C, C_dense)):
        assert np.abs(as_array(lazy) - dense).max() <= 1e-13 * np.abs(dense).max()
    assert _zeroed(B, np.array([], int), axis=0) is B  # nothing active: the border itself, no copy
