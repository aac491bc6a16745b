"""The film's periodic state under a cycle's motion: the film replayed alone between coupled cycles
(``solver.periodic_acceleration = "film"``).

What settles slowly in a run with the mass-conserving film is the oil held in the film (its film
fraction), not the mechanism: near the periodic state the pin's cycle-end position changes by the
integrator's noise while the film fraction creeps by a contraction of ~0.6 a cycle
(docs/verification.md). Each coupled cycle records the kinematics of every film state it commits
(solver.dynamics.joint.FilmJoint.trace: the accepted steps' and the outputs'); solved again at those
kinematics and times from the cycle's first committed states, the film alone gives the cycle's film
states back (the same solves: the film's state depends on the motion and its own history only). Solved
again one period later, and again, the film runs cycles of its own under that motion, one solve per
committed state instead of the integrator's stages and Newton iterations (~12 solves a step), until
its film fraction changes by less than ``tolerance`` at every node over a film cycle. Under a fixed
motion the film creeps as slowly as in the coupled cycles (0.65-0.7 a film cycle), so each film cycle
after the second starts from the mixing of the last PAIRS film cycles' ends (the cycle map's
extrapolation, solver.study.periodic, here on the deterministic map of the film alone). The next coupled
cycle starts from the mechanism's end state and that film, whose history is moved back by the periods
replayed (the BDF2 rates depend on the times' differences only).

The fixed point is the plain iteration's: at the periodic state the coupled cycle's end film is the
film's own periodic state under its motion, which the replay leaves as it is. The periodic test is the
plain one, on the coupled cycles.

Numpy here; the film is the run's (solver.film.model.Film).
"""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np

from solver.study.motion import Motion, MotionRun, solve_row
from solver.study.periodic import PAIRS, mixing_coefficients

log = logging.getLogger(__name__)

#: the film cycles stop when one changes the film fraction by more than this fraction of the last
#: one's change: the film no longer contracts under the motion (a motion that does not close, e.g. the
#: first cycle's from the centred pin, drives the film by its jump at every wrap)
STAGNATION = 0.8


@dataclasses.dataclass
class Relaxation:
    """The film replayed alone: its committed history at the coupled cycle's end time (``history``), the
    film cycles replayed, each one's largest change of the film fraction at a node, the solves and the
    seconds they took."""

    history: list[tuple[float, np.ndarray]]
    cycles: int
    changes: list[float]
    solves: int
    seconds: float


def trace_motion(trace: list[tuple[float, tuple]]) -> Motion:
    """The Motion of a cycle's trace (FilmJoint.trace: (t, (e_x, e_y, de_x/dt, de_y/dt, omega_rel)) of
    each committed state, the cycle's start first): the film's relative speed as the journal's."""
    times = np.array([t for t, _ in trace], dtype=float)
    keys = np.array([key for _, key in trace], dtype=float)
    return Motion(times, keys[:, 0:2], keys[:, 2:4], keys[:, 4], np.zeros(len(times)))


def replay(model, motion: Motion, shift: float = 0.0) -> int:
    """Solve ``model`` at rows 1.. of ``motion`` at the rows' times + ``shift``, committing each (a row
    that fails is reached through halved steps, solver.study.motion.solve_row), from the history the
    film holds (its last committed state at row 0's time + shift); returns the solves."""
    shifted = dataclasses.replace(motion, time=motion.time + shift)
    run = MotionRun({}, np.zeros(0, dtype=int))
    solves = model.stats.solves
    for i in range(1, len(shifted)):
        solve_row(model, shifted, i, run)
    return model.stats.solves - solves


def relax(model, film, trace, history, tolerance: float, max_cycles: int, mix: bool = True) -> Relaxation:
    """The film ``model`` replayed alone under the cycle's ``trace`` (module docstring) from its committed
    ``history`` at the cycle's end (time = the trace's last), until its film fraction changes by less
    than ``tolerance`` at every node over a film cycle (or no longer contracts: STAGNATION), at most
    ``max_cycles`` film cycles; ``film`` is its solver.study.periodic.HistoryFilm (the film fraction's
    change). With ``mix`` each film cycle after the first starts from the mixing of the last PAIRS film
    cycles (solver.study.periodic.mixing_coefficients; the history moved by the same correction)."""
    motion = trace_motion(trace)
    period = float(motion.time[-1] - motion.time[0])
    clock = time.perf_counter()
    for time_s, state in history:
        model.commit_history(state, time_s)
    model.start_from(history[-1][1])
    start, changes, solves, pairs = history[-1][1], [], 0, []
    cycles = 0
    for cycles in range(1, max_cycles + 1):
        solves += replay(model, motion, cycles * period)
        committed = model.committed_history()
        end = committed[-1][1]
        a, b = film.parts(start), film.parts(end)
        changes.append(film.changes(a, b).get(film.prefix + "film_fraction", 0.0))
        log.info(
            "film cycle %d under the last cycle's motion: film fraction changed by %.3g (largest at a node)",
            cycles,
            changes[-1],
        )
        if changes[-1] < tolerance or (cycles > 1 and changes[-1] > STAGNATION * changes[-2]):
            break
        start = end
        if mix:
            x, y = (np.concatenate(list(parts.values())) for parts in (a, b))
            pairs = [*pairs, (x, y, end)][-PAIRS:]
            alpha = mixing_coefficients([y - x for x, y, _ in pairs]) if len(pairs) > 1 else None
            if alpha is not None:
                shift = sum(w * x for w, (_, _, x) in zip(alpha, pairs)) - end
                for time_s, state in committed:
                    model.commit_history(film.admissible(state + shift), time_s)
                start = model.committed_history()[-1][1]
                model.start_from(start)
    moved = [(t - cycles * period, x) for t, x in model.committed_history()]
    return Relaxation(moved, cycles, changes, solves, time.perf_counter() - clock)
