"""Fixtures of the film tests: the central differences that the film's exact Jacobians are checked against."""

from __future__ import annotations

import numpy as np
import pytest


def _outputs(result) -> np.ndarray:
    return np.array([*result.force, result.torque_journal, result.torque_bushing])


def central_differences(model, base, steps, time_s=None) -> np.ndarray:
    """d(force_x, force_y, torque_journal, torque_bushing)/d(ecc, ecc_rate, omega_rel) by central
    differences of full film solves (``time_s`` passed on to an elastic film's solve)."""
    from solver.film.bearing import Kinematics

    J_fd = np.zeros((4, 5))
    for j in range(5):
        d = np.zeros(5)
        d[j] = steps[j]
        plus, minus = (
            Kinematics(
                (base.ecc[0] + s * d[0], base.ecc[1] + s * d[1]),
                (base.ecc_rate[0] + s * d[2], base.ecc_rate[1] + s * d[3]),
                base.omega_journal + s * d[4],
                base.omega_bushing,
            )
            for s in (1, -1)
        )
        J_fd[:, j] = (_outputs(model.solve(plus, time_s)) - _outputs(model.solve(minus, time_s))) / (
            2 * steps[j]
        )
    return J_fd


@pytest.fixture
def film_differences():
    """``central_differences(model, base, steps, time_s=None)`` as a fixture."""
    return central_differences
