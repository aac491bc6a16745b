"""The equilibrium of the reference small end with the finite-element eye under a load (``python3 -m
solver bearing --load ... --elastic fe``): the journal goes past one clearance into the deflecting eye,
and the search must follow it there (the bound from the compliance, steps the film can follow)."""

from __future__ import annotations

import json
import math
import types

import numpy as np
import pytest

from solver.errors import FilmNotConverged
from solver.film import equilibrium as search
from solver.film.types import FilmJacobian
from tests.conftest import run_cli

#: the reference small end, its shank opposite the load (the bearing command's default): the eye bends
#: open under the load, 5 kN spread over the projected area open the bushing by 1.06 c
SMALL_END = [
    "--radius",
    "0.012",
    "--width",
    "0.022",
    "--clearance",
    "12e-6",
    "--grade",
    "5W-30",
    "--temperature",
    "110",
    "--speed",
    "750",
    "--elastic",
    "fe",
    "--bushing-thickness",
    "1.5e-3",
    "--eye-outer-radius",
    "0.019",
    "--inlet",
    "none",
    "--json",
]
ROUGH = ["--sigma-journal", "1e-7", "--sigma-bushing", "3e-7"]
LOADS = (5000.0, 20000.0, 33000.0)
#: the equilibrium's relative tolerance on the force residual (solver.film.equilibrium, its default)
TOL = 1e-7


def _equilibria(surface: list[str], loads) -> list[dict]:
    reports = []
    for load in loads:
        proc = run_cli("bearing", *SMALL_END, *surface, "--load", f"{load:g}")
        assert proc.returncode == 0, proc.stderr
        assert "Traceback" not in proc.stderr and "Warning" not in proc.stderr, proc.stderr
        reports.append(json.loads(proc.stdout))
    return reports


def _check(reports: list[dict], loads) -> None:
    """Load balance, direction, and a physically sane journal position for each load."""
    for load, report in zip(loads, reports):
        fx, fy = report["force_x_N"], report["force_y_N"]
        # the film (and asperity) force on the journal balances the load (0, -W): its residual within
        # the equilibrium's tolerance TOL |W| (the search stops there)
        assert math.hypot(fx, fy - load) <= TOL * load, (load, fx, fy)
        assert report["force_residual_N"] <= TOL * load
        # direction: straight up, against the load, to TOL (the same residual bounds the angle)
        assert abs(math.atan2(fx, fy)) <= 2 * TOL, (load, fx, fy)
        assert report["load_N"] == pytest.approx(load, rel=TOL)
        # past one clearance (the eye deflects open by more than c already at 5 kN), within the bound
        # the compliance gives (1 + 2 x 1.06 c at 5 kN, proportionally more above), the film open
        assert 1.0 < report["eccentricity"] < 1.0 + 2 * 1.06 * load / 5000.0
        assert report["h_min_m"] > 0.0
        assert report["max_deformation_m"] > report["h_min_m"]
    eccentricities = [r["eccentricity"] for r in reports]
    assert eccentricities == sorted(eccentricities) and len(set(eccentricities)) == len(loads)
    peaks = [r["p_max_Pa"] for r in reports]
    assert peaks == sorted(peaks)


@pytest.mark.serial
def test_fe_eye_equilibrium_at_5_kN_smooth_and_rough():
    """5 kN, smooth and rough: the load balanced past one clearance (eps = 1.85), quick: the search
    that needed 62 s reached the bound, halved its steps and came back."""
    for surface in ([], ROUGH):
        (report,) = _equilibria(surface, LOADS[:1])
        _check([report], LOADS[:1])


@pytest.mark.serial
@pytest.mark.slow
def test_fe_eye_equilibrium_under_growing_loads_smooth():
    """5, 20 and 33 kN on smooth surfaces (the film alone carries the load)."""
    _check(_equilibria([], LOADS), LOADS)


