"""Mass-conserving film (JFO) on an elastic bushing: one semismooth Newton on (u, q) in PETSc SNES.

The JFO film of solver.film.jfo (one nodal unknown u: P - P_cav = max(u, 0), theta = 1 + min(u, 0)) on
the deformed gap H = H_rigid + Phi q of solver.film.ehd, with the bushing's equation as there::

    R_u(u, q) = K(H) max(u, 0) + T(H) theta(u) + s(H, theta) = 0     (prescribed dofs: u - u_bc)
    R_q(u, q) = q - g * Phi^T (a p(P) + F_c(H)) = 0

K the Poiseuille matrix (H^3 phi_x, H^3 phi_y), T the conservative Couette transport of the mean gap
h_T with Kuzmin's upwinding (limited edge by edge when ``MidpointJFO.limited`` is set: solver.film.jfo.
TransportLimiter, from the last committed film fraction), s the storage in its rate form:
m (theta - theta_ref) / dT + mdot theta, m_i = integral(h_T phi_i), mdot_i = integral(phi_c dH/dT
phi_i), with the deformation's rate inside dH/dT (solver.film.reynolds.FilmGeometry) and dtheta/dT by
BDF2 through the committed states (``theta_ref``, ``dT``; solver.film.history). Every coefficient is
evaluated at the cell midpoints
(the operator's rule, solver.film.tensors), so the matrices are sums over cells of fixed local
matrices times these values, and their derivatives with respect to the midpoint gap H_K are as
cheap. The exact Jacobian::

    dR_u/du = K diag(u > 0) + (T + diag(m/dT + mdot)) diag(u <= 0)       (identity rows: prescribed)
    dR_u/dq = sum over K of dR_u/dH_K dH_K/dq          (the upwinding's edge diffusion follows the
                                                        entry that is its maximum at this state)
    dR_q/du = -g Phi^T diag(a dp/dP (u > 0))
    dR_q/dq = I - g Phi^T (dF_c/dH) Phi

No bounds: semismooth Newton (``newtonls``, basic line search, the step limited as the coupled VI's,
``ElasticFilm._limit``) converges when a step keeps the partition (u > 0) and the residual is at
round-off; the LU of the full matrix is refactorised numerically (one pattern). The forces'
sensitivities to the kinematics use the same matrix.
"""

from __future__ import annotations

import logging

from petsc4py import PETSc

import numpy as np
import scipy.sparse
import ufl
from dolfinx import fem

from solver.errors import FilmNotConverged
from solver.film.cavitation import configured_snes
from solver.film.coupled_lu import DampedLU
from solver.film.ehd import ElasticFilm
from solver.film.jfo import JFOSolution, semismooth_reason, upwind_pick
from solver.film.tensors import MIDPOINT

log = logging.getLogger(__name__)

#: PETSc options of the coupled semismooth Newton
OPTIONS: dict[str, str | float | int] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_max_it": 60,
    "snes_divergence_tolerance": -1.0,
    "ksp_type": "preonly",
    "pc_type": "python",
}


