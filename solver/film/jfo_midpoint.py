"""The JFO film's matrices at the cell midpoints, and their derivatives (``MidpointJFO``): shared by the
rigid JFO film's transport (solver.film.transport) and the JFO rows of the coupled elastic Newton
(solver.film.cavitation_jfo)."""

from __future__ import annotations

import numpy as np
import scipy.sparse
import ufl
from dolfinx import fem

from solver.film.jfo_limiter import upwind_pick
from solver.film.tensors import MIDPOINT


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