@pytest.mark.serial
@pytest.mark.slow
def test_fe_eye_equilibrium_under_growing_loads_rough():
    """5, 20 and 33 kN on rough surfaces (mixed lubrication: the asperities share the load). 33 kN took
    the film to h/sigma = 0.06, where the shear-flow factor was held below H = 0.5 with a step in its
    slope: the coupled Newton cycled between two iterates there and the search gave up at eps = 4.48
    (30.5 kN carried). With the C1 hold (solver.film.flow_factors) it is balanced like the others."""
    reports = _equilibria(ROUGH, LOADS)
    _check(reports, LOADS)
    assert all(0 < r["asperity_load_N"] < r["load_N"] for r in reports)
    # at 33 kN the film is thinner than the composite roughness (0.316 um): mixed lubrication
    assert reports[-1]["h_min_m"] < 0.316e-6


class _BarrierFilm:
    """A film whose force is a linear spring, F = -K e, and which cannot be solved past eps = BARRIER
    (as the rough small end at 33 kN): the equilibrium under W = K e_eq lies beyond the barrier."""

    BARRIER, K, c = 1.5, 1e4 / 12e-6, 12e-6

    def __init__(self):
        self.bearing = types.SimpleNamespace(clearance=self.c)
        self.failed: list[np.ndarray] = []  # the eccentricities [c] of the failed solves

    def reach(self, load) -> float:
        return 3.0  # > 1: the elastic search (trust region, failed solves halved)

    def start_near(self, kin) -> None:
        pass

    def solve(self, kin):
        e = np.asarray(kin.ecc)
        if np.linalg.norm(e) / self.c > self.BARRIER:
            self.failed.append(e / self.c)
            raise FilmNotConverged("elastic film solve did not converge", -5, 230)
        force = -self.K * e
        return types.SimpleNamespace(force=force, load=float(np.linalg.norm(force)), h_min=1e-7)

    def jacobian(self) -> FilmJacobian:
        matrix = np.zeros((4, 5))
        matrix[:2, :2] = -self.K * np.identity(2)
        return FilmJacobian(matrix)


@pytest.mark.serial
def test_equilibrium_ends_at_a_failed_solve_near_an_earlier_one():
    """A film that cannot be solved past eps = 1.5 under a load balanced at eps = 2: the search reaches
    the barrier (steps halved after each failed solve) and ends at the first failed solve within
    BARRIER_DISTANCE of an earlier one, FilmNotConverged naming the last eccentricity ratio it solved
    (before: it crept on in halved steps, one failed solve each, for its 60 Newton iterations)."""
    film = _BarrierFilm()
    load = (0.0, -2.0 * film.K * film.c)  # balanced at e = (0, -2 c)
    with pytest.raises(FilmNotConverged, match="cannot be solved past eccentricity ratio 1.4") as err:
        search.equilibrium(film, load, omega_journal=78.5)
    # the last failed solve is the first one near an earlier one (here the third: 1.78, 1.580, 1.589)
    *before, last = film.failed
    near = [np.linalg.norm(last - e) <= search.BARRIER_DISTANCE for e in before]
    assert any(near), film.failed
    assert not any(
        np.linalg.norm(a - b) <= search.BARRIER_DISTANCE for i, a in enumerate(before) for b in before[:i]
    ), film.failed
    # the solution it names lies below the barrier, within 0.1 of it (the search had come that near)
    eps = float(str(err.value).split("eccentricity ratio ")[1].split(" ")[0])
    assert film.BARRIER - 0.1 < eps <= film.BARRIER


@pytest.mark.serial
def test_equilibrium_ends_when_failed_solves_use_up_their_wall_budget(monkeypatch):
    """With no wall budget for failed film solves (FAILED_SECONDS = 0) the first failed solve ends the
    search: the budget bounds the time spent failing whatever the distance between the failures."""
    monkeypatch.setattr(search, "FAILED_SECONDS", 0.0)
    film = _BarrierFilm()
    with pytest.raises(FilmNotConverged, match="cannot be solved past"):
        search.equilibrium(film, (0.0, -2.0 * film.K * film.c), omega_journal=78.5)
    assert len(film.failed) == 1, film.failed
