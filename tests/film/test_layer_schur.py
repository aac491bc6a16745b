"""The FE eye's layer basis (the bushing's local compression node by node plus modes,
solver.film.bushings.Superposed) and the WinklerLayer (its case without modes) through the Schur complement
of the film block (solver.film.coupled_lu.SchurLU with solver.film.ehd.LayeredBlocks: the node-by-node
deformation eliminated, the film block J_uu + L diag(d) in its own fixed pattern) against an LU of the
whole coupled matrix (MUMPS, the method before it), with the Reynolds rows and the JFO rows, in asperity
contact (where the local unknowns of the cells in contact stay borders)."""

from __future__ import annotations

import math

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
import scipy.sparse.linalg

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.bushings import FEEye, Superposed, WinklerLayer
from solver.film.surface import Surface

pytestmark = pytest.mark.serial

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0
MODES = 12
BRONZE = dict(thickness=1.5e-3, E=115e9, nu=0.33)
ROUGH = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
# a mixed-lubrication state of the small end (tests/film/test_ehd.py's MIXED): rigid h_min 0.3 um, the
# asperities touching, squeeze, both surfaces turning; then warm starts near it
MIXED = Kinematics(
    (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)),
    (0.05 * C * OMEGA, -0.1 * C * OMEGA),
    0.2 * OMEGA,
    -0.3 * OMEGA,
)
STATES = [(None, MIXED)] + [
    (
        None,
        Kinematics(tuple(np.array(MIXED.ecc) * f), MIXED.ecc_rate, MIXED.omega_journal, MIXED.omega_bushing),
    )
    for f in (0.99, 0.97, 1.005)
]
#: the JFO film (from the full film the coupled Newton does not reach the mixed state, with either LU):
#: a steady state, then committed states 50 us apart closing the gap to h_min 1.3 um, the last in contact
JFO_STATES = [(0.0, Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0))] + [
    (5e-5 * k, Kinematics((5e-6 + 6e-7 * k, 3e-6 + 8e-7 * k), (0.01, 0.004), OMEGA, 30.0))
    for k in range(1, 6)
]


def _bushing(kind: str, eye):
    if kind == "winkler":
        return WinklerLayer(**BRONZE)
    bushing = FEEye(eye.geometry, modes=MODES, basis="layer").reduce(eye)
    assert isinstance(bushing, Superposed)
    return bushing


def _model(kind: str, cavitation: str, eye) -> FilmModel:
    keys = {"inlet": "none"} if cavitation == "reynolds" else {"inlet": "none", "cavitation_pressure": -0.5e5}
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, **keys)
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.1,
        cavitation=cavitation,
        roughness=ROUGH.roughness(),
        contact=ROUGH.contact(),
        elastic=_bushing(kind, eye),
    )


def _solve_path(model: FilmModel, cavitation: str) -> list:
    """(Newton iterations, (u, q), film Jacobian) along the states of ``cavitation``'s path."""
    out = []
    for t, state in JFO_STATES if cavitation == "jfo" else STATES:
        result = model.solve(state, t)
        out.append((result.iterations, model.solver.ehd.state(), model.jacobian().matrix))
        if t is not None:
            model.commit_history(model.history_state(), t)
    return out


CASES = [(kind, cavitation) for kind in ("layer", "winkler") for cavitation in ("reynolds", "jfo")]


@pytest.mark.parametrize("kind, cavitation", CASES)
def test_eliminated_system_is_the_whole_matrix_solve(kind, cavitation, coarse_eye):
    """At the path's last solution and at that state with less deformation, where the asperities touch
    (the local unknowns of the cells in contact kept as borders): none for the Reynolds film, half for the
    JFO film (with none its film block dR_u/du is singular there, cond 1e18: so with modal borders too),
    SchurLU's solution of the coupled Newton system
    (every unknown inactive) against scipy's sparse LU of the whole coupled Jacobian, for three random
    right-hand sides: 1e-10 of the solution's largest entry (two direct solves of a system whose
    condition number is ~1e6 on this film: measured ~1e-13)."""
    from solver.film.coupled_lu import SchurLU
    from solver.film.ehd import LayeredBlocks

    rng = np.random.default_rng(1)
    with _model(kind, cavitation, coarse_eye) as model:
        newton = model.solver.ehd
        block, lu = newton.block, newton.block.lu
        assert newton.layered and isinstance(lu, SchurLU)
        _solve_path(model, cavitation)
        solution = newton.state_x.copy()
        less = 0.5 if cavitation == "jfo" else 0.0  # (less deformation: more contact)
        n = newton.n
        for touching, x in enumerate((solution, np.concatenate([solution[:n], less * solution[n:]]))):
            newton.residual(x)
            J = block.jacobian_matrix("csr").tocsc()
            block.blocks = block.jacobian_blocks(layered=True)
            assert isinstance(block.blocks, LayeredBlocks)
            if touching:  # (the asperities touch: local unknowns kept as borders)
                assert len(block.blocks.kept) > 0
            everything = PETSc.IS().createGeneral(np.arange(newton.N, dtype=PETSc.IntType))
            lu.factor(everything)
            everything.destroy()
            for _ in range(3):
                b = rng.standard_normal(newton.N)
                expected = scipy.sparse.linalg.spsolve(J, b)
                got = lu._solve(b)
                assert np.abs(got - expected).max() <= 1e-10 * np.abs(expected).max()


@pytest.mark.parametrize("kind, cavitation", CASES)
def test_schur_path_gives_the_whole_lu_iterates(kind, cavitation, coarse_eye):
    """From a cold start at the mixed state and along warm starts (the JFO film: from the full film along
    committed states into contact): the same Newton iterations, the same (u, q) to 1e-9 of their
    largest values (the same linear systems solved in another order), the same film Jacobian to 1e-8 of
    each row's largest entry."""
    from solver.film.coupled_lu import SchurLU

    runs = []
    for whole in (False, True):
        with _model(kind, cavitation, coarse_eye) as model:
            block = model.solver.ehd.block
            assert isinstance(block.lu, SchurLU)
            if whole:
                block.use_whole_lu()
            runs.append(_solve_path(model, cavitation))
    for (its, x, J), (its_ref, x_ref, J_ref) in zip(*runs):
        assert its == its_ref
        assert np.abs(x - x_ref).max() <= 1e-9 * np.abs(x_ref).max()
        assert np.all(np.abs(J - J_ref) <= 1e-8 * np.abs(J_ref).max(axis=1, keepdims=True))
