"""The film's history: the film state carried from one accepted integrator step to the next.

A film with history (an elastic bushing: its deformation; the mass-conserving film: its film fraction)
depends on time through the rate of that state. After every accepted step the integrator commits the
state of the step's last solve (``commit``); a solve at time t takes the rate from the committed states
strictly before t by variable-step BDF2 (``rate``), and a solve that fails may start again from the
last committed state (``start``). After a short step (the integrator's last step before an output,
clipped to end there) the next step is many times longer; its BDF2 then goes through the short step's
end and the state committed before the short step began, instead of an implicit Euler rate (which cost
the film alone 0.45 % of its friction and 1.4 % of its min h_min over ten such steps a cycle:
docs/verification.md).
A rigid Reynolds film has no history: nothing is ever committed.

Numpy only. The states are the film solver's unknowns (solver.film.interfaces.FilmSolver.state),
dimensionless, copied in and out.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


class FilmHistory:
    """The committed film states of one film, oldest first: (t_n [s], state x_n)."""

    #: committed states kept before the newest: the last SIZE - 1, and also the two a solve at the newest
    #: one's time took its rate from (after a short step one of them is older), so that a solve again at
    #: that time (the output's state, solver.study.cycles) takes the same rate
    SIZE = 3
    #: the largest ratio h / (t_n - t_m) of the step to the interval between the two states the BDF2 rate
    #: goes through (variable-step BDF2 is zero-stable below 1 + sqrt(2)); the newest older state within
    #: it is taken, and without one (a step grown fast from a regular one) the rate is implicit Euler
    BDF2_MAX_RATIO = 2.4

    def __init__(self) -> None:
        self._entries: list[tuple[float, np.ndarray]] = []
        #: the last committed state before the current solve's time (its fall-back start), set by ``rate``
        self.start: tuple[float, np.ndarray] | None = None

    def commit(self, state: np.ndarray, time_s: float) -> None:
        """Make ``state`` at ``time_s`` the start of the rate for solves after ``time_s``. Committed
        states at or after ``time_s`` are dropped (a history replayed from an earlier time)."""
        earlier = [entry for entry in self._entries if entry[0] < time_s]
        kept = {t for t, _ in earlier[-(self.SIZE - 1) :]} | {t for t, _ in self.before(time_s)}
        self._entries = [*(entry for entry in earlier if entry[0] in kept), (time_s, state.copy())]

    def committed(self) -> list[tuple[float, np.ndarray]]:
        """The committed states kept, oldest first, copies (for a checkpoint: committed again in that
        order, they restore the history)."""
        return [(time_s, state.copy()) for time_s, state in self._entries]

    def before(self, time_s: float | None) -> list[tuple[float, np.ndarray]]:
        """The committed states a solve at ``time_s`` takes its rate from, oldest first: the latest
        strictly before ``time_s`` and the newest one before it within BDF2_MAX_RATIO (usually the
        latest but one; after a short step the one before that), or the latest alone (implicit Euler;
        []: quasi-static)."""
        if time_s is None:
            return []
        earlier = [entry for entry in self._entries if entry[0] < time_s]
        if len(earlier) < 2:
            return earlier
        t_n = earlier[-1][0]
        for entry in reversed(earlier[:-1]):
            if time_s - t_n <= self.BDF2_MAX_RATIO * (t_n - entry[0]):
                return [entry, earlier[-1]]
        return earlier[-1:]

    def rate(
        self, time_s: float | None, field: Callable[[float, np.ndarray], np.ndarray]
    ) -> tuple[float, np.ndarray] | None:
        """A field's rate at ``time_s`` as ``inverse_step (f - reference)``, f its unknown value there:
        the variable-step BDF2 derivative through the two committed states ``before`` gives (second
        order in the step), ``df/dt = [(1 + 2w)/(1 + w) f - (1 + w) f_n + w^2/(1 + w) f_m] / h`` with
        ``h = t - t_n``, ``w = h / (t_n - t_m)``; implicit Euler from the last one when it gives one.
        Returns (inverse_step [1/s], reference), None without a committed state (quasi-static);
        ``field(t_k, state)`` is the field in the state committed at t_k (at the point where the rate is
        taken: a film whose shapes turn with time evaluates each committed state with its own time's
        shapes). Sets ``start``, the solve's fall-back start (the
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
            inverse_step = (1 + 2 * w) / ((1 + w) * h)
            reference = ((1 + w) * reference - w**2 / (1 + w) * field(t_m, x_m)) / (inverse_step * h)
        return inverse_step, reference
