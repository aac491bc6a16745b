"""The interfaces of a film's parts (typing.Protocol, as solver.film.reynolds.Roughness).

- ``FilmSolver``: what a Film (solver.film.model) asks of the solver the factory picked: solve at the
  space's constants, the sensitivities, the history state, the outputs only it knows. Implementations:
  solver.film.solvers.ReynoldsVI, RigidJFO, CoupledFilm.
- ``CavitationBlock``: the film's rows of the coupled elastic Newton (solver.film.ehd.CoupledNewton), one
  per cavitation law: solver.film.coupled_reynolds.ReynoldsRows (the VI), solver.film.cavitation_jfo.JFORows.
- ``Bushing``: solver.film.bushings.Bushing (shapes and gains of the deformation).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from solver.film.bushings import Bushing
from solver.film.history import FilmHistory

__all__ = ["Bushing", "CavitationBlock", "FilmSolver"]


class FilmSolver(Protocol):
    """One film kind's solver on a FilmSpace (the factory builds it; the Film calls it)."""

    has_history: bool  # its solves depend on committed states (solver.film.history)
    max_eccentricity_ratio: float  # |e| / c below which it is defined

    def reach(self, load: np.ndarray) -> float: ...  # max_eccentricity_ratio for a static load [N], raised
    def start_near(self, eps: np.ndarray) -> None: ...  # warm start moved along the last sensitivities

    def prepare(self, time_s: float | None, history: FilmHistory) -> None: ...  # rates from the history
    def solve(self) -> int: ...  # at the space's constants; the pressure in space.P; iterations
    def fall_back(self) -> bool: ...  # after a failed solve: True if a retry may succeed
    def turn(self, turn: Any, delta: float) -> None: ...  # its own state in a turned frame (P aside)
    def set_bushing_angle(self, angle: Any) -> None: ...  # the bushing's turn against the film, phi(t)
    def sensitivities(self, dr: list) -> tuple[list, list | None, list | None]: ...  # (dP, dW, dtheta)
    def film_fraction(self) -> np.ndarray | None: ...  # theta of the last solve (owned dofs); None: none
    def state(self) -> np.ndarray | None: ...  # the history state of the last solve, a copy
    def start_from(self, state: np.ndarray) -> None: ...  # the next solve's warm start
    def h_min(self, kin_ecc: np.ndarray) -> float: ...  # m, of the last solve
    def deformation_peak(self) -> tuple[float, float] | None: ...  # (m, rad, solution frame); rigid: None
    def flows(self) -> tuple[float, float]: ...  # (side, supply) m^3/s
    def ruptured(self) -> np.ndarray: ...  # owned dofs where the film is ruptured
    def oil_volume(self) -> float: ...  # m^3 (NaN: not mass-conserving)
    def nodal_fields(self) -> dict[str, tuple[str, np.ndarray]]: ...  # extra output fields (SI)
    def set_scales(self) -> None: ...  # after the space's scales changed (a new viscosity)
    def close(self) -> None: ...


class CavitationBlock(Protocol):
    """A cavitation law's rows in the coupled elastic Newton (solver.film.ehd.CoupledNewton), on the
    film's nodal unknown u (Reynolds: u = P; JFO: P = P_cav + max(u, 0)). The Newton owns the state x =
    (u, q), the bushing's rows, the fixed pattern and the step limit; the block its rows and its solve."""

    coefficients: list  # UFL evaluated at the midpoints in the Newton's kernel (before the derivatives)

    def attach(self, newton: Any) -> None: ...  # its SNES and LU on the Newton's pattern and vectors
    def pressure(self, u: np.ndarray) -> np.ndarray: ...  # P (/ p_ref) from u
    def pressure_step(self, u: np.ndarray, step: np.ndarray) -> tuple: ...  # (P, dP) of the step u - step
    def rows(self, u: np.ndarray, values: np.ndarray) -> np.ndarray: ...  # R_u at the Newton's state
    def jacobian_matrix(self, format: str = "csr") -> Any: ...  # the coupled Jacobian at the state
    def solve(self) -> int: ...  # Newton from the last (u, q); iterations
    def film_state(self) -> np.ndarray: ...  # u of the last solve
    def start_from(self, u: np.ndarray) -> None: ...
    def prepare(self, time_s: float | None, history: FilmHistory) -> None: ...  # its own rates
    def fall_back(self) -> bool: ...
    def film_derivatives(self, dr: list) -> list: ...  # dR_u/dtheta at fixed (u, q)
    def sensitivities(self, dr: list) -> list: ...  # d(P - P_cav, q)/dtheta, its set frozen
    def after_solve(self, forms: Any) -> None: ...
    def flows(self, forms: Any) -> tuple[float, float]: ...  # (side, supply) m^3/s
    def ruptured(self) -> np.ndarray: ...
    def oil_volume(self) -> float: ...
    def nodal_fields(self) -> dict: ...
    def set_scales(self) -> None: ...  # after a new p_ref
    def close(self) -> None: ...
