"""The JFO rows of the coupled elastic Newton (solver.film.ehd.CoupledNewton): the cavitation block
``JFORows``, one semismooth Newton on (u, q) in PETSc SNES.

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
solver.film.ehd.step_factor) converges when a step keeps the partition (u > 0) and the residual is at
round-off. With a few modes (the FE eye) its systems are solved by the Schur complement of the film
block dR_u/du (solver.film.coupled_lu.SchurLU, as the Reynolds rows': PETSc's LU of the film block's
fixed pattern refactorised numerically, the m x m Schur system by GMRES preconditioned with the last
complement formed), and the SNES's Jacobian callback computes the blocks only (dR_u/dq = M Phi with M a
fixed linear map of the cells' d R_u/d H_K, solver.film.ehd.border_map). dR_u/du is the rigid JFO
film's generalised Jacobian, an M-matrix (solver.film.jfo), so the LU needs no pivoting (at a zero
pivot SchurLU takes MUMPS for that factorisation); the dense borders, which made the whole matrix need
MUMPS, only enter the complement. Node by node (the layer basis, Winkler) SchurLU eliminates the
local deformation first (solver.film.ehd.LayeredBlocks: the film block J_uu + L diag(d)). The forces'
sensitivities to the kinematics use the Jacobian at the solution, factorised there. The coefficients
and their d/dW are evaluated in the coupled Newton's one compiled kernel.
"""

from __future__ import annotations

import logging
import weakref

from petsc4py import PETSc

import numpy as np
import scipy.sparse
import ufl
from ufl.algorithms import expand_derivatives

from solver.errors import FilmNotConverged
from solver.film.cavitation import ReducedShell, configured_snes
from solver.film.coupled_lu import DampedLU, SchurLU
from solver.film.ehd import ModalBorder, as_array
from solver.film.jfo import JFOSolution, semismooth_reason
from solver.film.jfo_midpoint import MidpointJFO
from solver.film.transport import (
    FilmFractionTransport,
    jfo_coefficients,
    jfo_flows,
    jfo_oil_volume,
    jfo_prescribed,
)

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


