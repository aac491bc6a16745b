"""Elastic bushing coupled to the film (EHD, DESIGN 7): one SNES VI on the pressure and the deformation.

The bushing surface deforms radially by w (positive: the gap opens) under the film and asperity
pressures, and the film sees ``H = H_rigid + W`` with ``W = w / c`` (solver.film.reynolds.FilmGeometry).
The deformation is reduced to m unknowns q (dimensionless, / c)::

    W = Phi q,     q = g * (Phi^T F),     F_i = a_i P_i + F_c,i(H)

with F the nodal forces of the film pressure (lumped areas a_i) and of the asperity pressure P_c(H)
(midpoint rule), Phi (n x m) the deformation shapes at the film's dofs and g their gains:

* ``ModalCompliance``: the finite-element compliance of the eye and its bushing
  (solver.film.compliance), Phi = T Psi with Psi its m dominant eigenvectors on the compliance's load
  grid and T the interpolation from that grid to the film's nodes, g = lambda p_ref R^2 / c; so
  ``w = T Psi Lambda Psi^T T^T F``, symmetric (Maxwell-Betti).
* ``WinklerLayer``: a thin elastic layer on a rigid housing, ``w = k (p + p_c)`` node by node with
  ``k = t (1 + nu)(1 - 2 nu) / (E (1 - nu))``: Phi = I, g_i = k p_ref / (c a_i).

Pressure and deformation are solved together by one SNES VI (P >= P_cav, q free; ``vinewtonrsls``, with
a semismooth start when it fails from far: ELASTIC_OPTIONS, FAR_OPTIONS) on::

    R_P(P, q) = A(H) P + l(H) = 0          the rigid film's Reynolds residual, H from q
    R_q(P, q) = q - g * Phi^T F(P, H) = 0

with its exact Jacobian::

    dR_P/dP = A(H)
    dR_P/dq = sum over cells K of [d(A_K P_K + l_K)/dH_K dH_K/dq + dl_K/dW'_K dW'_K/dq]   (W' = dW/dtheta)
    dR_q/dP = -g Phi^T diag(a)
    dR_q/dq = I - g Phi^T (dF_c/dH) Phi

where the coefficients and their derivatives (``ufl.diff`` with respect to W and W') come from the
same UFL expressions as the rigid film, evaluated at the cell midpoints: the operator's rule
(solver.film.tensors). A relaxed fixed-point loop between film and structure converges badly at
engine loads (DESIGN 7); Newton on the coupled system does not. With a few modes (m << n) the reduced
systems are solved through the Schur complement of the film block (``SchurLU``: an LU of the film
block's fixed pattern; the m x m Schur system by GMRES preconditioned with the last complement formed,
which is formed anew, m back-substitutions, only when that converges slowly); node by node (Winkler)
the matrix keeps one sparsity pattern and ``FixedPatternLU`` refactorises it numerically only (MUMPS).
Either way the film's Jacobian with respect to the kinematics reuses the converged factorisation.

Serial, P1 (the tensors' assumptions). The deformation's rate in the squeeze term is in the UFL
coefficients (solver.film.reynolds.FilmGeometry), so the derivatives above include it.
"""

from __future__ import annotations

import logging
import math

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
import scipy.sparse
import ufl
from dolfinx import fem

from solver.errors import FilmNotConverged
from solver.film.bushings import ModalCompliance, WinklerLayer, bushing_model
from solver.film.cavitation import DEFAULT_OPTIONS, FixedPatternLU, ReducedShell, configured_snes
from solver.film.coupled_lu import DampedLU, SchurLU
from solver.film.tensors import MIDPOINT, MidpointOperator

log = logging.getLogger(__name__)


