"""The film history's rates (solver.film.history.FilmHistory): variable-step BDF2 through the committed
states, also after a short step (numpy only)."""

import numpy as np
import pytest

from solver.film.history import FilmHistory


def field(t: float) -> np.ndarray:
    """A smooth history field of two components, its exact derivative below."""
    return np.array([np.exp(np.sin(3.0 * t)), np.cos(2.0 * t) + t**2])


def derivative(t: float) -> np.ndarray:
    return np.array([3.0 * np.cos(3.0 * t) * np.exp(np.sin(3.0 * t)), -2.0 * np.sin(2.0 * t) + 2.0 * t])


def rate_error(times: list[float], time_s: float) -> float:
    """The largest error of the history's rate at ``time_s`` with the exact field there, after committing
    the exact field at ``times``."""
    history = FilmHistory()
    for t in times:
        history.commit(field(t), t)
    inverse_step, reference = history.rate(time_s, lambda _, x: x)
    return float(np.max(np.abs(inverse_step * (field(time_s) - reference) - derivative(time_s))))


@pytest.mark.parametrize("short", [0.01, 0.2])
def test_the_rate_after_a_short_step_is_second_order(short):
    """Steps h, then a short one (``short`` h, an integrator step clipped at an output), then the rate one
    step h later, for h and h / 2 from t = 0.3: BDF2's error falls by 4 when h halves. Through the
    short step's two ends the ratio w = 1 / short is beyond BDF2_MAX_RATIO (implicit Euler there would
    halve the error only); the rate goes through the state before the short step instead. Tolerance:
    the ratio of the errors in (3.2, 4.8), order 2 within 0.3 (the next term at these h moves it by
    ~0.2)."""
    errors = []
    for h in (0.02, 0.01):
        times = [0.3, 0.3 + h, 0.3 + h + short * h]
        errors.append(rate_error(times, times[-1] + h))
    assert 3.2 < errors[0] / errors[1] < 4.8, errors


def test_the_rate_with_regular_steps_is_second_order():
    """Steps h with a ratio 1.5 between the last two (inside BDF2_MAX_RATIO): the same order 2 (the
    check that the selection keeps the adjacent pair). Tolerance as above."""
    errors = []
    for h in (0.02, 0.01):
        times = [0.3, 0.3 + h, 0.3 + 2.0 * h]
        errors.append(rate_error(times, times[-1] + 1.5 * h))
    assert 3.2 < errors[0] / errors[1] < 4.8, errors


def test_the_states_before_a_time_give_its_rate_again():
    """The states ``before`` returns, committed into a new history, give the same rate (the ParaView
    fields solve the output states again from them: solver.study.fields); after a short step they are
    the short step's end and the state before it; beyond the ratio from every older state, the last
    alone (implicit Euler). Exact."""
    history = FilmHistory()
    times = [0.0, 0.1, 0.101]
    for t in times:
        history.commit(field(t), t)
    chosen = history.before(0.201)
    assert [t for t, _ in chosen] == [0.0, 0.101]
    again = FilmHistory()
    for t, x in chosen:
        again.commit(x, t)
    first, second = history.rate(0.201, lambda _, x: x), again.rate(0.201, lambda _, x: x)
    assert first[0] == second[0] and np.array_equal(first[1], second[1])
    assert [t for t, _ in history.before(0.101 + 2.4 * 0.101 + 1e-3)] == [0.101]