class JFORows:
    """The JFO film's rows and semismooth Newton in the coupled Newton (module docstring), with the film
    fraction's transport in time (solver.film.transport.FilmFractionTransport).

    Args:
        space: the film's FilmSpace (its geometry's W the coefficients are differentiated by).
        operator: the film's MidpointOperator (serial P1).
        options: PETSc options over OPTIONS.
    """

    def __init__(self, space, operator, options: dict | None = None):
        self.space, self.op, self.options = space, operator, options
        n = space.n
        self.n = n
        self.lower = np.full(n, space.cavitation_bound)
        # the five coefficients, then their d/dW at the midpoints: evaluated in the coupled Newton's
        # kernel, before its derivatives (one compiled kernel: the gap and flow factors computed once)
        values = list(jfo_coefficients(space))
        W = space.geometry.W
        self.coefficients: list = values + [expand_derivatives(ufl.diff(e, W)) for e in values]
        self.set_prescribed(jfo_prescribed(space))
        is_bc = self.is_bc
        self.mid = MidpointJFO(operator, values, [W], is_bc)
        # K, T and dR_u/du of the cached state: their values set per evaluation in the operator's CSR layout
        layout = (operator.indices, operator.indptr)
        self._K, self._T, self._J_uu = (
            scipy.sparse.csr_matrix((np.zeros(len(operator.indices)), *layout), (n, n)) for _ in range(3)
        )
        self.transport = FilmFractionTransport(
            space, operator, self.prescribed, (operator.indptr, operator.indices), also=self.mid
        )
        self.u = np.ones(n)  # the full film: its first step is the Reynolds solution without cavitation
        self.u[is_bc] = self.u_bc[is_bc]
        self.rate: tuple[float, np.ndarray] | None = None  # (dT, theta_ref) of the film fraction
        self._partition: np.ndarray | None = None
        self._scale = 1.0
        self.solution: JFOSolution | None = None  # the last solve's

    def set_prescribed(self, prescribed: dict) -> None:
        """The prescribed dofs and their u (solver.film.transport.jfo_prescribed)."""
        self.prescribed = {
            name: (np.asarray(dofs, np.int32), float(value)) for name, (dofs, value) in prescribed.items()
        }
        self.u_bc = np.zeros(self.n)
        self.is_bc = np.zeros(self.n, dtype=bool)
        for dofs, value in self.prescribed.values():
            self.u_bc[dofs] = value
            self.is_bc[dofs] = True

    def attach(self, newton) -> None:
        """Build the semismooth Newton on the coupled Newton's pattern (solver.film.ehd.CoupledNewton):
        with a few modes its systems solved by the Schur complement of the film block (SchurLU, no
        bounds), node by node (Winkler) by an LU of the whole fixed pattern (DampedLU, MUMPS)."""
        self.newton = weakref.proxy(newton)
        self.comm, self.A = newton.comm, newton.A
        self.N, self.m = newton.N, newton.m
        self.snes = configured_snes(self.comm, "ehdjfo", {**OPTIONS, **(self.options or {})})
        self.snes.setFunction(newton.snes_residual, newton.r)
        self.snes.setConvergenceTest(self._converged)
        self.blocks = None  # the Jacobian's blocks at the cached state (SchurLU reads them)
        self.fraction_sensitivities: list[np.ndarray] = []  # the last sensitivities' film fraction part
        self._shell = None
        if newton.dense or newton.layered:
            # dR_u/dq = M Phi, M (n x n, the film's pattern) a fixed linear map of the cells' d R_u/d H_K
            # (solver.film.ehd.border_map: its gap part; the JFO coefficients have no slope)
            mapping, indices, indptr = newton.border
            self._border = mapping.tocsc()[:, : 3 * len(self.op.cells)].tocsr()
            self._M = scipy.sparse.csr_matrix((np.zeros(len(indices)), indices, indptr), (self.n, self.n))
            self.lu = SchurLU(self, bounded=False)
            self.lu.limit = newton.limit
            # ``preonly`` never applies the operator: a shell, its callback computes the blocks only
            self._shell = PETSc.Mat().createPython(
                ((self.N, self.N), (self.N, self.N)), ReducedShell(), comm=self.comm
            )
            self._shell.setUp()
            self.snes.setJacobian(self._blocks_only, self._shell)
        else:
            self.lu = DampedLU(self.comm, newton.limit)
            self.snes.setJacobian(self._jacobian, self.A)
        pc = self.snes.getKSP().getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        pc.setPythonContext(self.lu)

    def use_whole_lu(self) -> None:
        """An LU of the whole coupled matrix (MUMPS, DampedLU) instead of SchurLU (the reference for its
        tests)."""
        self.lu.destroy()
        self.lu = DampedLU(self.comm, self.newton.limit)
        self.snes.getKSP().getPC().setPythonContext(self.lu)
        self.snes.setJacobian(self._jacobian, self.A)

    # -- history ------------------------------------------------------------------------------------
    def prepare(self, time_s, history) -> None:
        """The film fraction's rate and transport for a solve at ``time_s``."""
        self.transport.prepare(time_s, history)
        self.rate = self.transport.rate

    def fall_back(self) -> bool:
        return self.transport.fall_back()

    # -- the rows -----------------------------------------------------------------------------------
    def pressure(self, u: np.ndarray) -> np.ndarray:
        """P = P_cav + max(u, 0)."""
        return self.lower + np.maximum(u, 0.0)

    def pressure_step(self, u: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P, its change) for the Newton step u - step."""
        plus = np.maximum(u, 0.0)
        return self.lower + plus, -(plus - np.maximum(u - step, 0.0))

    def rows(self, u: np.ndarray, values: np.ndarray) -> np.ndarray:
        """R_u (module docstring); caches this state's matrices and coefficients."""
        n, op = self.n, self.op
        c = values  # (cell, 10): the coefficients, then d/dW at the midpoints
        self.c = c
        # the matrices' values in the operator's CSR layout, in fixed CSR matrices (no new scipy matrix)
        self._K_values = self._K.data = op.T_theta @ c[:, 0] + op.T_z @ c[:, 1]
        self._T_values, self._d, self._pick = self.mid.upwinded(self.mid.T_C @ c[:, 2])
        self._T.data = self._T_values
        m, mdot = op.T_f @ c[:, 3], op.T_f @ c[:, 4]
        self._storage, self._history = mdot.copy(), np.zeros(n)
        if self.rate is not None:
            dT, theta_ref = self.rate
            self._storage += m / dT
            self._history = -m * theta_ref / dT
        self._m = m
        self._unconstrained = self._film_rows(u)
        R_u = self._unconstrained.copy()
        R_u[self.is_bc] = u[self.is_bc] - self.u_bc[self.is_bc]
        return R_u

    def _film_rows(self, u: np.ndarray) -> np.ndarray:
        """R_u without the prescribed rows, for u at the cached matrices (the cached q)."""
        plus, theta = np.maximum(u, 0.0), 1.0 + np.minimum(u, 0.0)
        return self._K @ plus + self._T @ theta + self._storage * theta + self._history

    def _jacobian(self, snes, x, J, Pmat) -> None:
        """The SNES's Jacobian callback with the whole-matrix LU: the coupled matrix in the fixed pattern."""
        self._partition = x.getArray(readonly=True)[: self.n] > 0.0
        self.newton.snes_jacobian(snes, x, J, Pmat)

    def _blocks_only(self, snes, x, J, Pmat) -> None:
        """The SNES's Jacobian callback with SchurLU: the blocks, no coupled matrix (SchurLU reads the
        blocks; ``preonly`` never applies the operator, a shell). The shell is assembled anew: its state
        changes, so the PC is set up (SchurLU factorises) at every Newton iteration (newtonls keeps the
        operator, and a PC whose operator's state has not changed keeps its factorisation)."""
        self._partition = x.getArray(readonly=True)[: self.n] > 0.0
        self.newton.evaluate_at(x)
        self.blocks = self.jacobian_blocks(layered=self.newton.layered)
        J.assemble()

    def jacobian_blocks(self, layered: bool = False):
        """(dR_u/du, dR_u/dq, dR_q/du, dR_q/dq) at the cached state (module docstring): dR_u/du a CSR
        matrix in the operator's layout (SchurLU refactorises its values numerically), the others dense
        arrays with a few modes, scipy matrices node by node (Winkler); ``layered`` (the layer basis, for
        SchurLU): the blocks as solver.film.ehd.LayeredBlocks."""
        newton, op, n, mid = self.newton, self.op, self.n, self.mid
        u = newton.state_x[:n]
        positive = u > 0.0
        # K diag(u > 0) + (T + diag(storage)) diag(u <= 0), the prescribed rows identity rows
        values = np.where(positive[op.indices], self._K_values, self._T_values)
        values[mid.diagonal] += np.where(positive, 0.0, self._storage)
        values[self.is_bc[mid.rows]] = 0.0
        values[mid.diagonal[self.is_bc]] = 1.0
        J_uu = self._J_uu
        J_uu.data = values
        # d R_u / d H_K at the vertices of each cell
        local = mid.local_derivative(self.c[:, 5:10], mid.local_bases(u, (self._d, self._pick), self.rate))
        slope = positive.astype(float) if newton.slope is None else positive * newton.slope
        if layered:
            M = self._M
            M.data = self._border @ local.ravel()
            return newton.layered_blocks(J_uu, M, (~self.is_bc).astype(float), slope)
        if newton.dense:
            pattern = self._M  # (a new matrix: SchurLU keeps the border of its factorisation)
            values = self._border @ local.ravel()
            M = scipy.sparse.csr_matrix((values, pattern.indices, pattern.indptr), pattern.shape)
            J_uq = ModalBorder((~self.is_bc).astype(float), M, newton.Phi)
        else:
            rows, cols = op.dofs.ravel(), np.repeat(op.cells, 3)
            dH = scipy.sparse.csr_matrix((local.ravel(), (rows, cols)), shape=(n, len(op.cells)))
            J_uq = scipy.sparse.diags((~self.is_bc).astype(float)) @ (dH @ newton.average_Phi)
        J_qu, J_qq = newton.bushing_blocks(slope, dense=newton.dense)
        return J_uu, J_uq, J_qu, J_qq

    def jacobian_matrix(self, format: str = "csr") -> scipy.sparse.spmatrix:
        """The coupled Jacobian at the cached state (module docstring)."""
        self.blocks = J_uu, J_uq, J_qu, J_qq = self.jacobian_blocks()
        if self.newton.dense:
            J_uq, J_qu, J_qq = (scipy.sparse.csr_matrix(as_array(M)) for M in (J_uq, J_qu, J_qq))
        return scipy.sparse.bmat([[J_uu, J_uq], [J_qu, J_qq]], format=format)

    # -- solve -------------------------------------------------------------------------------------
    def _converged(self, snes, iteration: int, norms) -> int:
        """As solver.film.jfo.JFOSolver: a step that kept the partition with the residual at round-off
        (the coupled residual is not piecewise linear in q, so its size is checked too)."""

        def kept() -> bool:
            x = snes.getSolution().getArray(readonly=True)
            return np.array_equal(x[: self.n] > 0.0, self._partition) and norms[2] <= 1e-10 * self._scale

        return semismooth_reason(snes, iteration, norms[2], 1e-11 * self._scale, self._partition, kept)

    def solve(self) -> int:
        """Solve from the last (u, q); returns the Newton iterations."""
        newton, n = self.newton, self.n
        x0 = np.concatenate([np.where(self.is_bc, self.u_bc, self.u), newton.q])
        r0 = newton.residual(x0)  # (cached: the SNES's first residual)
        # the flux scale: the film's residual at the full film with zero gauge pressure inside (the
        # prescribed rows zero), at the start's q: the matrices just evaluated
        reference = self._film_rows(np.where(self.is_bc, self.u_bc, 0.0))
        reference[self.is_bc] = 0.0
        self._scale = max(float(np.linalg.norm(reference)), float(np.linalg.norm(r0[n:])), 1e-12)
        self._partition = None
        newton.x.setArray(x0)
        self.snes.solve(None, newton.x)
        iterations = self.snes.getIterationNumber()
        reason = self.snes.getConvergedReason()
        x = newton.x.getArray(readonly=True).copy()
        if reason <= 0 or not np.all(np.isfinite(x)):
            newton.residual(x0)
            raise FilmNotConverged("elastic mass-conserving film did not converge", reason, iterations)
        if not np.array_equal(x, newton.state_x):
            newton.residual(x)
        self.u, newton.q = x[:n].copy(), x[n:].copy()
        self.solution = self._solution(iterations)
        return iterations

    #: the step's damping of the retry after a failed cold start (``damped``)
    COLD_START_DAMPING = 0.5

    def damped(self, solve):
        """``solve()`` with the Newton steps damped by COLD_START_DAMPING (the SNES's line search
        ``basic`` with that damping), then the undamped steps again. For a start with no accepted state
        to continue from, where the semismooth iteration can cycle between the full and a ruptured film:
        the elastic JFO film of cases/reference-2000rpm-ehd-jfo with Roelands oil at 0.067 R, the pin
        centred, cycles with period 3 for 60 iterations undamped and converges in 36 damped."""
        snes, options = self.snes, PETSc.Options()
        key = snes.getOptionsPrefix() + "snes_linesearch_damping"
        options[key] = self.COLD_START_DAMPING
        snes.setFromOptions()
        try:
            return solve()
        finally:
            options[key] = 1.0
            snes.setFromOptions()
            options.delValue(key)

    def _solution(self, iterations: int) -> JFOSolution:
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
            load=float(self.newton.areas @ np.maximum(u, 0.0)),
            outflow=outflow,
            iterations=iterations,
        )

    def film_state(self) -> np.ndarray:
        """The film's unknown of the last solve: u."""
        return self.u

    def start_from(self, u: np.ndarray) -> None:
        self.u = u.copy()

    # -- sensitivities -------------------------------------------------------------------------------
    def film_derivatives(self, dr: list) -> list[np.ndarray]:
        """dR_u/dtheta at fixed (u, q) (the rigid forms' dr are the Reynolds rows': not these)."""
        return self.transport.derivatives.kinematic_derivatives(self.u, self.rate)

    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(u, q)/dc = -J^-1 dR/dc at the last solution (J at its partition: the last Newton
        iteration's is at the iterate before, so it is evaluated and factorised here); the u part is
        returned as d(P - P_cav) = diag(u > 0) du; the film fraction's part, dtheta = diag(u <= 0) du (theta
        = 1 + u there), is kept in ``fraction_sensitivities`` (solver.film.solvers.CoupledFilm reads it)."""
        newton = self.newton
        positive = newton.state_x[: self.n] > 0.0
        if isinstance(self.lu, SchurLU):
            # (the cached state is the solution: ``solve``)
            self.blocks = self.jacobian_blocks(layered=newton.layered)
            self.lu.factor(self.lu.everything)
            b, y = self.lu.b, self.lu.x
            solve = self.lu.solve_full
        else:
            x = PETSc.Vec().createWithArray(newton.state_x.copy(), comm=self.comm)
            self._jacobian(None, x, self.A, self.A)
            x.destroy()
            self.lu.setUp(_Operators(self.A))
            b, y = self.A.createVecs()
            solve = self._whole_solve
        out, self.fraction_sensitivities = [], []
        for d in dr:
            b.setArray(-np.asarray(d))
            solve(b, y)
            values = y.getArray(readonly=True).copy()
            self.fraction_sensitivities.append(np.where(positive, 0.0, values[: self.n]))
            values[: self.n] *= positive
            out.append(values)
        if not isinstance(self.lu, SchurLU):
            b.destroy()
            y.destroy()
        return out

    def _whole_solve(self, b: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = J^-1 b by the whole-matrix LU (DampedLU's KSP, no step limit)."""
        self.lu.ksp.solve(b, y)
        if self.lu.ksp.getConvergedReason() < 0:
            self.lu.failed = True
            raise FilmNotConverged("elastic mass-conserving film: the sensitivities' LU failed", -1, 0)

    # -- outputs -----------------------------------------------------------------------------------
    def flows(self, forms) -> tuple[float, float]:
        """(side, supply) [m^3/s]: the prescribed dofs' outflows."""
        return jfo_flows(self.space, self.solution)

    def ruptured(self) -> np.ndarray:
        return self.solution.theta < 1.0

    def oil_volume(self) -> float:
        return jfo_oil_volume(self.space, self.solution)

    def nodal_fields(self) -> dict:
        return {"film_fraction": ("film_fraction", self.solution.theta)}

    def after_solve(self, forms) -> None:
        """The operator's integrals (the Couette torques) of the solution."""
        forms.operator.evaluate()

    def set_scales(self) -> None:
        """After a new p_ref: the bound and the prescribed values."""
        self.lower[:] = self.space.cavitation_bound
        self.set_prescribed(jfo_prescribed(self.space))

    def close(self) -> None:
        self.lu.destroy()
        self.snes.destroy()
        if self._shell is not None:
            self._shell.destroy()


class _Operators:
    """What DampedLU.setUp asks of a PC: its operators."""

    def __init__(self, A: PETSc.Mat):
        self.A = A

    def getOperators(self):  # noqa: N802 - PETSc's name
        return self.A, self.A
