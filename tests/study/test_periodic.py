"""The cycle map's extrapolation (solver.study.periodic): exact on a linear map, and on the coarse JFO
engine the same periodic state as the plain cycles in fewer cycles.

References: the fixed point of a linear map ``x -> A x + b``, ``(I - A)^-1 b`` (closed form), which the
mixing of pairs reaches exactly once the pairs span the map's non-zero modes (the Krylov property of
the minimal polynomial extrapolation, Smith, Ford & Sidi 1987); and the plain cycle iteration of the
same coarse case, run in the test, for the periodic state (its own tolerances).
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.study.periodic import PAIRS, mixing_coefficients
from solver.study.simulation import run_case
from tests.study.test_engine_jfo import _jfo_case


@pytest.mark.serial
def test_the_mixing_reaches_the_fixed_point_of_a_linear_map():
    """A linear map with two slow modes (0.7 and 0.4, the rest 0) in 6 dimensions, from a start whose
    error lies in the slow modes (the fast ones settle in the first cycle): the plain iteration is still
    0.7^k from the fixed point; the mixing of the last PAIRS = 3 pairs is at it to round-off once three
    pairs are known (two residual differences span the two modes). 1e-10 relative: the least-squares
    solve's round-off on residuals of order 1."""
    rng = np.random.default_rng(7)
    basis, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    A = basis @ np.diag([0.7, 0.4, 0.0, 0.0, 0.0, 0.0]) @ basis.T
    b = rng.normal(size=6)
    fixed = np.linalg.solve(np.eye(6) - A, b)
    start = fixed + basis[:, :2] @ np.array([1.0, -2.0])
    x, pairs = start, []
    for _ in range(3):
        pairs.append((x, A @ x + b))
        alpha = (
            mixing_coefficients([end - start for start, end in pairs[-PAIRS:]]) if len(pairs) > 1 else None
        )
        x = pairs[-1][1] if alpha is None else sum(a * end for a, (_, end) in zip(alpha, pairs[-PAIRS:]))
    plain = start
    for _ in range(3):
        plain = A @ plain + b
    assert np.linalg.norm(x - fixed) < 1e-10 * np.linalg.norm(fixed)
    assert np.linalg.norm(plain - fixed) > 0.1 * np.linalg.norm(fixed)  # (the plain one is not)


def test_the_mixing_refuses_a_far_extrapolation():
    """Two parallel residuals, the second 0.9 and 0.7 of the first (a mode contracting by 0.9 or 0.7):
    the combination is Aitken's, alpha = (-lambda, 1) / (1 - lambda), i.e. (-9, 10) beyond
    MAX_COEFFICIENT = 5 (None: the plain start) and (-2.33, 3.33) within it (to round-off)."""
    f = np.array([1.0, 0.0])
    assert mixing_coefficients([f, 0.9 * f]) is None
    np.testing.assert_allclose(mixing_coefficients([f, 0.7 * f]), np.array([-0.7, 1.0]) / 0.3, rtol=1e-12)


COARSE = (
    "max_cycles = 12\nstep_deg = 4\nmesh_size = 0.2\nperiodic_tolerance = 0.0002\n"
    "periodic_friction_tolerance = 0.005\nfield_step_deg = 0\nfield_angles_deg = []\n"
)


@pytest.mark.slow
@pytest.mark.serial
def test_the_extrapolated_cycles_reach_the_plain_periodic_state(tmp_path):
    """The coarse JFO engine (film 0.2 R, 4 deg outputs; the JFO cases' tolerances: 2 nm in min h_min,
    0.5 % in the friction) run plain and with ``periodic_acceleration = "mpe"``: both periodic and the
    same periodic state within the tolerances the periodic test itself allows between two cycles. The
    extrapolation saved cycles here (5 against 7) until the shear-flow factor was held C1 below
    h/sigma = 0.5 (solver.film.flow_factors), which this coarse film reaches: since then its friction
    wanders by 1-5 % from cycle to cycle for longer, and the runs took 9 (plain) and 10 cycles (MPE; 8
    since the extrapolated start's projection holds the eccentricities), so fewer cycles is not asserted
    (measured: min h_min 0.2028 / 0.2012 um, friction 4.4229 / 4.4116 W; since: 0.2028 / 0.2028 um,
    4.4229 / 4.4484 W).
    Tolerances: min h_min within 2 x 0.0002 x clearance (each run is within one tolerance of its own
    periodic state), the friction within 2 x 0.5 %."""
    results = {}
    for acceleration in ("none", "mpe"):
        case = _jfo_case(tmp_path / acceleration)
        toml = case / "case.toml"
        # the full-film shear, as the JFO cases run: with the film-fraction weighted shear the coarse
        # film's friction alternates by ~1 % a cycle (12 plain cycles not periodic at 0.5 %)
        full = 'cavitation = "jfo"\ncavitated_shear = "full"'
        text = toml.read_text().replace('cavitation = "jfo"', full, 1)
        text = text.split("[solver]")[0]
        toml.write_text(text + f'[solver]\n{COARSE}periodic_acceleration = "{acceleration}"\n')
        summary = run_case(case, MPI.COMM_SELF)
        with xr.open_dataset(summary.results) as ds:
            results[acceleration] = (summary, ds.attrs.copy())
    (plain, plain_attrs), (mpe, mpe_attrs) = results["none"], results["mpe"]
    clearance = plain_attrs["small_end.clearance_um"] * 1e-6
    assert plain.periodic and mpe.periodic
    assert abs(mpe.h_min_min - plain.h_min_min) < 2 * 0.0002 * clearance
    assert abs(mpe.friction_power_mean / plain.friction_power_mean - 1) < 2 * 0.005
    # each cycle's change of each part of the state is in results.nc; the plain run never extrapolates
    assert np.all(np.asarray(plain_attrs["history.extrapolated_start"]) == 0)
    assert np.asarray(mpe_attrs["history.extrapolated_start"]).sum() >= 1
    assert np.all(np.isfinite(np.asarray(mpe_attrs["history.state_change_film_fraction"])))