#: PETSc options of the coupled VI over the rigid film's (solver.film.cavitation.DEFAULT_OPTIONS):
#: the reduced-space method, as the rigid film, from a start near the solution (a warm start: 3
#: iterations along a load path).
ELASTIC_OPTIONS: dict[str, str | float | int] = {"snes_max_it": 30}
#: From far (a cold start, or a warm one it cannot finish) the reduced-space method can cycle: it
#: projects the pressure onto its bound after each step, which leaves the deformation's step computed
#: for the unprojected pressure (a mixed state at h_min = 0.5 um from a cold start: no convergence in
#: 200 iterations). The semismooth (Fischer-Burmeister) method converges from there (35 iterations)
#: but only linearly where the complementarity is degenerate (pressure and residual both ~0), so it
#: brings the iterate near the solution (FAR_TOLERANCE of the start's residual) and the
#: reduced-space method finishes.
FAR_OPTIONS: dict[str, str | float | int] = {"snes_type": "vinewtonssls", "snes_max_it": 200}
FAR_TOLERANCE = 1e-6


class ElasticFilm:
    """The coupled VI of pressure and deformation (module docstring) on a FilmModel's operator.

    Args:
        operator: the film's MidpointOperator (fills A(H) and l(H) for the current W).
        P: the pressure Function; W: the deformation Function W = w / c in the film's forms.
        lower: the pressure's lower bounds per dof (P_cav, or the Dirichlet value where lower).
        derivatives: UFL expressions (dk_theta/dW, dk_z/dW, df/dW, df/dW', P_c, dP_c/dW).
        shapes: (Phi, g) at the film's dofs.
        options: PETSc options over solver.film.cavitation.DEFAULT_OPTIONS.
        pressure_map: with piezoviscosity P is the reduced pressure: ``pressure_map(P) -> (p, dp/dP)``
            gives the true pressure that loads the bushing (solver.film.viscosity); q_limit: the
            reduced pressure's bound (the Newton steps stay below it).
    """

    def __init__(
        self,
        operator: MidpointOperator,
        P: fem.Function,
        W: fem.Function,
        lower: np.ndarray,
        derivatives,
        shapes,
        options: dict | None = None,
        pressure_map=None,
        q_limit: float | None = None,
    ):
        self.op, self.P, self.W = operator, P, W
        self.pressure_map, self.q_limit = pressure_map, q_limit
        self.comm = MPI.COMM_SELF
        self.expression = fem.Expression(
            ufl.as_vector(self._midpoint_expressions(operator, derivatives)), MIDPOINT
        )
        Phi, gains = shapes
        Phi, self.gains = scipy.sparse.csr_matrix(Phi), np.asarray(gains, float)
        op = operator
        n, m = len(lower), Phi.shape[1]
        self.n, self.m = n, m
        cells = op.cells
        c3 = np.repeat(cells, 3)
        self.areas = op.nodal_areas  # lumped nodal areas a_i (/ R^2)
        average = scipy.sparse.csr_matrix(
            (np.full(3 * len(cells), 1.0 / 3.0), (c3, op.dofs.ravel())), shape=(len(cells), n)
        )  # midpoint value of a P1 field
        slope = scipy.sparse.csr_matrix((op.g_theta.ravel(), (c3, op.dofs.ravel())), shape=(len(cells), n))
        self.average_Phi = (average @ Phi).tocsr()  # dW_K/dq
        self.slope_Phi = (slope @ Phi).tocsr()  # dW'_K/dq
        # with a few modes the shapes are dense: their products with the cells' sparse matrices as dense
        # arrays (a sparse-sparse product with a dense result costs ~10 x more)
        self.dense = m < n
        self.to_nodes = op.T_f  # (n, cells): |K|/3 to each vertex
        # the shapes, for deformation() and modal_forces(): a dense array with a few modes (a CSR matrix of
        # its n m entries multiplies ~3 x slower)
        self.Phi = Phi.toarray() if self.dense else Phi
        self.interior = np.ones(n)
        self.interior[op.bc_dofs] = 0.0
        self.gPhiT = (scipy.sparse.diags(self.gains) @ Phi.T).tocsr()
        self.J_qP = -(self.gPhiT @ scipy.sparse.diags(self.areas)).tocsr()
        if self.dense:
            self._average_Phi = self.average_Phi.toarray()
            self._J_qP = self.J_qP.toarray()
            self._gPhiT_cells = (self.gPhiT @ self.to_nodes).toarray()  # (m, cells): dR_q/dF_c per cell
            self._border = self._border_map(op, n)
        # one sparsity pattern for every Jacobian: the union of the blocks' structures
        ones = scipy.sparse.csr_matrix(
            (np.ones(3 * len(cells)), (op.dofs.ravel(), c3)), shape=(n, len(cells))
        )
        A_pattern = scipy.sparse.csr_matrix((np.ones(len(op.indices)), op.indices, op.indptr), shape=(n, n))
        absolute = lambda M: abs(M).tocsr()  # noqa: E731
        Pq = ones @ (absolute(self.average_Phi) + absolute(self.slope_Phi))
        qq = absolute(self.gPhiT) @ ones @ absolute(self.average_Phi) + scipy.sparse.identity(m)
        pattern = scipy.sparse.bmat([[A_pattern, Pq], [absolute(self.J_qP), qq]], format="csr")
        pattern.sum_duplicates()
        pattern.sort_indices()
        self.N = n + m
        self.indptr, self.indices = (
            pattern.indptr.astype(PETSc.IntType),
            pattern.indices.astype(PETSc.IntType),
        )
        self.keys = np.repeat(np.arange(self.N, dtype=np.int64), np.diff(self.indptr)) * self.N + self.indices
        self.A = PETSc.Mat().createAIJ(
            (self.N, self.N), csr=(self.indptr, self.indices, np.zeros(len(self.indices))), comm=self.comm
        )
        self.A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        self.x, self.r = self.A.createVecs()
        self.lower_vec, self.upper_vec = self.A.createVecs()
        self.lower_vec.setArray(np.concatenate([lower, np.full(m, PETSc.NINFINITY)]))
        self.upper_vec.set(PETSc.INFINITY)
        self.lower = lower
        merged = {**DEFAULT_OPTIONS, **ELASTIC_OPTIONS, **(options or {})}
        self._rtol = float(merged["snes_rtol"])
        self.snes = self._snes(merged)
        self.far = self._snes({**DEFAULT_OPTIONS, **FAR_OPTIONS})
        # the reduced-space method's and the sensitivities' factorisation: with a few modes by the Schur
        # complement of the film block (SchurLU), node by node deformation (Winkler) by an LU of the whole
        # fixed pattern
        self.blocks = None
        self.lu = SchurLU(self) if m < n else self._whole_lu()
        self.lu.limit = self._limit
        self._shell = None
        if isinstance(self.lu, SchurLU):  # the reduced-space SNES then needs the blocks only
            self._shell = PETSc.Mat().createPython(
                ((self.N, self.N), (self.N, self.N)), ReducedShell(), comm=self.comm
            )
            self._shell.setUp()
            self.snes.setJacobian(self._blocks_only, self._shell)
        self.damped = DampedLU(
            self.comm, self._limit
        )  # the semismooth method's: LU of its full matrix, limited step
        for snes, context in ((self.snes, self.lu), (self.far, self.damped)):
            pc = snes.getKSP().getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(context)
        self.q = np.zeros(m)
        self.rigid_gap = np.ones(n)  # H_rigid at the dofs of the state being solved (set by the FilmModel)
        self._state: np.ndarray | None = None  # the x of the cached evaluation (and its residual, _r)
        self._positions: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # _scatter's lookup
        self.iterations = 0
        self._factored_state: np.ndarray | None = None  # the solution the sensitivities' factorisation is at

    @staticmethod
    def _midpoint_expressions(operator: MidpointOperator, derivatives) -> list:
        """What ``expression`` evaluates at the midpoints: the operator's coefficients and their
        derivatives in one kernel, which computes the common subexpressions (gap, flow factors) once
        (0.28 ms against 0.41 ms for two at 1514 cells); ``midpoint_values`` splits them."""
        return operator.coefficients + list(derivatives)

    def deformation(self, q: np.ndarray) -> np.ndarray:
        """W = Phi q at the film's dofs (/ c)."""
        return self.Phi @ q

    def modal_forces(self, F: np.ndarray) -> np.ndarray:
        """Phi^T F: nodal forces on the modes."""
        return self.Phi.T @ F

    @staticmethod
    def _border_map(op: MidpointOperator, n: int) -> tuple:
        """dR_P/dq = M Phi with M = [dH, dslope] [average; slope] (n x n): the cells' derivatives of
        A_K P_K + l_K with respect to the midpoint gap and slope, times the midpoint value and slope of a
        P1 field. M has the film's nearest-neighbour pattern and its values are a fixed linear map of
        the cells' derivatives (``local`` and ``slopes`` of jacobian_blocks, concatenated): returns
        (map, M's indices, M's indptr). M Phi reads the n x m shapes once; the product of the n x 2 cells
        derivatives with the 2 cells x m midpoint shapes it replaces read 3.7 x as much memory (0.43 ms a
        Jacobian in the engine cycle; a 40 deg window after firing 28.4 -> 27.3 s)."""
        n_cells = len(op.cells)
        # the derivative entries, in the order of the concatenated values: (row, cell, kind) with kind 0 the
        # gap's (its P1 midpoint value: 1/3 at each vertex) and 1 the slope's (g_theta at each vertex)
        rows = np.concatenate([op.dofs.ravel(), op.dofs.ravel()])
        cell = np.tile(np.repeat(op.cells, 3), 2)
        weights = np.concatenate([np.full((3 * n_cells, 3), 1.0 / 3.0), np.repeat(op.g_theta, 3, axis=0)])
        I = np.repeat(rows, 3)
        J = op.dofs[cell].ravel()
        source = np.repeat(np.arange(len(rows)), 3)
        keys = np.unique(I.astype(np.int64) * n + J)
        position = np.searchsorted(keys, I.astype(np.int64) * n + J)
        mapping = scipy.sparse.csr_matrix((weights.ravel(), (position, source)), shape=(len(keys), len(rows)))
        indices = (keys % n).astype(np.int32)
        indptr = np.searchsorted(keys // n, np.arange(n + 1)).astype(np.int32)
        return mapping, indices, indptr

    def _whole_lu(self) -> FixedPatternLU:
        lu = FixedPatternLU(self)
        # MUMPS pivots: where the gap closes the film's rows become tiny against the deformation's and
        # PETSc's own LU (no pivoting) meets zero pivots
        lu.ksp.getPC().setFactorSolverType("mumps")
        return lu

    def use_whole_lu(self) -> None:
        """An LU of the whole coupled matrix (MUMPS) instead of SchurLU (the reference for its tests)."""
        self.lu.destroy()
        self.lu = self._whole_lu()
        self.lu.limit = self._limit
        self.snes.getKSP().getPC().setPythonContext(self.lu)
        self.snes.setJacobian(self._jacobian, self.A)

    def _snes(self, options: dict) -> PETSc.SNES:
        snes = configured_snes(self.comm, "ehd", options)
        snes.setFunction(self._residual, self.r)
        snes.setJacobian(self._jacobian, self.A)
        snes.setVariableBounds(self.lower_vec, self.upper_vec)
        snes.setForceIteration(True)
        return snes

    # -- the coupled residual and Jacobian ---------------------------------------------------------
    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual at x = (P, q); caches the operator and coefficient derivatives of this state."""
        n = self.n
        P, q = x[:n], x[n:]
        self.P.x.array[:n] = P
        self.W.x.array[:] = self.deformation(q)
        op = self.op
        self.k = self.midpoint_values()  # (cell, 6) at the midpoints
        self._A = scipy.sparse.csr_matrix((op.values, op.indices, op.indptr), shape=(n, n))  # A(H), dR_P/dP
        R_P = self._A @ P + op.source
        p, self.slope = (P, None) if self.pressure_map is None else self.pressure_map(P)
        F = self.areas * p + self.to_nodes @ self.k[:, 4]
        R_q = q - self.gains * self.modal_forces(F)
        self._state = x.copy()
        self._r = np.concatenate([R_P, R_q])
        return self._r

    def midpoint_values(self) -> np.ndarray:
        """The operator filled for the current P and W, and the derivatives (``derivatives`` of the
        constructor) at the cell midpoints, (cell, 6)."""
        values = self.expression.eval(self.op.cells)
        columns = len(self.op.coefficients)
        self.op.evaluate(values[:, :columns])
        return values[:, columns:]

    def _residual(self, snes, x, r) -> None:
        self._evaluate_at(x)  # (the start's is the one ``solve`` has just evaluated)
        r.setArray(self._r)

    def _evaluate_at(self, x: PETSc.Vec) -> None:
        xa = x.getArray(readonly=True)
        if self._state is None or not np.array_equal(xa, self._state):
            self.residual(xa)

    def _jacobian(self, snes, x, J, Pmat) -> None:
        self._evaluate_at(x)
        J.setValuesCSR(self.indptr, self.indices, self._scatter(self.jacobian_matrix("coo")))
        J.assemble()

    def jacobian_blocks(self) -> tuple:
        """(dR_P/dP, dR_P/dq, dR_q/dP, dR_q/dq) at the cached state: scipy matrices, and with a few modes
        the last three dense arrays."""
        op, k, n = self.op, self.k, self.n
        P = self.P.x.array[:n].copy()
        P[op.bc_dofs] = op.bc_values[op.bc_dofs]  # the residual's lifting uses the Dirichlet values
        P_cells = P[op.dofs]  # (cell, 3)
        local = (
            k[:, 0, None] * np.einsum("cij,cj->ci", op.local_theta, P_cells)
            + k[:, 1, None] * np.einsum("cij,cj->ci", op.local_z, P_cells)
            + (k[:, 2] * op.weight / 3.0)[:, None]
        )  # d(A_K P_K + l_K)/dH_K at each vertex
        n_cells = len(op.cells)
        slopes = np.repeat(k[:, 3] * op.weight / 3.0, 3)
        if self.dense:  # the same blocks as dense arrays (module docstring)
            mapping, indices, indptr = self._border
            M = scipy.sparse.csr_matrix(
                (mapping @ np.concatenate([local.ravel(), slopes]), indices, indptr), shape=(n, n)
            )
            J_Pq = self.interior[:, None] * (M @ self.Phi)
            touching = np.flatnonzero(k[:, 5])  # the asperity pressure's slope: on the cells in contact only
            J_qq = np.identity(self.m) - self._gPhiT_cells[:, touching] @ (
                k[touching, 5, None] * self._average_Phi[touching]
            )
            J_qP = self._J_qP if self.slope is None else self._J_qP * self.slope[None, :]
        else:
            rows, cols = op.dofs.ravel(), np.repeat(op.cells, 3)
            dH = scipy.sparse.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n_cells))
            dslope = scipy.sparse.csr_matrix((slopes, (rows, cols)), shape=(n, n_cells))
            J_Pq = scipy.sparse.diags(self.interior) @ (dH @ self.average_Phi + dslope @ self.slope_Phi)
            contact = self.to_nodes @ scipy.sparse.diags(k[:, 5]) @ self.average_Phi
            J_qq = scipy.sparse.identity(self.m) - self.gPhiT @ contact
            J_qP = self.J_qP if self.slope is None else self.J_qP @ scipy.sparse.diags(self.slope)
        return self._A, J_Pq, J_qP, J_qq

    def jacobian_matrix(self, format: str = "csr") -> scipy.sparse.spmatrix:
        """The coupled Jacobian at the cached state (scipy, in ``format``: ``coo`` for the scatter,
        unsorted and with duplicates, which ``_scatter`` sums; ``csr`` for tests)."""
        self.blocks = A, J_Pq, J_qP, J_qq = self.jacobian_blocks()
        if self.dense:
            J_Pq, J_qP, J_qq = (scipy.sparse.csr_matrix(M) for M in (J_Pq, J_qP, J_qq))
        return scipy.sparse.bmat([[A, J_Pq], [J_qP, J_qq]], format=format)

    def _blocks_only(self, snes, x, J, Pmat) -> None:
        """The reduced-space SNES's Jacobian callback with SchurLU: the blocks, no coupled matrix (SchurLU
        reads the blocks; ``preonly`` never applies the operator, a shell)."""
        self._evaluate_at(x)
        self.blocks = self.jacobian_blocks()

    def _scatter(self, J: scipy.sparse.coo_matrix) -> np.ndarray:
        """J's values in the fixed pattern (duplicates summed; zeros where J has no entry). The blocks'
        structures repeat from call to call, so the positions in the pattern are looked up once per
        structure (a sort and a search of every entry cost more than the rest of the Jacobian)."""
        row, col = J.row, J.col
        cached = self._positions
        if (
            cached is None
            or len(cached[0]) != len(row)
            or not (np.array_equal(cached[0], row) and np.array_equal(cached[1], col))
        ):
            position = np.searchsorted(self.keys, row.astype(np.int64) * self.N + col)
            self._positions = cached = (row.copy(), col.copy(), position)
        return np.bincount(cached[2], weights=J.data, minlength=len(self.indices))

    #: the largest change of the film thickness per Newton step (W = w / c): from a far start (a cold
    #: one, or a warm one after a large change of load) the full step overshoots the deformation by
    #: many clearances and the iteration diverges; limited, it follows the film into the solution
    MAX_THICKNESS_STEP = 0.2
    MAX_GAP_CLOSURE = 0.7

    def _limit(self, step: np.ndarray) -> float:
        """The factor of the Newton step x - step: at most MAX_THICKNESS_STEP of film thickness, and at
        most MAX_GAP_CLOSURE of the gap where it is open wider than the flow floor's scale (so the iterates
        do not jump across the contact), and with piezoviscosity at most half the way from the reduced
        pressure to its bound."""
        dW = -self.deformation(step[self.n :])
        largest = float(np.max(np.abs(dW), initial=0.0))
        factor = min(1.0, self.MAX_THICKNESS_STEP / largest) if largest > 0 else 1.0
        H = self.rigid_gap + self.W.x.array[: self.n]
        closing = (dW < 0) & (H > 0.05)
        if np.any(closing):
            factor = min(factor, float(np.min(self.MAX_GAP_CLOSURE * H[closing] / -dW[closing])))
        if self.q_limit is not None:
            rise = -step[: self.n]
            room = self.q_limit - self._state[: self.n]
            up = rise > 0
            if np.any(up):
                factor = min(factor, float(np.min(0.5 * room[up] / rise[up])))
        return factor

    # -- solve ----------------------------------------------------------------------------------
    #: the coupled residual at which a solve has converged, relative to the film's source (or the
    #: deformation's residual at the start, if larger). In the elastic engine cycle 1e-8 moves min
    #: h_min, max p_max and the mean friction power by < 1e-8 of themselves against 1e-11 (100 x below
    #: the integrator's rtol) and takes 23 % fewer Newton iterations (13414 against 17446 per cycle):
    #: from a warm start the first iteration leaves ~1e-6 of the source (median), the second below 1e-11
    TOLERANCE = 1e-8

    def solve(self) -> int:
        """Solve the coupled VI from the last (P, q); returns the Newton iterations."""
        n = self.n
        P0 = self.P.x.array[:n].copy()
        for dof, value in zip(self.op.bc_dofs, self.op.bc_values[self.op.bc_dofs]):
            P0[dof] = value  # Dirichlet values exactly
        x0 = np.concatenate([P0, self.q])
        r0 = self.residual(x0)
        scale = max(np.linalg.norm(self.op.source), np.linalg.norm(r0[n:]), 1e-3)
        atol = max(self.TOLERANCE * scale, 1e-14)
        self.snes.setTolerances(atol=atol, rtol=self._rtol, stol=0.0)
        self.lu.inactive = None
        self.iterations = 0
        reason = self._run(self.snes, x0)
        if reason <= 0:  # from far: the semismooth method brings it near, the reduced-space one finishes
            self.far.setTolerances(atol=max(FAR_TOLERANCE * np.linalg.norm(r0), atol), rtol=0.0, stol=0.0)
            reason = self._run(self.far, x0)
            if reason > 0:
                reason = self._run(self.snes, self.x.getArray(readonly=True).copy())
        x = self.x.getArray(readonly=True).copy()
        if reason <= 0:
            self.residual(x0)  # back to the last good state
            raise FilmNotConverged("elastic film solve did not converge", reason, self.iterations)
        if not np.array_equal(x, self._state):
            self.residual(x)
        self.q = x[n:].copy()
        violation = float(np.max(self.lower - x[:n], initial=0.0))
        if violation > 1e-8 * max(1.0, float(np.max(np.abs(x[:n]), initial=0.0))):
            raise FilmNotConverged(
                f"elastic film solve violated the cavitation bound by {violation:.3g}",
                reason,
                self.iterations,
            )
        return self.iterations

    def _run(self, snes: PETSc.SNES, x0: np.ndarray) -> int:
        """One SNES from x0; its converged reason (negative also for a non-finite result)."""
        self.x.setArray(x0)
        snes.solve(None, self.x)
        self.iterations += snes.getIterationNumber()
        reason = snes.getConvergedReason()
        return reason if np.all(np.isfinite(self.x.getArray(readonly=True))) else -1

    def state(self) -> np.ndarray:
        """The unknowns of the last solve, a copy: the film's (the pressure), then the deformation's."""
        return np.concatenate([self.P.x.array[: self.n], self.q])

    def start_from(self, state: np.ndarray) -> None:
        """Make ``state`` (from ``state``) the next solve's start."""
        self.P.x.array[: self.n] = state[: self.n]
        self.q = state[self.n :].copy()

    # -- sensitivities --------------------------------------------------------------------------
    def inactive_set(self) -> PETSc.IS:
        """The pressurised pressure dofs and every deformation unknown, at the last solution (the
        state of the last residual evaluation, which ``solve`` leaves at the solution)."""
        x, r, n = self._state, self._r, self.n
        scale = max(1.0, float(np.max(np.abs(r[:n]), initial=0.0)))
        active = (x[:n] <= self.lower + 1e-12 * max(1.0, float(np.max(np.abs(x[:n]))))) & (
            r[:n] > 1e-10 * scale
        )
        keep = np.concatenate([~active, np.ones(self.m, dtype=bool)])
        return PETSc.IS().createGeneral(np.flatnonzero(keep).astype(PETSc.IntType), comm=self.comm)

    def residual_derivatives(self, dr_P: list[np.ndarray], variables: list[str]) -> list[np.ndarray]:
        """dR/dtheta = (dR_P/dtheta, dR_q/dtheta) at fixed (P, q); dR_q/deps from the asperity forces."""
        out = []
        angle = self.op.centroid_angle
        for d, name in zip(dr_P, variables):
            d_q = np.zeros(self.m)
            if name in ("eps_x", "eps_y"):  # H_K = ... - eps_x cos - eps_y sin at the midpoints
                dH = -np.cos(angle) if name == "eps_x" else -np.sin(angle)
                d_q = -self.gains * self.modal_forces(self.to_nodes @ (self.k[:, 5] * dH))
            out.append(np.concatenate([d, d_q]))
        return out

    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(P, q)/dtheta = -J_II^-1 dR/dtheta on the inactive set (active set frozen), 0 elsewhere.

        The Jacobian is evaluated and factorised at the solution (once per solution): the last Newton
        iteration's factorisation is at the iterate before it (from a warm start that converges in one
        iteration, the start), and the semismooth method leaves its own modified matrix in A."""
        if self.lu.inactive is None or self._factored_state is not self._state:
            self._factored_state = self._state
            inactive = self.inactive_set()
            if isinstance(self.lu, SchurLU):
                self._blocks_only(None, self.x, None, None)
            else:
                self._jacobian(None, self.x, self.A, self.A)
            self.lu.factor(inactive)
        out = []
        keep = self.lu.local
        for d in dr:
            values = np.zeros(self.N)
            values[keep] = -d[keep]
            self.lu.b.setArray(values)
            self.lu.solve_full(self.lu.b, self.lu.x)
            out.append(self.lu.x.getArray(readonly=True).copy())
        return out

    def close(self) -> None:
        self.lu.destroy()
        self.damped.destroy()
        for obj in (self.snes, self.far, self.A, self.x, self.r, self.lower_vec, self.upper_vec, self._shell):
            if obj is not None:
                obj.destroy()


def deformation_peak(W: np.ndarray, coords: np.ndarray, clearance: float) -> tuple[float, float]:
    """(largest |w| [m], its bushing angle [rad]) over the film's nodes; w keeps its sign."""
    if not len(W):
        return 0.0, 0.0
    i = int(np.argmax(np.abs(W)))
    return float(W[i] * clearance), math.atan2(coords[i, 1], coords[i, 0]) % (2 * math.pi)


__all__ = [
    "DampedLU",
    "ElasticFilm",
    "ModalCompliance",
    "SchurLU",
    "WinklerLayer",
    "bushing_model",
    "deformation_peak",
]