class MidpointJFO:
    """The JFO film's matrices as sums over cells of fixed local matrices times the coefficients at the
    cell midpoints (the operator's rule, solver.film.tensors), and their derivatives.

    With P1 and the midpoint rule the Couette matrix of cell K is ``C^K_ij = -|K|/3 flux(c_K)
    t.grad(phi_i)`` (any j), the Poiseuille matrix ``k_theta(c_K) L_theta + k_z(c_K) L_z`` and the
    lumped storage |K|/3 h_T(c_K) and |K|/3 rate(c_K) at each vertex; so the derivative of the
    residual R_u with respect to anything the five coefficients (k_theta, k_z, flux, h_T, rate) depend
    on is the same sum with their derivatives (``local_bases``, ``local_derivative``), the upwinding's
    edge diffusion following the entry that is its maximum at the state (``upwinded``).

    Args:
        op: the film's MidpointOperator (serial P1).
        coefficients: the five UFL coefficients.
        variables: ufl.variables to differentiate them by (``kinematic_derivatives``).
        is_bc: the prescribed dofs (their rows of R_u are u - u_bc: zero derivatives).
    """

    def __init__(self, op, coefficients, variables, is_bc: np.ndarray):
        self.op, self.n_variables, self.is_bc = op, len(variables), is_bc
        n = len(op.indptr) - 1
        values = list(coefficients)
        derivatives = [ufl.algorithms.expand_derivatives(ufl.diff(e, c)) for c in variables for e in values]
        self.expression = fem.Expression(ufl.as_vector(values + derivatives), MIDPOINT)
        # the coefficients and the operator's midpoint integrals (the Couette torques), evaluated together
        self.values_expression = fem.Expression(ufl.as_vector(values + op.integrands), MIDPOINT)
        self.local_couette = -(op.weight / 3.0)[:, None, None] * np.repeat(op.g_theta[:, :, None], 3, axis=2)
        self.T_C = scipy.sparse.csr_matrix(
            (self.local_couette.ravel(), (op.positions.ravel(), np.repeat(op.cells, 9))),
            shape=(len(op.indices), len(op.cells)),
        )
        self.rows = np.repeat(np.arange(n), np.diff(op.indptr))
        keys = self.rows.astype(np.int64) * n + op.indices
        self.transpose = np.searchsorted(keys, op.indices.astype(np.int64) * n + self.rows)
        self.off = self.rows != op.indices
        self.diagonal = np.flatnonzero(~self.off)
        #: the film fraction's limited transport (solver.film.jfo.TransportLimiter), set per solve by the
        #: film; None: upwind
        self.limited = None

    def operator(self) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
        """((K's CSR values, the Couette matrix's before upwinding, m, mdot), the operator's integrals)
        at the current constants (one evaluation at the midpoints; the integrals as
        MidpointOperator.evaluate gives them)."""
        op = self.op
        c = self.values_expression.eval(op.cells)
        matrices = (
            op.T_theta @ c[:, 0] + op.T_z @ c[:, 1],
            self.T_C @ c[:, 2],
            op.T_f @ c[:, 3],
            op.T_f @ c[:, 4],
        )
        return matrices, op.weight @ c[:, 5:]

    def upwinded(self, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(upwinded values, d_ij, pick_self) of the Couette matrix's CSR values C: Kuzmin's edge
        diffusion d_ij = max(0, C_ij, C_ji), the pair's larger entry picked the same way from both
        sides (ties: the one in the lower row); with ``limited`` scaled edge by edge by 1 - alpha_ij
        (constant at a state: the limiter's film fraction is a committed one)."""
        Ct = C[self.transpose]
        pick_self = upwind_pick(C, Ct, self.rows, self.op.indices)
        d = np.where(self.off, np.maximum(0.0, np.where(pick_self, C, Ct)), 0.0)
        if self.limited is not None:
            d = d * self.limited.factor(pick_self)
        values = C - d
        values[self.diagonal] += np.add.reduceat(d, self.op.indptr[:-1])
        return values, d, pick_self

    def local_bases(self, u: np.ndarray, selection, rate) -> np.ndarray:
        """(5, cell, 3): d R_u at each cell's vertices per unit change of each coefficient at the cell's
        midpoint, at fixed u; ``selection`` = (d, pick_self) of ``upwinded`` at the state; ``rate`` =
        (dT, theta_ref) or None. R_u is linear in the five coefficients of a cell, so the derivative
        with respect to any parameter s is ``sum_j dc_j/ds bases_j`` (``local_derivative``)."""
        op = self.op
        plus, theta = np.maximum(u, 0.0)[op.dofs], (1.0 + np.minimum(u, 0.0))[op.dofs]  # (cell, 3)
        third = (op.weight / 3.0)[:, None]
        d, pick = selection
        active = d[op.positions] > 0.0
        picked, other = pick[op.positions] & active, ~pick[op.positions] & active  # d_ij follows C_ij or C_ji
        couette = self.local_couette
        diffusion = np.where(picked, couette, 0.0) + np.where(other, np.swapaxes(couette, 1, 2), 0.0)
        diffusion[:, np.arange(3), np.arange(3)] = 0.0
        if self.limited is not None:  # each edge keeps 1 - alpha_ij of its diffusion
            diffusion *= self.limited.factor(pick)[op.positions]
        bases = np.empty((5,) + plus.shape)
        bases[0] = np.einsum("cij,cj->ci", op.local_theta, plus)
        bases[1] = np.einsum("cij,cj->ci", op.local_z, plus)
        bases[2] = np.einsum("cij,cj->ci", couette, theta) - np.einsum(
            "cij,cij->ci", diffusion, theta[:, None, :] - theta[:, :, None]
        )
        bases[3] = 0.0 if rate is None else third * (theta - rate[1][op.dofs]) / rate[0]
        bases[4] = third * theta
        return bases

    @staticmethod
    def local_derivative(dc: np.ndarray, bases: np.ndarray) -> np.ndarray:
        """d R_u / d s at each cell's vertices (cell, 3) from the coefficients' derivatives dc (cell, 5)."""
        return np.einsum("cj,jci->ci", dc, bases)

    def kinematic_derivatives(self, u: np.ndarray, rate) -> list[np.ndarray]:
        """dR_u/dc for every variable at fixed u (zero on the prescribed dofs), at the current constants."""
        op = self.op
        values = self.expression.eval(op.cells)
        bases = self.local_bases(u, self.upwinded(self.T_C @ values[:, 2])[1:], rate)
        n = len(u)
        out = []
        for k in range(self.n_variables):
            local = self.local_derivative(values[:, 5 + 5 * k : 10 + 5 * k], bases)
            d = np.bincount(op.dofs.ravel(), weights=local.ravel(), minlength=n)
            d[self.is_bc] = 0.0
            out.append(d)
        return out


class ElasticJFOFilm(ElasticFilm):
    """The coupled JFO film and bushing (module docstring) on a FilmModel's operator.

    Args (besides ElasticFilm's):
        coefficients: UFL expressions (k_theta, k_z, flux, h_T, rate) of the JFO film (flux: the
            Couette flux per unit film fraction along the sliding direction; rate: phi_c dH/dT).
        W_variable: the ufl.variable of the deformation the coefficients are differentiated by.
        prescribed: name -> (dofs, value of u).
    """

    def __init__(
        self,
        operator,
        P,
        W,
        lower,
        derivatives,
        shapes,
        coefficients,
        W_variable,
        prescribed,
        options=None,
        pressure_map=None,
        q_limit=None,
    ):
        super().__init__(operator, P, W, lower, derivatives, shapes, options, pressure_map, q_limit)
        op, n = self.op, self.n
        self.prescribed = {
            name: (np.asarray(dofs, np.int32), float(value)) for name, (dofs, value) in prescribed.items()
        }
        self.u_bc = np.zeros(n)
        is_bc = np.zeros(n, dtype=bool)
        for dofs, value in self.prescribed.values():
            self.u_bc[dofs] = value
            is_bc[dofs] = True
        self.is_bc = is_bc
        self.mid = MidpointJFO(op, coefficients, [W_variable], is_bc)  # values, then d/dW at the midpoints
        self.u = np.ones(n)  # the full film: its first step is the Reynolds solution without cavitation
        self.u[is_bc] = self.u_bc[is_bc]
        self.rate: tuple[float, np.ndarray] | None = (
            None  # (dT, theta_ref) of the film fraction; None: quasi-static
        )
        self.jfo_snes = configured_snes(self.comm, "ehdjfo", {**OPTIONS, **(options or {})})
        self.jfo_snes.setFunction(self._residual, self.r)
        self.jfo_snes.setJacobian(self._jfo_jacobian, self.A)
        self.jfo_snes.setConvergenceTest(self._converged)
        self.jfo_lu = DampedLU(self.comm, self._limit)
        pc = self.jfo_snes.getKSP().getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        pc.setPythonContext(self.jfo_lu)
        self._partition: np.ndarray | None = None
        self._scale = 1.0

    @staticmethod
    def _midpoint_expressions(operator, derivatives) -> list:
        """The derivatives only: this film's coefficients are MidpointJFO's, not the operator's."""
        return list(derivatives)

    # -- residual --------------------------------------------------------------------------------
    def residual(self, x: np.ndarray) -> np.ndarray:
        """R(u, q) (module docstring); caches this state's matrices and coefficients."""
        n, op = self.n, self.op
        u, q = x[:n], x[n:]
        plus, theta = np.maximum(u, 0.0), 1.0 + np.minimum(u, 0.0)
        P = self.lower + plus
        self.P.x.array[:n] = P
        self.W.x.array[:] = self.deformation(q)
        self.k = self.expression.eval(op.cells)  # the asperity pressure and its slope (columns 4, 5)
        c = self.mid.expression.eval(op.cells)  # (cell, 10): values, then d/dW at the midpoints
        self.c = c
        K = scipy.sparse.csr_matrix(
            (op.T_theta @ c[:, 0] + op.T_z @ c[:, 1], op.indices, op.indptr), shape=(n, n)
        )
        upwinded, self._d, self._pick = self.mid.upwinded(self.mid.T_C @ c[:, 2])
        T = scipy.sparse.csr_matrix((upwinded, op.indices, op.indptr), shape=(n, n))
        m, mdot = op.T_f @ c[:, 3], op.T_f @ c[:, 4]
        storage_diagonal, history = mdot.copy(), np.zeros(n)
        if self.rate is not None:
            dT, theta_ref = self.rate
            storage_diagonal += m / dT
            history = -m * theta_ref / dT
        self._K, self._T, self._m, self._storage = K, T, m, storage_diagonal
        R_u = K @ plus + T @ theta + storage_diagonal * theta + history
        self._unconstrained = R_u.copy()
        R_u[self.is_bc] = u[self.is_bc] - self.u_bc[self.is_bc]
        p, self.slope = (P, None) if self.pressure_map is None else self.pressure_map(P)
        F = self.areas * p + self.to_nodes @ self.k[:, 4]
        R_q = q - self.gains * self.modal_forces(F)
        self._state = x.copy()
        self._r = np.concatenate([R_u, R_q])
        return self._r

    # -- Jacobian --------------------------------------------------------------------------------
    def _jfo_jacobian(self, snes, x, J, Pmat) -> None:
        xa = x.getArray(readonly=True)
        if self._state is None or not np.array_equal(xa, self._state):
            self.residual(xa)
        self._partition = xa[: self.n] > 0.0
        J.setValuesCSR(self.indptr, self.indices, self._scatter(self.jacobian_matrix("coo")))
        J.assemble()

    def jacobian_matrix(self, format: str = "csr") -> scipy.sparse.spmatrix:
        """The coupled Jacobian at the cached state (as ElasticFilm.jacobian_matrix)."""
        op, n, c = self.op, self.n, self.c
        u = self._state[:n]
        positive = u > 0.0
        Ts = self._T + scipy.sparse.diags(self._storage)
        J_uu = self._K @ scipy.sparse.diags(positive.astype(float)) + Ts @ scipy.sparse.diags(
            (~positive).astype(float)
        )
        keep = scipy.sparse.diags((~self.is_bc).astype(float))
        J_uu = (keep @ J_uu + scipy.sparse.diags(self.is_bc.astype(float))).tocsr()
        # d R_u / d H_K at the vertices of each cell
        local = self.mid.local_derivative(
            c[:, 5:10], self.mid.local_bases(u, (self._d, self._pick), self.rate)
        )
        rows, cols = op.dofs.ravel(), np.repeat(op.cells, 3)
        dH = scipy.sparse.csr_matrix((local.ravel(), (rows, cols)), shape=(n, len(op.cells)))
        J_uq = keep @ (dH @ self.average_Phi)
        slope = positive.astype(float) if self.slope is None else positive * self.slope
        J_qu = self.J_qP @ scipy.sparse.diags(slope)
        contact = self.to_nodes @ scipy.sparse.diags(self.k[:, 5]) @ self.average_Phi
        J_qq = scipy.sparse.identity(self.m) - self.gPhiT @ contact
        return scipy.sparse.bmat([[J_uu, J_uq], [J_qu, J_qq]], format=format)

    # -- solve -------------------------------------------------------------------------------------
    def _converged(self, snes, iteration: int, norms) -> int:
        """As solver.film.jfo.JFOSolver: a step that kept the partition with the residual at round-off
        (the coupled residual is not piecewise linear in q, so its size is checked too)."""

        def kept() -> bool:
            x = snes.getSolution().getArray(readonly=True)
            return np.array_equal(x[: self.n] > 0.0, self._partition) and norms[2] <= 1e-10 * self._scale

        return semismooth_reason(snes, iteration, norms[2], 1e-11 * self._scale, self._partition, kept)

    def _limit(self, step: np.ndarray) -> float:
        """ElasticFilm._limit with the pressure's step from u's (P = P_cav + max(u, 0))."""
        n = self.n
        u = self._state[:n]
        pressure_step = np.maximum(u, 0.0) - np.maximum(u - step[:n], 0.0)  # P_old - P_new
        state, self._state = self._state, np.concatenate([self.lower + np.maximum(u, 0.0), self._state[n:]])
        try:
            return super()._limit(np.concatenate([pressure_step, step[n:]]))
        finally:
            self._state = state

    def solve(self) -> int:
        """Solve from the last (u, q); returns the Newton iterations."""
        n = self.n
        x0 = np.concatenate([np.where(self.is_bc, self.u_bc, self.u), self.q])
        r0 = self.residual(x0)
        # the flux scale: the film's residual at the full film with zero gauge pressure inside
        reference = np.concatenate([np.where(self.is_bc, self.u_bc, 0.0), self.q])
        self._scale = max(
            float(np.linalg.norm(self.residual(reference)[:n])), float(np.linalg.norm(r0[n:])), 1e-12
        )
        self._partition = None
        self.x.setArray(x0)
        self.jfo_snes.solve(None, self.x)
        self.iterations = self.jfo_snes.getIterationNumber()
        reason = self.jfo_snes.getConvergedReason()
        x = self.x.getArray(readonly=True).copy()
        if reason <= 0 or not np.all(np.isfinite(x)):
            self.residual(x0)
            raise FilmNotConverged("elastic mass-conserving film did not converge", reason, self.iterations)
        if not np.array_equal(x, self._state):
            self.residual(x)
        self.u, self.q = x[:n].copy(), x[n:].copy()
        return self.iterations

    def state(self) -> np.ndarray:
        """The unknowns of the last solve, a copy: the film's (u), then the deformation's."""
        return np.concatenate([self.u, self.q])

    def start_from(self, state: np.ndarray) -> None:
        """Make ``state`` (from ``state``) the next solve's start."""
        self.u = state[: self.n].copy()
        self.q = state[self.n :].copy()

    def solution(self) -> JFOSolution:
        """The film of the last solve as solver.film.jfo reports it (dimensionless, every dof)."""
        u = self.u
        theta = 1.0 + np.minimum(u, 0.0)
        outflow = {
            name: -float(np.sum(self._unconstrained[dofs])) for name, (dofs, _) in self.prescribed.items()
        }
        return JFOSolution(
            pressure=np.maximum(u, 0.0),
            theta=theta,
            content=self._m * theta,
            load=float(self.areas @ np.maximum(u, 0.0)),
            outflow=outflow,
            iterations=self.iterations,
        )

    # -- sensitivities ---------------------------------------------------------------------------
    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(u, q)/dc = -J^-1 dR/dc at the last solution (J at its partition); the u part is returned
        as d(P - P_cav) = diag(u > 0) du."""
        x = PETSc.Vec().createWithArray(self._state.copy(), comm=self.comm)
        self._jfo_jacobian(None, x, self.A, self.A)
        x.destroy()
        self.jfo_lu.setUp(_Operators(self.A))
        b, y = self.A.createVecs()
        out = []
        positive = self._state[: self.n] > 0.0
        for d in dr:
            b.setArray(-np.asarray(d))
            self.jfo_lu.ksp.solve(b, y)
            if self.jfo_lu.ksp.getConvergedReason() < 0:
                self.jfo_lu.failed = True
                raise FilmNotConverged("elastic mass-conserving film: the sensitivities' LU failed", -1, 0)
            values = y.getArray(readonly=True).copy()
            values[: self.n] *= positive
            out.append(values)
        b.destroy()
        y.destroy()
        return out

    def close(self) -> None:
        self.jfo_lu.destroy()
        self.jfo_snes.destroy()
        super().close()


class _Operators:
    """What DampedLU.setUp asks of a PC: its operators."""

    def __init__(self, A: PETSc.Mat):
        self.A = A

    def getOperators(self):  # noqa: N802 - PETSc's name
        return self.A, self.A
