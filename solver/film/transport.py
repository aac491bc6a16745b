"""The mass-conserving (JFO) film's pieces shared by the rigid and the elastic JFO films: its
coefficients, its rigid solver, and the film fraction's transport in time.

``FilmFractionTransport`` gives a solve its film-fraction rate from the film's history (BDF2,
solver.film.history) and the limited transport's factors (solver.film.jfo.TransportLimiter) from the
last committed film fraction, once per committed state; none (upwind) for a quasi-static solve, with
transport 'upwind', and for the committed state whose limited solve did not converge (``fall_back``:
the limited transport's matrix is no M-matrix, each edge's downwind entry is +alpha d, so where the
storage does not dominate semismooth Newton can cycle; that committed state's step then falls back
to upwinding, every solve until the next commit, so the integrator sees one residual per step).
"""

from __future__ import annotations

import logging

import numpy as np
import ufl

from solver.film import reynolds
from solver.film.history import FilmHistory
from solver.film.jfo import JFOSolver
from solver.film.jfo_limiter import TransportLimiter
from solver.film.jfo_midpoint import MidpointJFO
from solver.film.space import FilmSpace

log = logging.getLogger(__name__)


def jfo_coefficients(space: FilmSpace):
    """(k_theta, k_z, flux, h_T, rate) of the mass-conserving film (UFL): the Reynolds forms'
    H^3 phi_x and H^3 phi_y, the Couette flux per unit film fraction along the sliding direction,
    the mean gap and its rate phi_c dH/dT."""
    g, prm, roughness = space.geometry, space.params, space.roughness
    k_theta, k_z, _ = reynolds.reynolds_coefficients(g, roughness)
    if roughness is None:
        h_T, phi_c, shear = g.H, 1.0, 0.0
    else:
        Hs = g.H / prm.S
        h_T = prm.S * roughness.mean_gap(Hs, mod=ufl)
        phi_c = roughness.contact_factor(Hs, mod=ufl)
        shear = g.U_half_diff * prm.S * roughness.shear_flow(Hs, mod=ufl)
    return k_theta, k_z, g.U_mean * h_T + shear, h_T, phi_c * g.dH_dT


def jfo_prescribed(space: FilmSpace) -> dict:
    """The JFO film's prescribed dofs and their u = P - P_cav: with ambient at the cavitation pressure
    the edges are a flooded boundary at P_cav (u = 0: theta = 1)."""
    lower = space.cavitation_bound
    return {name: (dofs, value - lower) for name, (dofs, value) in space.prescribed().items()}


def jfo_solver(space: FilmSpace) -> JFOSolver:
    """The rigid mass-conserving film on the space (solver.film.jfo).

    The same flow factors as the Reynolds forms: D = H^3 phi_x t t + H^3 phi_y e_z e_z; the Couette
    flux per unit film fraction (U_mean h_T + U_d sigma phi_s) t, with h_T the mean gap
    (d h_T/dH = phi_c, solver.film.flow_factors.mean_gap); storage h_T and its rate phi_c dH/dT
    (rate form). Midpoint quadrature, as the Reynolds operator."""
    g = space.geometry
    k_theta, k_z, flux, h_T, rate = jfo_coefficients(space)
    D = k_theta * ufl.outer(g.tangent, g.tangent) + k_z * ufl.outer(g.axial, g.axial)
    return JFOSolver(
        space.V,
        h_T,
        None,
        jfo_prescribed(space),
        D=D,
        flux=flux * g.tangent,
        rate=rate,
        quadrature_degree=1,
        options={"snes_max_it": 40},
    )  # (engine: 1.2 iterations a solve; a cycling start is retried)


def jfo_flows(space: FilmSpace, solution) -> tuple[float, float]:
    """(side flow, supply flow) [m^3/s] of a JFO solution: the prescribed dofs' outflows."""
    s, whole = space.scales, float(space.mesh_spec.multiplicity)
    outflow = solution.outflow
    return outflow["edges"] * whole * s.flow, -outflow.get("supply", 0.0) * whole * s.flow


