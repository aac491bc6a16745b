"""The Reynolds rows of the coupled elastic Newton (solver.film.ehd.CoupledNewton): the cavitation block
``ReynoldsRows``, one SNES VI on (P, q) with P >= P_cav and q free.

Its rows are the rigid film's Reynolds residual on the deformed gap, ``R_P = A(H) P + l(H)``, with the
exact derivatives of solver.film.ehd's docstring. The VI is PETSc's reduced-space method (``vinewtonrsls``)
from a start near the solution; from far (a cold start, or a warm one it cannot finish) it can cycle: it
projects the pressure onto its bound after each step, which leaves the deformation's step computed for
the unprojected pressure (a mixed state at h_min = 0.5 um from a cold start: no convergence in 200
iterations). The semismooth (Fischer-Burmeister) method converges from there (35 iterations) but only
linearly where the complementarity is degenerate (pressure and residual both ~0), so it brings the
iterate near the solution (FAR_TOLERANCE of the start's residual) and the reduced-space method finishes.
The reduced systems are solved by the Schur complement of the film block (SchurLU; node by node, the
layer basis and Winkler, with the local deformation eliminated first: solver.film.ehd.LayeredBlocks).
"""

from __future__ import annotations

import math
import weakref

from petsc4py import PETSc

import numpy as np
import scipy.sparse

from solver.errors import FilmNotConverged
from solver.film.cavitation import DEFAULT_OPTIONS, FixedPatternLU, ReducedShell, configured_snes
from solver.film.coupled_lu import DampedLU, SchurLU
from solver.film.ehd import ModalBorder, as_array

#: PETSc options of the coupled VI over the rigid film's (solver.film.cavitation.DEFAULT_OPTIONS):
#: the reduced-space method, as the rigid film, from a start near the solution (a warm start: 3
#: iterations along a load path).
ELASTIC_OPTIONS: dict[str, str | float | int] = {"snes_max_it": 30}
#: From far: the semismooth method (module docstring), to FAR_TOLERANCE of the start's residual
FAR_OPTIONS: dict[str, str | float | int] = {"snes_type": "vinewtonssls", "snes_max_it": 200}
FAR_TOLERANCE = 1e-6


