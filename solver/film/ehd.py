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

Pressure and deformation are solved together by one Newton (``CoupledNewton``) on the film's rows, given
by a cavitation block (solver.film.interfaces.CavitationBlock: ``ReynoldsRows``, the SNES VI P >= P_cav
of solver.film.coupled_reynolds; ``JFORows``, the semismooth JFO rows of solver.film.cavitation_jfo),
and the bushing's rows, which are this module's. With the Reynolds rows::

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
which is formed anew, m back-substitutions, only when that converges slowly). Node by node (the FE
eye's layer basis, W = q_L + Phi q, and a WinklerLayer) SchurLU first eliminates q_L where its row is
q_L = g F(P) (every node off the cells in asperity contact): the film block becomes J_uu + L diag(d),
L = dR_u/dW in the film's own pattern (``border_map``), d = g a dp/du, and the kept q_L and the modes
are the borders (``LayeredBlocks``); the whole matrix (MUMPS) remains the semismooth far start's.
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
import scipy.sparse
import ufl
from dolfinx import fem

from solver.film.tensors import MIDPOINT, MidpointOperator

log = logging.getLogger(__name__)

#: the largest change of the film thickness per Newton step (W = w / c): from a far start (a cold
#: one, or a warm one after a large change of load) the full step overshoots the deformation by
#: many clearances and the iteration diverges; limited, it follows the film into the solution
MAX_THICKNESS_STEP = 0.2
MAX_GAP_CLOSURE = 0.7
#: the C compiler's options for the coupled film's kernel (the block's coefficients and their derivatives
#: at the midpoints), which is evaluated at every residual, 2.6 times a film solve in the engine (the
#: rigid films evaluate theirs once a solve): dolfinx's -O2 and the floating-point rules relaxed so that
#: the compiler may reassociate and share the many subexpressions of the flow factors, the contact and
#: their derivatives (1.63 -> 0.97 ms at the 2561 cells of cases/reference-2000rpm-ehd-jfo;
#: docs/benchmarks.md). Not -ffinite-math-only (a far iterate's overflow must stay inf or NaN, which
#: the Newton tests) nor -march=native (a JIT cache shared by the nodes of a cluster)
KERNEL_JIT = {"cffi_extra_compile_args": ["-O2", "-g0", "-funsafe-math-optimizations", "-fno-math-errno"]}


def step_factor(
    H: np.ndarray,
    dW: np.ndarray,
    P: np.ndarray | None = None,
    dP: np.ndarray | None = None,
    q_limit: float | None = None,
) -> float:
    """The factor of a coupled Newton step that changes the film thickness H by dW and the pressure P by
    dP: at most MAX_THICKNESS_STEP of film thickness, at most MAX_GAP_CLOSURE of the gap where it is
    open wider than the flow floor's scale (so the iterates do not jump across the contact), and with
    piezoviscosity (``q_limit``: the reduced pressure's bound) at most half the way from P to it."""
    largest = float(np.max(np.abs(dW), initial=0.0))
    factor = min(1.0, MAX_THICKNESS_STEP / largest) if largest > 0 else 1.0
    closing = (dW < 0) & (H > 0.05)
    if np.any(closing):
        factor = min(factor, float(np.min(MAX_GAP_CLOSURE * H[closing] / -dW[closing])))
    if q_limit is not None:
        room = q_limit - P
        up = dP > 0
        if np.any(up):
            factor = min(factor, float(np.min(0.5 * room[up] / dP[up])))
    return factor


class CoupledNewton:
    """The film's rows (a cavitation block) and the bushing's rows (module docstring) on one fixed
    sparsity pattern, x = (u, q) with u the block's nodal unknown and q the deformation's.

    Args:
        operator: the film's MidpointOperator.
        P: the pressure Function; W: the deformation Function W = w / c in the film's forms.
        derivatives: UFL expressions (dk_theta/dW, dk_z/dW, df/dW, df/dW', P_c, dP_c/dW).
        shapes: (Phi, g) at the film's dofs (solver.film.bushings.Bushing.shapes).
        block: the film's rows (solver.film.interfaces.CavitationBlock); attached here.
        pressure_map: with piezoviscosity P is the reduced pressure: ``pressure_map(P) -> (p, dp/dP)``
            gives the true pressure that loads the bushing (solver.film.viscosity); q_limit: the
            reduced pressure's bound (the Newton steps stay below it).
    """

    def __init__(
        self,
        operator: MidpointOperator,
        P: fem.Function,
        W: fem.Function,
        derivatives,
        shapes,
        block,
        pressure_map=None,
        q_limit: float | None = None,
    ):
        self.op, self.P, self.W, self.block = operator, P, W, block
        self.pressure_map, self.q_limit = pressure_map, q_limit
        self.comm = MPI.COMM_SELF
        # the block's coefficients and the derivatives in one kernel, which computes the common
        # subexpressions (gap, flow factors) once (0.28 ms against 0.41 ms for two at 1514 cells)
        self.columns = len(block.coefficients)
        self.expression = fem.Expression(
            ufl.as_vector(list(block.coefficients) + list(derivatives)), MIDPOINT, jit_params=KERNEL_JIT
        )
        Phi, gains = shapes
        Phi = scipy.sparse.csr_matrix(Phi)
        op = operator
        n, m = len(op.indptr) - 1, Phi.shape[1]
        self.n, self.m = n, m
        #: the layer basis (and a WinklerLayer, its m = 0 case): the first n unknowns are the deformation
        #: node by node (Phi = [I, Phi_modes]), eliminated from the Newton systems (``layered_blocks``)
        self.layered = m >= n and _is_identity(Phi[:, :n])
        self.modes = m - n if self.layered else m  # the dense columns of Phi
        cells = op.cells
        c3 = np.repeat(cells, 3)
        self.areas = op.nodal_areas  # lumped nodal areas a_i (/ R^2)
        self._average = scipy.sparse.csr_matrix(
            (np.full(3 * len(cells), 1.0 / 3.0), (c3, op.dofs.ravel())), shape=(len(cells), n)
        )  # midpoint value of a P1 field
        self._slope = scipy.sparse.csr_matrix(
            (op.g_theta.ravel(), (c3, op.dofs.ravel())), shape=(len(cells), n)
        )  # its slope d/dtheta
        # with a few modes the shapes are dense: their products with the cells' sparse matrices as dense
        # arrays (a sparse-sparse product with a dense result costs ~10 x more)
        self.dense = m < n and not self.layered
        self.to_nodes = op.T_f  # (n, cells): |K|/3 to each vertex
        self.interior = np.ones(n)
        self.interior[op.bc_dofs] = 0.0
        if self.dense or self.layered:
            self.border = border_map(op, n)
        if self.layered:  # the midpoint value of a P1 field
            self.average = self._average
            self._pattern_rows = np.repeat(np.arange(n), np.diff(op.indptr))  # the row of each entry of M
            self._to_nodes_csc = self.to_nodes.tocsc()  # (its columns of the cells in contact)
        self.gains = np.asarray(gains, float)
        self._set_shapes(Phi)
        # one sparsity pattern for every Jacobian: the union of the blocks' structures
        ones = scipy.sparse.csr_matrix(
            (np.ones(3 * len(cells)), (op.dofs.ravel(), c3)), shape=(n, len(cells))
        )
        A_pattern = scipy.sparse.csr_matrix((np.ones(len(op.indices)), op.indices, op.indptr), shape=(n, n))
        # the modes' columns full (``set_shapes`` may change the shapes, not the pattern; the modes' shapes
        # have no zero entries, so this is their pattern anyway)
        structure = abs(Phi).tocsr()
        if self.dense:
            structure = scipy.sparse.csr_matrix(np.ones((n, m)))
        elif self.layered and self.modes:
            structure = scipy.sparse.hstack(
                [Phi[:, :n], scipy.sparse.csr_matrix(np.ones((n, self.modes)))], format="csr"
            )
        average_structure = (self._average @ structure).tocsr()
        Pq = ones @ (abs(average_structure) + abs(self._slope @ structure))
        gPhiT_structure = scipy.sparse.diags(self.gains) @ structure.T
        qq = abs(gPhiT_structure) @ ones @ abs(average_structure) + scipy.sparse.identity(m)
        J_qP_structure = abs(gPhiT_structure @ scipy.sparse.diags(self.areas))
        pattern = scipy.sparse.bmat([[A_pattern, Pq], [J_qP_structure, qq]], format="csr")
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
        self.q = np.zeros(m)
        self.rigid_gap = np.ones(n)  # H_rigid at the dofs of the state being solved (set by the film)
        self.state_x: np.ndarray | None = None  # the x of the cached evaluation (and its residual)
        self.residual_x: np.ndarray | None = None
        self.k: np.ndarray | None = None  # the derivatives at the midpoints of the cached state
        self.slope: np.ndarray | None = None  # dp/dP of the cached state (piezoviscosity), or None
        self._positions: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # _scatter's lookup
        self.iterations = 0
        block.attach(self)

    def _set_shapes(self, Phi) -> None:
        """The shapes Phi (n x m) and the blocks built from them (and from the gains)."""
        Phi = scipy.sparse.csr_matrix(Phi)
        n = self.n
        self._Phi_sparse = Phi
        self.average_Phi = (self._average @ Phi).tocsr()  # dW_K/dq
        self.slope_Phi = (self._slope @ Phi).tocsr()  # dW'_K/dq
        # the shapes, for deformation() and modal_forces(): a dense array with a few modes (a CSR matrix of
        # its n m entries multiplies ~3 x slower)
        self.Phi = Phi.toarray() if self.dense else Phi
        if self.dense:
            self.average_Phi_dense = self.average_Phi.toarray()
        if self.layered:  # the modes' shapes dense (n x modes)
            self.Phi_modes = Phi[:, n:].toarray()
        self._set_gains(self.gains)

    def set_shapes(self, Phi) -> None:
        """New shapes of the same size and kind (solver.film.bushings.Bushing.shapes: the FE eye's seen from
        a frame turned against it, solver.film.solvers.CoupledFilm.set_bushing_angle), the gains kept:
        what is built from Phi anew; the pattern stays (the modes' columns are full in it), the state
        (u, q) stays (the modal unknowns are the eye's), the cached evaluation is dropped. SchurLU's last
        Schur complement only preconditions the next factorisation's Schur system (solved to 1e-12), and
        it is formed anew when it no longer does so well."""
        Phi = scipy.sparse.csr_matrix(Phi)
        if Phi.shape != (self.n, self.m) or (self.layered and not _is_identity(Phi[:, : self.n])):
            raise ValueError(f"shapes of shape {Phi.shape} for a coupled Newton of {self.n} x {self.m}")
        self._set_shapes(Phi)
        self.state_x = self.residual_x = self.k = self.slope = None

    def _set_gains(self, gains) -> None:
        """The gains g and the blocks built from them: g Phi^T, dR_q/dP = -g Phi^T diag(a) and, with a few
        modes, their dense copies (their sparsity does not depend on g > 0: the pattern stays)."""
        self.gains = np.asarray(gains, float)
        self.gPhiT = (scipy.sparse.diags(self.gains) @ self._Phi_sparse.T).tocsr()
        self.J_qP = -(self.gPhiT @ scipy.sparse.diags(self.areas)).tocsr()
        if self.dense:
            self.J_qP_dense = self.J_qP.toarray()
            self.gPhiT_cells = (self.gPhiT @ self.to_nodes).toarray()  # (m, cells): dR_q/dF_c per cell
        if self.layered:  # the modes' g Phi^T (modes x n)
            self.gPhiT_modes = self.gains[self.n :, None] * self.Phi_modes.T

    def set_scales(self, gains, pressure_map=None, q_limit: float | None = None) -> None:
        """A new p_ref (a new viscosity): the bushing's gains (solver.film.bushings.Bushing.shapes) and
        what is built from them, the piezoviscous pressure map and the reduced pressure's bound (as in
        the constructor); the compiled expression, the pattern and the state (u, q) stay, the cached
        evaluation is dropped."""
        self._set_gains(gains)
        self.pressure_map, self.q_limit = pressure_map, q_limit
        self.state_x = self.residual_x = self.k = self.slope = None

    def deformation(self, q: np.ndarray) -> np.ndarray:
        """W = Phi q at the film's dofs (/ c)."""
        if self.layered:
            return q[: self.n] + self.Phi_modes @ q[self.n :]
        return self.Phi @ q

    def modal_forces(self, F: np.ndarray) -> np.ndarray:
        """Phi^T F: nodal forces on the modes."""
        if self.layered:
            return np.concatenate([F, self.Phi_modes.T @ F])
        return self.Phi.T @ F

    # -- the coupled residual and Jacobian ---------------------------------------------------------
    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual at x = (u, q); caches the state's evaluation (the block's and the derivatives)."""
        n = self.n
        u, q = x[:n], x[n:]
        P = self.block.pressure(u)
        self.P.x.array[:n] = P
        self.W.x.array[:] = self.deformation(q)
        values = self.expression.eval(self.op.cells)
        self.k = values[:, self.columns :]  # (cell, 6) at the midpoints
        R_u = self.block.rows(u, values[:, : self.columns])
        p, self.slope = (P, None) if self.pressure_map is None else self.pressure_map(P)
        F = self.areas * p + self.to_nodes @ self.k[:, 4]
        R_q = q - self.gains * self.modal_forces(F)
        self.state_x = x.copy()
        self.residual_x = np.concatenate([R_u, R_q])
        return self.residual_x

    def snes_residual(self, snes, x, r) -> None:
        """The SNES's residual callback."""
        self.evaluate_at(x)  # (the start's is the one the solve has just evaluated)
        r.setArray(self.residual_x)

    def evaluate_at(self, x: PETSc.Vec) -> None:
        """The residual at x unless it is the cached state's."""
        xa = x.getArray(readonly=True)
        if self.state_x is None or not np.array_equal(xa, self.state_x):
            self.residual(xa)

    def snes_jacobian(self, snes, x, J, Pmat) -> None:
        """The SNES's Jacobian callback: the block's coupled Jacobian in the fixed pattern."""
        self.evaluate_at(x)
        J.setValuesCSR(self.indptr, self.indices, self.scatter(self.jacobian_matrix("coo")))
        J.assemble()

    def jacobian_matrix(self, format: str = "csr") -> scipy.sparse.spmatrix:
        """The coupled Jacobian at the cached state (scipy, in ``format``: ``coo`` for the scatter,
        unsorted and with duplicates, which ``scatter`` sums; ``csr`` for tests)."""
        return self.block.jacobian_matrix(format)

    def bushing_blocks(self, slope: np.ndarray | None, dense: bool) -> tuple:
        """(dR_q/du, dR_q/dq) at the cached state, with ``slope`` the true pressure's derivative dp/du at each
        node (None: 1): dense arrays or scipy matrices."""
        k = self.k
        if dense:
            touching = np.flatnonzero(k[:, 5])  # the asperity pressure's slope: on the cells in contact only
            J_qq = np.identity(self.m) - self.gPhiT_cells[:, touching] @ (
                k[touching, 5, None] * self.average_Phi_dense[touching]
            )
            J_qu = self.J_qP_dense if slope is None else ScaledBorder(self.J_qP_dense, slope)
        else:
            contact = self.to_nodes @ scipy.sparse.diags(k[:, 5]) @ self.average_Phi
            J_qq = scipy.sparse.identity(self.m) - self.gPhiT @ contact
            J_qu = self.J_qP if slope is None else self.J_qP @ scipy.sparse.diags(slope)
        return J_qu, J_qq

    def layered_blocks(self, J_uu, M, rows: np.ndarray, slope: np.ndarray) -> "LayeredBlocks":
        """The Jacobian's blocks at the cached state in the layer basis, for SchurLU's elimination of the
        node-by-node deformation (``LayeredBlocks``): ``J_uu`` = dR_u/du (CSR, the operator's layout),
        ``M`` = dR_u/dW (CSR, the same pattern: solver.film.ehd.border_map) before ``rows`` (1 on the
        block's own rows, 0 on its prescribed ones) masks it, ``slope`` the true pressure's dp/du at each
        node."""
        n, k = self.n, self.k
        L = M.copy()
        L.data = L.data * rows[self._pattern_rows]  # dR_u/dW = dR_u/dq_L
        d = self.gains[:n] * self.areas * slope  # dR_L/du = -diag(d)
        touching = np.flatnonzero(k[:, 5])  # the asperity pressure's slope: on the cells in contact only
        kept = np.unique(self.op.dofs[touching])  # their vertices: the local unknowns kept
        modes, size = self.modes, len(kept)
        # the contact's nodal forces per W, to_nodes diag(dP_c/dW) average: its entries are in kept x kept
        contact = (self._to_nodes_csc[:, touching][kept].toarray() * k[touching, 5][None, :]) @ (
            self.average[touching][:, kept].toarray()
        )
        g_kept = self.gains[kept, None]
        # the borders' rows' blocks: (L_kept, modes) against (L_kept, modes)
        D = np.identity(size + modes)
        D[:size, :size] -= g_kept * contact
        if modes and size:
            Phi_kept, gPhiT_kept = self.Phi_modes[kept], self.gPhiT_modes[:, kept]
            D[:size, size:] = -g_kept * (contact @ Phi_kept)
            D[size:, :size] = -gPhiT_kept @ contact
            D[size:, size:] -= gPhiT_kept @ (contact @ Phi_kept)
        B_modes = (rows[:, None] * (L @ self.Phi_modes)) if modes else np.zeros((n, 0))  # dR_u/dq_modes
        C_modes = -self.gPhiT_modes * (self.areas * slope)[None, :]  # dR_modes/du
        return LayeredBlocks(J_uu, L, d, kept, B_modes, C_modes, D)

    def scatter(self, J: scipy.sparse.coo_matrix) -> np.ndarray:
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

    def limit(self, step: np.ndarray) -> float:
        """The factor of the Newton step x - step (``step_factor``: the film thickness's change, and the
        pressure's from the block's unknown)."""
        n = self.n
        dW = -self.deformation(step[n:])
        H = self.rigid_gap + self.W.x.array[:n]
        if self.q_limit is None:
            return step_factor(H, dW)
        P, dP = self.block.pressure_step(self.state_x[:n], step[:n])
        return step_factor(H, dW, P, dP, self.q_limit)

    # -- solve, state, sensitivities ---------------------------------------------------------------
    def solve(self) -> int:
        """Solve from the last (u, q) (the block's Newton); returns the iterations."""
        self.iterations = self.block.solve()
        return self.iterations

    def state(self) -> np.ndarray:
        """The unknowns of the last solve, a copy: the film's (the block's u), then the deformation's."""
        return np.concatenate([self.block.film_state(), self.q])

    def start_from(self, state: np.ndarray) -> None:
        """Make ``state`` (from ``state``) the next solve's start."""
        self.block.start_from(state[: self.n])
        self.q = state[self.n :].copy()

    def residual_derivatives(self, dr_u: list[np.ndarray], variables: list[str]) -> list[np.ndarray]:
        """dR/dtheta = (dR_u/dtheta, dR_q/dtheta) at fixed (u, q); dR_q/deps from the asperity forces."""
        out = []
        angle = self.op.centroid_angle
        for d, name in zip(dr_u, variables):
            d_q = np.zeros(self.m)
            if name in ("eps_x", "eps_y"):  # H_K = ... - eps_x cos - eps_y sin at the midpoints
                dH = -np.cos(angle) if name == "eps_x" else -np.sin(angle)
                d_q = -self.gains * self.modal_forces(self.to_nodes @ (self.k[:, 5] * dH))
            out.append(np.concatenate([d, d_q]))
        return out

    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(P - P_cav, q)/dtheta for the residual derivatives ``dr`` (the block's, its set frozen)."""
        return self.block.sensitivities(dr)

    def close(self) -> None:
        self.block.close()
        for obj in (self.A, self.x, self.r):
            obj.destroy()


class LayeredBlocks:
    """The coupled Jacobian's blocks in the layer basis (W = q_L + Phi_modes q_modes, q_L the deformation
    node by node): ``A`` = dR_u/du and ``L`` = dR_u/dq_L (n x n, the film's pattern), dR_L/du = -diag(``d``)
    (the layer's compliance times the pressure's slope), the nodes ``kept`` (the vertices of the cells in
    asperity contact: there dR_L/dq couples neighbours and the modes; elsewhere it is the identity row),
    ``B_modes`` = dR_u/dq_modes, ``C_modes`` = dR_modes/du and ``D`` the borders' own block on
    (q_L at ``kept``, q_modes). solver.film.coupled_lu.SchurLU eliminates the other q_L."""

    __slots__ = ("A", "L", "d", "kept", "B_modes", "C_modes", "D")

    def __init__(self, A, L, d, kept, B_modes, C_modes, D):
        self.A, self.L, self.d, self.kept = A, L, d, kept
        self.B_modes, self.C_modes, self.D = B_modes, C_modes, D


class ModalBorder:
    """dR_u/dq = diag(``rows``) M Phi (n x m) of a film with a few modes, kept as its factors: M (n x n, the
    film's nearest-neighbour pattern: solver.film.ehd.border_map) and the shapes Phi (n x m, dense). A
    product with a vector is two products (M sparse, Phi dense) instead of the n x m product formed at
    every Jacobian (~1.2 ms with 183 modes at 1405 dofs); solver.film.coupled_lu.SchurLU forms it
    (``toarray``) only with a Schur complement, about one factorisation in six."""

    __slots__ = ("rows", "M", "Phi", "shape")

    def __init__(self, rows: np.ndarray, M: scipy.sparse.csr_matrix, Phi: np.ndarray):
        self.rows, self.M, self.Phi = rows, M, Phi
        self.shape = Phi.shape

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        product = self.M @ (self.Phi @ v)
        return self.rows * product if product.ndim == 1 else self.rows[:, None] * product

    def toarray(self) -> np.ndarray:
        return self.rows[:, None] * (self.M @ self.Phi)

    def zeroed(self, rows: np.ndarray) -> ModalBorder:
        """The border with ``rows`` zeroed (the active set's)."""
        kept = self.rows.copy()
        kept[rows] = 0.0
        return ModalBorder(kept, self.M, self.Phi)


class ScaledBorder:
    """dR_q/du = J diag(``scale``) (m x n) of a film with a few modes, kept as its factors: J = dR_q/dP
    (fixed, dense) and the true pressure's slope dp/du at each node (piezoviscosity), so that no m x n
    product is formed at every Jacobian."""

    __slots__ = ("J", "scale", "shape")

    def __init__(self, J: np.ndarray, scale: np.ndarray):
        self.J, self.scale = J, scale
        self.shape = J.shape

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        return self.J @ (self.scale * v if v.ndim == 1 else self.scale[:, None] * v)

    def toarray(self) -> np.ndarray:
        return self.J * self.scale[None, :]

    def zeroed(self, columns: np.ndarray) -> ScaledBorder:
        """The border with ``columns`` zeroed (the active set's)."""
        scale = self.scale.copy()
        scale[columns] = 0.0
        return ScaledBorder(self.J, scale)


def as_array(block) -> np.ndarray:
    """A border as a dense array (``ModalBorder``, ``ScaledBorder`` or already an array)."""
    return block.toarray() if isinstance(block, (ModalBorder, ScaledBorder)) else block


def _is_identity(block: scipy.sparse.csr_matrix) -> bool:
    """Whether a square CSR block is the identity."""
    block = block.tocsr()
    block.sum_duplicates()
    n = block.shape[0]
    return (
        block.nnz == n
        and np.array_equal(block.indptr, np.arange(n + 1))
        and np.array_equal(block.indices, np.arange(n))
        and np.all(block.data == 1.0)
    )


def border_map(op: MidpointOperator, n: int) -> tuple:
    """dR_P/dq = M Phi with M = [dH, dslope] [average; slope] (n x n): the cells' derivatives of
    A_K P_K + l_K with respect to the midpoint gap and slope, times the midpoint value and slope of a
    P1 field. M has the film's nearest-neighbour pattern and its values are a fixed linear map of
    the cells' derivatives (``local`` and ``slopes`` of ReynoldsRows.jacobian_blocks, concatenated):
    returns (map, M's indices, M's indptr). M Phi reads the n x m shapes once; the product of the
    n x 2 cells derivatives with the 2 cells x m midpoint shapes it replaces read 3.7 x as much memory
    (0.43 ms a Jacobian in the engine cycle; a 40 deg window after firing 28.4 -> 27.3 s)."""
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


def deformation_peak(W: np.ndarray, coords: np.ndarray, clearance: float) -> tuple[float, float]:
    """(largest |w| [m], its bushing angle [rad]) over the film's nodes; w keeps its sign."""
    if not len(W):
        return 0.0, 0.0
    i = int(np.argmax(np.abs(W)))
    return float(W[i] * clearance), math.atan2(coords[i, 1], coords[i, 0]) % (2 * math.pi)


__all__ = [
    "CoupledNewton",
    "deformation_peak",
    "step_factor",
]
