"""The film replayed alone between coupled cycles (solver.study.relaxation, ``periodic_acceleration =
"film"``).

References: the coupled cycle itself (the film solved again at the kinematics and times of the states
the cycle committed, from the cycle's first committed states, must give the cycle's committed states:
the film's state depends on its motion and history only; a deterministic computation, round-off); and
a film whose film cycles are a linear contraction toward a known state (the cycles to the tolerance in
closed form, log(tol / d_1) / log(lambda)).
"""

from __future__ import annotations

import dataclasses
import math

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.case import load_case
from solver.study.periodic import HistoryFilm
from solver.study.relaxation import STAGNATION, relax, replay, trace_motion
from solver.study.simulation import Run, run_case
from tests.conftest import interrupt_and_resume, run_cli
from tests.study.test_engine_coupled import make_case
from tests.study.test_engine_jfo import _jfo_case


@pytest.mark.serial
def test_the_film_replayed_alone_gives_the_cycles_film_back(tmp_path):
    """One cycle of the coarse JFO engine (rigid bushing, film 0.2 R, 4 deg outputs) recording its film's
    trace (solver.dynamics.joint.FilmJoint.trace: one row per committed state, the accepted steps' and
    the outputs'); the film alone, from the cycle's first committed state, solved at the trace's rows:
    its committed states are the cycle's, to round-off (1e-12 of the film fraction; measured 2e-15). The
    trace starts at the cycle's start and ends at its end, and has a row for each accepted step."""
    directory = _jfo_case(tmp_path / "replay")
    toml = directory / "case.toml"
    toml.write_text(toml.read_text().replace("step_deg = 2", "step_deg = 4", 1))
    case = load_case(directory)
    run = Run(case, MPI.COMM_SELF, case.solver.joint)
    t0, q0, qd0 = run.em.initial_state(0.0)
    run.joint.trace = []
    _, (t_end, _, _) = run.integrate_cycle(0, t0, q0, qd0)
    end, start = run.model.committed_history(), run.start_film
    motion = trace_motion(run.joint.trace)
    assert motion.time[0] == t0 and motion.time[-1] == t_end
    assert len(motion) - 1 >= run.steps
    for time_s, state in start:
        run.model.commit_history(state, time_s)
    run.model.start_from(start[-1][1])
    assert replay(run.model, motion) == len(motion) - 1
    again = run.model.committed_history()
    assert [t for t, _ in again] == [t for t, _ in end]
    for (_, x), (_, y) in zip(end, again):
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-12)


@dataclasses.dataclass
class _Stats:
    solves: int = 0


class _ContractingFilm:
    """A film stand-in whose state x moves toward ``target`` by ``kappa`` of the way at each solve (a film
    cycle of n rows contracts its distance by lambda = (1 - kappa)^n), the target moved by ``drift`` at
    each solve (a forcing that does not settle); the state is u, the film fraction 1 + min(u, 0)."""

    def __init__(self, target, kappa, drift=0.0):
        self.target, self.kappa, self.drift = np.asarray(target, float), kappa, drift
        self.history, self.stats, self.warm = [], _Stats(), None

    def commit_history(self, state, time_s):
        self.history = [e for e in self.history if e[0] < time_s][-2:] + [(time_s, np.array(state))]

    def start_from(self, state):
        self.warm = np.array(state)

    def committed_history(self):
        return [(t, x.copy()) for t, x in self.history]

    def history_state(self):
        return self.state.copy()

    def solve(self, kin, time_s):
        self.stats.solves += 1
        last = self.history[-1][1]
        self.target = self.target + self.drift
        self.state = last + self.kappa * (self.target - last)
        return _Result()


class _Result:
    supply_flow = side_flow = 0.0


def _trace(rows):
    return [(k * 1e-3, (0.0, 0.0, 0.0, 0.0, 100.0)) for k in range(rows + 1)]


def test_relaxation_stops_at_the_tolerance_after_the_closed_form_number_of_film_cycles():
    """Plain film cycles (no mixing) of a film whose film cycle (10 rows, kappa 0.05 a row) contracts by
    lambda = 0.95^10 = 0.599 toward u* (film fractions 0.3, 0.6; u = theta - 1 < 0), from u = 0 (a full
    film, theta 1): the largest change of theta in film cycle k is d_1 lambda^(k - 1) with d_1 = (1 -
    lambda) 0.7, so it stops at the first k with d_1 lambda^(k - 1) < 1e-4, k = 1 + ceil(log(1e-4 / d_1)
    / log(lambda)) = 17, the state within d_k lambda / (1 - lambda) of u*, the history's times those of
    the cycle's end (moved back by the 17 periods) and 10 solves a film cycle. Exact arithmetic up to
    round-off (1e-12)."""
    target = np.array([-0.7, -0.4])
    model = _ContractingFilm(target, 0.05)
    film = HistoryFilm("", 2, True)
    trace = _trace(10)
    history = [(0.008, np.zeros(2)), (0.009, np.zeros(2)), (0.010, np.zeros(2))]
    relaxed = relax(model, film, trace, history, tolerance=1e-4, max_cycles=40, mix=False)
    lam = 0.95**10
    d1 = (1 - lam) * 0.7
    expected = 1 + math.ceil(math.log(1e-4 / d1) / math.log(lam))
    assert relaxed.cycles == expected == 17
    np.testing.assert_allclose(relaxed.changes, d1 * lam ** np.arange(expected), rtol=1e-9)
    assert relaxed.solves == 10 * expected
    assert [t for t, _ in relaxed.history] == pytest.approx([0.008, 0.009, 0.010], abs=1e-12)
    error = np.max(np.abs(relaxed.history[-1][1] - target))
    assert error <= relaxed.changes[-1] * lam / (1 - lam) * (1 + 1e-9)


