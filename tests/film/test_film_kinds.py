"""What every film kind must do, on one fixture parametrised over the kinds the factory builds
(tests/film/conftest.py: rigid smooth, rigid rough, Winkler, JFO, elastic JFO, the FE eye in
modes and in the layer basis with each cavitation law)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.film.types import Kinematics

C, OMEGA = 10e-6, 200.0


@pytest.mark.serial
def test_jacobian_matches_finite_differences(film, film_differences):
    """The exact Jacobian (active set, JFO partition frozen) against central differences of full solves,
    at a state with rotation of both surfaces and squeeze, a step after a committed state for the films
    with history. Steps 1e-5 of each input's scale: the truncation error ~1e-10, round-off ~1e-9 of the
    solves' tolerance; the partition does not move over such a step at this state. Tolerance 1e-4 of
    each row's largest entry (the mixed and JFO films' kinks allow no tighter a common bound)."""
    base = Kinematics(
        (0.8 * C * math.cos(1.0), 0.8 * C * math.sin(1.0)),
        (0.3 * C * OMEGA, -0.2 * C * OMEGA),
        OMEGA,
        0.3 * OMEGA,
    )
    time_s = None
    if film.has_history:  # a committed steady state, then the state a step later
        film.solve(Kinematics(base.ecc, (0.0, 0.0), OMEGA, 0.3 * OMEGA), 0.0)
        film.commit_history(film.history_state(), 0.0)
        time_s = 1e-4
    film.solve(base, time_s)
    J = film.jacobian().matrix
    steps = np.array([1e-5 * C] * 2 + [1e-5 * C * OMEGA] * 2 + [1e-5 * OMEGA])
    J_fd = film_differences(film, base, steps, time_s)
    for row in range(4):
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-4 * scale, (row, J[row], J_fd[row])


@pytest.mark.serial
def test_frame_angle_is_the_solution_frames_turn(film):
    """``Film.frame_angle``: 0 before a solve and with any inlet but max-gap; with the max-gap inlet the
    angle of the maximum gap (opposite the eccentricity), by which the last solve's frame is turned."""
    assert film.frame_angle == 0.0
    angle = 1.0
    film.solve(Kinematics((0.5 * C * math.cos(angle), 0.5 * C * math.sin(angle)), (0.0, 0.0), OMEGA, 0.0))
    expected = angle + math.pi if film.bearing.inlet == "max-gap" else 0.0
    assert film.frame_angle == pytest.approx(expected, abs=1e-12)