def jfo_oil_volume(space: FilmSpace, solution) -> float:
    """Oil in the film [m^3]: the sum of the nodes' contents m theta."""
    R, c = space.bearing.radius, space.bearing.clearance
    return float(np.sum(solution.content)) * float(space.mesh_spec.multiplicity) * R**2 * c


class FilmFractionTransport:
    """The film fraction's rate and limited transport of one JFO film (module docstring).

    Args:
        space: the film's space.
        operator: its MidpointOperator.
        prescribed: the JFO film's prescribed dofs (name -> (dofs, u)).
        layout: the CSR layout (indptr, indices) of the JFO film's matrices.
        also: another MidpointJFO that takes the same factors (the JFO rows of the coupled elastic
            Newton, solver.film.cavitation_jfo); None: rigid.
    """

    def __init__(self, space: FilmSpace, operator, prescribed: dict, layout, also=None):
        self.space, self.also = space, also
        is_bc = np.zeros(space.n, dtype=bool)
        for dofs, _ in prescribed.values():
            is_bc[dofs] = True
        #: the JFO residual's kinematic derivatives at the cell midpoints
        self.derivatives = MidpointJFO(
            operator, jfo_coefficients(space), list(space.geometry.variables().values()), is_bc
        )
        if not (np.array_equal(layout[0], operator.indptr) and np.array_equal(layout[1], operator.indices)):
            raise RuntimeError("the JFO film's matrices and the operator's have different CSR layouts")
        self.limiter: TransportLimiter | None = None
        if space.spec.transport == "limited":
            self.limiter = TransportLimiter(*layout)
            # the flow's orientation and couplings for the limiter: the Couette matrix of a unit flux
            # along +theta (the film's own flux reverses with the sliding; LimitedTransport picks the
            # orientation edge by edge), so the factors do not depend on the state being solved
            self.unit_couette = self.derivatives.T_C @ np.ones(len(operator.cells))
        self.limited = None  # the factors for the current committed film fraction (LimitedTransport)
        self.limited_key: tuple | None = None  # (time, film fraction) they were computed from
        self.upwind_key: tuple | None = None  # the committed state whose solves fell back to upwinding
        #: the solve's film-fraction rate: (dT, theta_reference), dtheta/dT = (theta - theta_ref) / dT
        self.rate: tuple[float, np.ndarray] | None = None
        self.history: FilmHistory | None = None

    def prepare(self, time_s: float | None, history: FilmHistory) -> None:
        """The film fraction's rate for a solve at ``time_s`` (None: quasi-static without a committed
        state), and the transport's factors."""
        self.history = history
        n = self.space.n  # (a state is u, or (u, q) with an elastic bushing)
        rate = history.rate(time_s, lambda _, x: 1.0 + np.minimum(x[:n], 0.0))
        self.rate = None if rate is None else (self.space.scales.omega_ref / rate[0], rate[1])
        self._limit()

    def _limit(self) -> None:
        limited = None
        start = self.history.start if self.history is not None else None
        if self.limiter is not None and self.rate is not None and start is not None:
            n = self.space.n
            t_n, x_n = start
            key = (t_n, x_n[:n].tobytes())
            if key != self.limited_key:
                self.limited = self.limiter.limit(self.unit_couette, 1.0 + np.minimum(x_n[:n], 0.0))
                self.limited_key = key
            limited = None if key == self.upwind_key else self.limited
        self.derivatives.limited = limited
        if self.also is not None:
            self.also.limited = limited

    def fall_back(self) -> bool:
        """After a failed solve: upwind until the next commit if the solve was limited (True: retry)."""
        if self.derivatives.limited is None:
            return False
        self.upwind_key = self.limited_key
        log.debug("JFO film: limited transport did not converge; upwind until the next commit")
        self._limit()
        return True
