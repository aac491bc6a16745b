"""The interfaces of a film's parts (typing.Protocol, as solver.film.reynolds.Roughness).

- ``FilmSolver``: what a Film (solver.film.model) asks of the solver the factory picked: solve at the
  space's constants, the sensitivities, the history state, the outputs only it knows. Implementations:
  solver.film.solvers.ReynoldsVI, RigidJFO, CoupledFilm.
- ``Bushing``: solver.film.bushings.Bushing (shapes and gains of the deformation).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from solver.film.bushings import Bushing
from solver.film.history import FilmHistory

__all__ = ["Bushing", "FilmSolver"]


class FilmSolver(Protocol):
    """One film kind's solver on a FilmSpace (the factory builds it; the Film calls it)."""

    has_history: bool  # its solves depend on committed states (solver.film.history)
    max_eccentricity_ratio: float  # |e| / c below which it is defined
    follows_viscosity: bool  # set_scales can take a new viscosity in place

    def prepare(self, time_s: float | None, history: FilmHistory) -> None: ...  # rates from the history
    def solve(self) -> int: ...  # at the space's constants; the pressure in space.P; iterations
    def fall_back(self) -> bool: ...  # after a failed solve: True if a retry may succeed
    def turn(self, turn: Any, delta: float) -> None: ...  # its own state in a turned frame (P aside)
    def sensitivities(self, dr: list) -> tuple[list, list | None]: ...  # (dP vectors, dW arrays)
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