class ReynoldsRows:
    """The Reynolds VI's rows and nonlinear solve in the coupled Newton (module docstring); the film's
    unknown u is the pressure P itself.

    Args:
        space: the film's FilmSpace (the pressure's lower bounds: P_cav, or the Dirichlet value where
            lower).
        operator: the film's MidpointOperator (fills A(H) and l(H) for the current W).
        options: PETSc options over solver.film.cavitation.DEFAULT_OPTIONS.
    """

    #: the coupled residual at which a solve has converged, relative to the film's source (or the
    #: deformation's residual at the start, if larger). In the elastic engine cycle 1e-8 moves min
    #: h_min, max p_max and the mean friction power by < 1e-8 of themselves against 1e-11 (100 x below
    #: the integrator's rtol) and takes 23 % fewer Newton iterations (13414 against 17446 per cycle):
    #: from a warm start the first iteration leaves ~1e-6 of the source (median), the second below 1e-11
    TOLERANCE = 1e-8

    def __init__(self, space, operator, options: dict | None = None):
        self.space, self.op, self.options = space, operator, options
        self.lower = space.lower_bounds()[: space.n].copy()
        #: evaluated with the coupled Newton's derivatives: the operator's coefficients
        self.coefficients = list(operator.coefficients)
        self.blocks = None  # the Jacobian's blocks at the cached state (SchurLU reads them)

    def attach(self, newton) -> None:
        """Build the VI on the coupled Newton's pattern (called by solver.film.ehd.CoupledNewton)."""
        self.newton = weakref.proxy(newton)
        self.n, self.N, self.m, self.comm = newton.n, newton.N, newton.m, newton.comm
        self.A = newton.A
        self.lower_vec, self.upper_vec = newton.A.createVecs()
        self.set_lower(self.lower)
        self.upper_vec.set(PETSc.INFINITY)
        merged = {**DEFAULT_OPTIONS, **ELASTIC_OPTIONS, **(self.options or {})}
        self._rtol = float(merged["snes_rtol"])
        self.snes = self._snes(merged)
        self.far = self._snes({**DEFAULT_OPTIONS, **FAR_OPTIONS})
        # the reduced-space method's and the sensitivities' factorisation: with a few modes by the Schur
        # complement of the film block (SchurLU), node by node deformation (Winkler) by an LU of the whole
        # fixed pattern
        self.lu = SchurLU(self) if newton.dense or newton.layered else self._whole_lu()
        self.lu.limit = newton.limit
        self._shell = None
        if isinstance(self.lu, SchurLU):  # the reduced-space SNES then needs the blocks only
            self._shell = PETSc.Mat().createPython(
                ((self.N, self.N), (self.N, self.N)), ReducedShell(), comm=self.comm
            )
            self._shell.setUp()
            self.snes.setJacobian(self._blocks_only, self._shell)
        self.damped_lu = DampedLU(self.comm, newton.limit)  # the semismooth method's: LU, limited step
        for snes, context in ((self.snes, self.lu), (self.far, self.damped_lu)):
            pc = snes.getKSP().getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(context)
        self._factored_state: np.ndarray | None = None  # the solution the sensitivities' LU is at

    def set_lower(self, lower: np.ndarray) -> None:
        """The pressure's lower bounds (a new p_ref)."""
        self.lower = lower
        self.lower_vec.setArray(np.concatenate([lower, np.full(self.m, PETSc.NINFINITY)]))

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
        self.lu.limit = self.newton.limit
        self.snes.getKSP().getPC().setPythonContext(self.lu)
        self.snes.setJacobian(self.newton.snes_jacobian, self.A)

    def _snes(self, options: dict) -> PETSc.SNES:
        snes = configured_snes(self.comm, "ehd", options)
        snes.setFunction(self.newton.snes_residual, self.newton.r)
        snes.setJacobian(self.newton.snes_jacobian, self.A)
        snes.setVariableBounds(self.lower_vec, self.upper_vec)
        snes.setForceIteration(True)
        return snes

    # -- the rows ------------------------------------------------------------------------------------
    def pressure(self, u: np.ndarray) -> np.ndarray:
        """P from the film's unknown: P itself."""
        return u

    def pressure_step(self, u: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P, its change) for the Newton step u - step."""
        return u, -step

    def rows(self, u: np.ndarray, values: np.ndarray) -> np.ndarray:
        """R_P = A(H) P + l(H), the operator filled from its coefficients at the midpoints (``values``)."""
        op, n = self.op, self.n
        op.evaluate(values)
        self._A = scipy.sparse.csr_matrix((op.values, op.indices, op.indptr), shape=(n, n))  # dR_P/dP
        return self._A @ u + op.source

    def jacobian_blocks(self, layered: bool = False):
        """(dR_P/dP, dR_P/dq, dR_q/dP, dR_q/dq) at the cached state: scipy matrices, and with a few modes
        the last three dense arrays; ``layered`` (the layer basis, for SchurLU): the blocks as
        solver.film.ehd.LayeredBlocks."""
        newton = self.newton
        op, k, n = self.op, newton.k, self.n
        P = newton.P.x.array[:n].copy()
        P[op.bc_dofs] = op.bc_values[op.bc_dofs]  # the residual's lifting uses the Dirichlet values
        P_cells = P[op.dofs]  # (cell, 3)
        local = (
            k[:, 0, None] * np.einsum("cij,cj->ci", op.local_theta, P_cells)
            + k[:, 1, None] * np.einsum("cij,cj->ci", op.local_z, P_cells)
            + (k[:, 2] * op.weight / 3.0)[:, None]
        )  # d(A_K P_K + l_K)/dH_K at each vertex
        n_cells = len(op.cells)
        slopes = np.repeat(k[:, 3] * op.weight / 3.0, 3)
        if newton.dense or layered:  # the same blocks as dense arrays (solver.film.ehd.border_map)
            mapping, indices, indptr = newton.border
            M = scipy.sparse.csr_matrix(
                (mapping @ np.concatenate([local.ravel(), slopes]), indices, indptr), shape=(n, n)
            )
            if layered:
                slope = np.ones(n) if newton.slope is None else newton.slope
                return newton.layered_blocks(self._A, M, newton.interior, slope)
            J_Pq = ModalBorder(newton.interior, M, newton.Phi)
        else:
            rows, cols = op.dofs.ravel(), np.repeat(op.cells, 3)
            dH = scipy.sparse.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n_cells))
            dslope = scipy.sparse.csr_matrix((slopes, (rows, cols)), shape=(n, n_cells))
            J_Pq = scipy.sparse.diags(newton.interior) @ (dH @ newton.average_Phi + dslope @ newton.slope_Phi)
        J_qP, J_qq = newton.bushing_blocks(newton.slope, newton.dense)
        return self._A, J_Pq, J_qP, J_qq

    def jacobian_matrix(self, format: str = "csr") -> scipy.sparse.spmatrix:
        """The coupled Jacobian at the cached state."""
        self.blocks = A, J_Pq, J_qP, J_qq = self.jacobian_blocks()
        if self.newton.dense:
            J_Pq, J_qP, J_qq = (scipy.sparse.csr_matrix(as_array(M)) for M in (J_Pq, J_qP, J_qq))
        return scipy.sparse.bmat([[A, J_Pq], [J_qP, J_qq]], format=format)

    def _blocks_only(self, snes, x, J, Pmat) -> None:
        """The reduced-space SNES's Jacobian callback with SchurLU: the blocks, no coupled matrix (SchurLU
        reads the blocks; ``preonly`` never applies the operator, a shell)."""
        self.newton.evaluate_at(x)
        self.blocks = self.jacobian_blocks(layered=self.newton.layered)

    # -- solve ------------------------------------------------------------------------------------------
    def solve(self) -> int:
        """Solve the coupled VI from the last (P, q); returns the Newton iterations."""
        newton, n, op = self.newton, self.n, self.op
        P0 = newton.P.x.array[:n].copy()
        for dof, value in zip(op.bc_dofs, op.bc_values[op.bc_dofs]):
            P0[dof] = value  # Dirichlet values exactly
        x0 = np.concatenate([P0, newton.q])
        r0 = newton.residual(x0)
        scale = max(np.linalg.norm(op.source), np.linalg.norm(r0[n:]), 1e-3)
        atol = max(self.TOLERANCE * scale, 1e-14)
        self.snes.setTolerances(atol=atol, rtol=self._rtol, stol=0.0)
        self.lu.inactive = None
        self.iterations = 0
        reason = self._run(self.snes, x0)
        if reason <= 0:  # from far: the semismooth method brings it near, the reduced-space one finishes
            self.far.setTolerances(atol=max(FAR_TOLERANCE * np.linalg.norm(r0), atol), rtol=0.0, stol=0.0)
            reason = self._run(self.far, x0)
            if reason > 0:
                reason = self._run(self.snes, newton.x.getArray(readonly=True).copy())
        x = newton.x.getArray(readonly=True).copy()
        if reason <= 0:
            newton.residual(x0)  # back to the last good state
            raise FilmNotConverged("elastic film solve did not converge", reason, self.iterations)
        if not np.array_equal(x, newton.state_x):
            newton.residual(x)
        newton.q = x[n:].copy()
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
        x = self.newton.x
        x.setArray(x0)
        snes.solve(None, x)
        self.iterations += snes.getIterationNumber()
        reason = snes.getConvergedReason()
        return reason if np.all(np.isfinite(x.getArray(readonly=True))) else -1

    def film_state(self) -> np.ndarray:
        """The film's unknown of the last solve: the pressure."""
        return self.newton.P.x.array[: self.n]

    def start_from(self, u: np.ndarray) -> None:
        self.newton.P.x.array[: self.n] = u

    # -- sensitivities ----------------------------------------------------------------------------------
    def film_derivatives(self, dr: list) -> list[np.ndarray]:
        """dR_P/dtheta at fixed (P, q): the rigid forms' (PETSc vectors) as arrays."""
        return [v.getArray().copy() for v in dr]

    def inactive_set(self) -> PETSc.IS:
        """The pressurised pressure dofs and every deformation unknown, at the last solution (the
        state of the last residual evaluation, which ``solve`` leaves at the solution)."""
        newton, n = self.newton, self.n
        x, r = newton.state_x, newton.residual_x
        scale = max(1.0, float(np.max(np.abs(r[:n]), initial=0.0)))
        active = (x[:n] <= self.lower + 1e-12 * max(1.0, float(np.max(np.abs(x[:n]))))) & (
            r[:n] > 1e-10 * scale
        )
        keep = np.concatenate([~active, np.ones(self.m, dtype=bool)])
        return PETSc.IS().createGeneral(np.flatnonzero(keep).astype(PETSc.IntType), comm=self.comm)

    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(P, q)/dtheta = -J_II^-1 dR/dtheta on the inactive set (active set frozen), 0 elsewhere.

        The Jacobian is evaluated and factorised at the solution (once per solution): the last Newton
        iteration's factorisation is at the iterate before it (from a warm start that converges in one
        iteration, the start), and the semismooth method leaves its own modified matrix in A."""
        newton = self.newton
        if self.lu.inactive is None or self._factored_state is not newton.state_x:
            self._factored_state = newton.state_x
            inactive = self.inactive_set()
            if isinstance(self.lu, SchurLU):
                self._blocks_only(None, newton.x, None, None)
            else:
                newton.snes_jacobian(None, newton.x, self.A, self.A)
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

    # -- history and outputs ---------------------------------------------------------------------------
    def prepare(self, time_s, history) -> None:
        pass

    def fall_back(self) -> bool:
        return False

    def flows(self, forms) -> tuple[float, float]:
        return reynolds_flows(self.space, forms)

    def ruptured(self) -> np.ndarray:
        return at_bound(self.space.P.x.array[: self.n], self.lower)

    def oil_volume(self) -> float:
        return math.nan

    def nodal_fields(self) -> dict:
        return {}

    def after_solve(self, forms) -> None:
        pass

    def set_scales(self) -> None:
        """After a new p_ref: the bounds."""
        self.set_lower(self.space.lower_bounds()[: self.n].copy())

    def close(self) -> None:
        self.lu.destroy()
        self.damped_lu.destroy()
        for obj in (self.snes, self.far, self.lower_vec, self.upper_vec, self._shell):
            if obj is not None:
                obj.destroy()


def reynolds_flows(space, forms) -> tuple[float, float]:
    """(side flow, supply flow) [m^3/s] of the last solve: the consistent fluxes (solver.film.forms)."""
    s = space.scales
    supply = forms.assemble(forms.supply_flow_form) * s.flow if forms.supply_flow_form is not None else 0.0
    return -forms.assemble(forms.side_flow_form) * s.flow, supply


def at_bound(P: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """The dofs where the pressure is at its lower bound (ruptured)."""
    return P - lower <= 1e-12 * max(1.0, float(np.max(np.abs(lower), initial=0.0)))
