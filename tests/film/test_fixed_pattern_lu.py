"""FixedPatternLU after a failed factorisation (solver.film.cavitation).

MUMPS keeps the error of a failed numeric factorisation and returns from every later one at once, so
without a fresh start one zero pivot (a far trial state of an elastic film) failed every later solve
of the same film (found in the bearing command's equilibrium search with the FE eye). Reference: the
exact solution of a small diagonal system.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest

from solver.errors import FilmNotConverged
from solver.film.cavitation import FixedPatternLU


class _Matrix:
    """What FixedPatternLU needs of its film: the matrix A and the communicator."""

    def __init__(self, diagonal: np.ndarray):
        n = len(diagonal)
        self.comm = MPI.COMM_SELF
        indptr = np.arange(n + 1, dtype=PETSc.IntType)
        self.A = PETSc.Mat().createAIJ(
            (n, n), csr=(indptr, np.arange(n, dtype=PETSc.IntType), diagonal), comm=self.comm
        )
        self.A.assemble()

    def set_diagonal(self, diagonal: np.ndarray) -> None:
        n = len(diagonal)
        self.A.setValuesCSR(
            np.arange(n + 1, dtype=PETSc.IntType), np.arange(n, dtype=PETSc.IntType), diagonal
        )
        self.A.assemble()


@pytest.mark.serial
def test_a_failed_factorisation_does_not_fail_the_next_ones():
    """A singular matrix fails (FilmNotConverged); the next, regular one is solved exactly (1e-14)."""
    film = _Matrix(np.array([2.0, 0.0, 4.0, 5.0]))
    lu = FixedPatternLU(film)
    lu.ksp.getPC().setFactorSolverType("mumps")  # the elastic film's factorisation
    everything = PETSc.IS().createGeneral(np.arange(4, dtype=PETSc.IntType), comm=film.comm)
    b = np.array([1.0, 2.0, 3.0, 4.0])
    try:
        lu.factor(everything)
        lu.b.setArray(b)
        with pytest.raises(FilmNotConverged):
            lu.solve_full(lu.b, lu.x)
        diagonal = np.array([2.0, 8.0, 4.0, 5.0])
        film.set_diagonal(diagonal)
        lu.factor(everything)
        lu.b.setArray(b)
        lu.solve_full(lu.b, lu.x)
        np.testing.assert_allclose(lu.x.getArray(), b / diagonal, rtol=1e-14)
    finally:
        lu.destroy()
        everything.destroy()
        film.A.destroy()