def test_relaxation_stops_when_the_film_no_longer_contracts():
    """The same film with its target moved by 1e-4 a solve (a motion whose wrap keeps feeding the film):
    the change tends to 10 x 1e-4 a film cycle instead of falling below the tolerance, and the film cycles
    stop at the first one whose change is above STAGNATION of the last one's, well before max_cycles."""
    model = _ContractingFilm(np.array([-0.7, -0.4]), 0.05, drift=1e-4)
    film = HistoryFilm("", 2, True)
    history = [(0.008, np.zeros(2)), (0.009, np.zeros(2)), (0.010, np.zeros(2))]
    relaxed = relax(model, film, _trace(10), history, tolerance=1e-6, max_cycles=40, mix=False)
    assert relaxed.cycles < 40 and relaxed.changes[-1] > 100 * 1e-6
    assert relaxed.changes[-1] > STAGNATION * relaxed.changes[-2]
    assert all(b <= STAGNATION * a for a, b in zip(relaxed.changes[:-2], relaxed.changes[1:-1]))


def test_the_mixed_film_cycles_reach_a_linear_films_periodic_state_in_three():
    """The film of the closed-form test with the mixing: its film cycle is affine, u -> lambda u + (1 -
    lambda) u*, so the third film cycle starts from the Aitken combination of the first two's pairs, u*
    itself (to round-off), and changes nothing (< 1e-4): 3 film cycles instead of 17, the history at u*
    (1e-12)."""
    target = np.array([-0.7, -0.4])
    model = _ContractingFilm(target, 0.05)
    history = [(0.008, np.zeros(2)), (0.009, np.zeros(2)), (0.010, np.zeros(2))]
    relaxed = relax(model, HistoryFilm("", 2, True), _trace(10), history, tolerance=1e-4, max_cycles=40)
    assert relaxed.cycles == 3 and relaxed.changes[-1] < 1e-12
    for _, state in relaxed.history:
        np.testing.assert_allclose(state, target, rtol=0, atol=1e-12)


def _film_case(directory):
    """The coarse JFO engine (0.2 R, 4 deg outputs, 2 cycles) with ``periodic_acceleration = "film"``."""
    case = _jfo_case(directory)
    toml = case / "case.toml"
    text = toml.read_text().replace("step_deg = 2", 'step_deg = 4\nperiodic_acceleration = "film"', 1)
    toml.write_text(text.replace("field_angles_deg = [380]", "field_angles_deg = []", 1))
    return case


@pytest.mark.slow
@pytest.mark.serial
def test_a_run_with_the_film_alone_records_it_and_resumes_exactly(tmp_path, monkeypatch):
    """Two cycles of the coarse JFO engine with ``periodic_acceleration = "film"`` (never periodic at its
    tolerance of 1e-9): after the first the film runs alone (``history.film_alone_cycles`` >= 1, none after
    the last cycle), one solve per committed state (``timing.film_alone_solves`` at least the film cycles
    x the 180 outputs); stopped after the first cycle and resumed, the run ends with the same numbers
    (exact: the checkpoint holds the film the film alone left, not the cycle's end)."""
    straight = run_case(_film_case(tmp_path / "straight"), MPI.COMM_SELF)
    resumed = interrupt_and_resume(_film_case(tmp_path / "interrupted"), monkeypatch, 1)
    with xr.open_dataset(straight.results) as a, xr.open_dataset(resumed.results) as b:
        alone = a.attrs["history.film_alone_cycles"]
        assert alone[0] >= 1 and alone[1] == 0
        solves = a.attrs["timing.film_alone_solves"]
        assert solves[0] >= 180 * alone[0] and solves[1] == 0
        for name in ("ecc_x", "ecc_y", "h_min", "oil_volume", "friction_power"):
            np.testing.assert_array_equal(a[name].values, b[name].values)


@pytest.mark.serial
def test_the_film_alone_needs_a_mass_conserving_small_end(tmp_path):
    """The reference case (Reynolds cavitation) with ``periodic_acceleration = "film"``: one line naming
    the key and what is allowed, exit 2, nothing written."""
    case = make_case(tmp_path / "reynolds", 'periodic_acceleration = "film"\nmax_cycles = 1\n')
    result = run_cli("run", str(case), "--quiet")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0
    assert 'solver.periodic_acceleration = "film"' in result.stderr
    assert 'oil.cavitation = "jfo"' in result.stderr
    assert "Traceback" not in result.stderr and not (case / "results" / "results.nc").exists()
