"""The film's history: the film state carried from one accepted integrator step to the next.

A film with history (an elastic bushing: its deformation; the mass-conserving film: its film fraction)
depends on time through the rate of that state. After every accepted step the integrator commits the
state of the step's last solve (``commit``); a solve at time t takes the rate from the committed states
strictly before t by variable-step BDF2 (``rate``), and a solve that fails may start again from the
last committed state (``start``). A rigid Reynolds film has no history: nothing is ever committed.

Numpy only. The states are the film solver's unknowns (solver.film.interfaces.FilmSolver.state),
dimensionless, copied in and out.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


class FilmHistory:
    """The committed film states of one film, oldest first: (t_n [s], state x_n)."""

    #: committed states kept: a solve at the time of the last commit takes its rate from the two before
    SIZE = 3
    #: the largest step ratio h / h_previous with which the rate is second order (variable-step BDF2 is
    #: zero-stable below 1 + sqrt(2)); above it (a step grown fast) the rate is implicit Euler
    BDF2_MAX_RATIO = 2.4

    def __init__(self) -> None:
        self._entries: list[tuple[float, np.ndarray]] = []
        #: the last committed state before the current solve's time (its fall-back start), set by ``rate``
        self.start: tuple[float, np.ndarray] | None = None

    def commit(self, state: np.ndarray, time_s: float) -> bool:
        """Make ``state`` at ``time_s`` the start of the rate for solves after ``time_s``. Committed
        states at or after ``time_s`` are dropped (a history replayed from an earlier time). Returns
        True when the step that ends here (a new time after two committed states) was more than
        BDF2_MAX_RATIO times the one before: the rate over it was implicit Euler, not BDF2."""
        earlier = [entry for entry in self._entries if entry[0] < time_s]
        new = len(earlier) == len(self._entries)
        self._entries = [*earlier[len(earlier) - (self.SIZE - 1) :], (time_s, state.copy())]
        if not new or len(earlier) < 2:
            return False
        (t_m, _), (t_n, _) = earlier[-2:]
        return not self._second_order((time_s - t_n) / (t_n - t_m))

    def _second_order(self, ratio: float) -> bool:
        """A step ``ratio`` times the one before takes the BDF2 rate (else implicit Euler)."""
        return ratio <= self.BDF2_MAX_RATIO

    def committed(self) -> list[tuple[float, np.ndarray]]:
        """The committed states kept, oldest first, copies (for a checkpoint: committed again in that
        order, they restore the history)."""
        return [(time_s, state.copy()) for time_s, state in self._entries]

    def before(self, time_s: float | None) -> list[tuple[float, np.ndarray]]:
        """The committed states a solve at ``time_s`` takes its rate from: the two latest strictly before
        ``time_s``, oldest first ([]: quasi-static)."""
        if time_s is None:
            return []
        return [entry for entry in self._entries if entry[0] < time_s][-2:]

    def rate(
        self, time_s: float | None, field: Callable[[float, np.ndarray], np.ndarray]
    ) -> tuple[float, np.ndarray] | None:
        """A field's rate at ``time_s`` as ``inverse_step (f - reference)``, f its unknown value there:
        the variable-step BDF2 derivative through the two committed states before ``time_s`` (second
        order in the step), ``df/dt = [(1 + 2w)/(1 + w) f - (1 + w) f_n + w^2/(1 + w) f_n-1] / h`` with
        ``h = t - t_n``, ``w = h / (t_n - t_n-1)``; implicit Euler from the last one when there is only
        one (or w is above BDF2_MAX_RATIO). Returns (inverse_step [1/s], reference), None without a
        committed state (quasi-static); ``field(t_k, state)`` is the field in the state committed at
        t_k (at the point where the rate is taken: a film whose shapes turn with time evaluates each
        committed state with its own time's shapes). Sets ``start``, the solve's fall-back start (the
        last committed state)."""
        history = self.before(time_s)
        self.start = history[-1] if history else None
        if not history:
            return None
        t_n, x_n = history[-1]
        h = time_s - t_n
        inverse_step, reference = 1.0 / h, field(t_n, x_n)
        if len(history) == 2:
            t_m, x_m = history[0]
            w = h / (t_n - t_m)
            if self._second_order(w):
                inverse_step = (1 + 2 * w) / ((1 + w) * h)
                reference = ((1 + w) * reference - w**2 / (1 + w) * field(t_m, x_m)) / (inverse_step * h)
        return inverse_step, reference
