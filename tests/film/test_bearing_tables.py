"""The finite-element film against published finite-bearing tables and closed forms.

References (independent of this code):
- H. J. Butenschoen, Das hydrodynamische, zylindrische Gleitlager endlicher Breite unter
  instationaerer Belastung, Karlsruhe 1976: So and attitude angle for journal rotation and So for
  pure squeeze (../shared/data). The tables assume the Reynolds condition with the film starting
  at the line of maximum thickness, i.e. ``inlet = "max-gap"``.
- F. W. Ocvirk, Short-bearing approximation for full journal bearings, NACA TN 2808, 1952.
- N. P. Petroff (1883): concentric journal, torque = 2 pi mu omega R^3 B / c.
"""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from solver.film.bearing import Bearing, FilmModel, Kinematics, default_mesh_size, equilibrium
from tests.conftest import SHARED_DATA

R, C, MU = 0.02, 20e-6, 0.01  # m, m, Pa s: any values; the tables are dimensionless
OMEGA = 2 * math.pi * 50  # rad/s


def _table(name: str) -> list[dict[str, float]]:
    with open(SHARED_DATA / name) as f:
        rows = [line for line in f if not line.startswith("#")]
    return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(rows)]


def sommerfeld(load: float, width: float, speed: float) -> float:
    """So = F psi^2 / (B D eta omega) (Butenschoen)."""
    return load * (C / R) ** 2 / (width * 2 * R * MU * speed)


@pytest.fixture(scope="module", params=[1.0, 0.5], ids=["B/D=1", "B/D=0.5"])
def rotating_bearing(request):
    width = request.param * 2 * R
    with FilmModel(
        Bearing(radius=R, width=width, clearance=C, viscosity=MU), _self(), omega_ref=OMEGA
    ) as model:
        yield request.param, model


def _self():
    from mpi4py import MPI

    return MPI.COMM_SELF


@pytest.mark.serial
def test_rotation_matches_butenschoen(rotating_bearing):
    """So within 3 % (eps 0.2-0.95) and attitude within 2 deg (eps >= 0.4) at the default mesh.

    The tolerances are the issue's acceptance figures; DESIGN 6 says a VI solution of ~5000 nodes
    gets within ~1 % and 1.5 deg. The eccentricity direction is deliberately off the mesh axes.
    """
    ratio, model = rotating_bearing
    rows = [
        r
        for r in _table("butenschoen_rotation.csv")
        if r["width_to_diameter"] == ratio and 0.2 <= r["eccentricity_ratio"] <= 0.95
    ]
    assert len(rows) >= 8
    direction = 2.2  # rad
    for row in rows:
        eps = row["eccentricity_ratio"]
        kin = Kinematics(
            (eps * C * math.cos(direction), eps * C * math.sin(direction)), (0.0, 0.0), OMEGA, 0.0
        )
        result = model.solve(kin)
        So = sommerfeld(result.load, ratio * 2 * R, OMEGA)
        assert So == pytest.approx(row["So"], rel=0.03), f"eps = {eps}"
        load_direction = math.atan2(-result.force[1], -result.force[0])
        attitude = abs((math.degrees(direction - load_direction) + 180) % 360 - 180)
        if eps >= 0.4:
            assert attitude == pytest.approx(row["beta_deg"], abs=2.0), f"eps = {eps}"


@pytest.mark.serial
@pytest.mark.parametrize("inlet", ["max-gap", "none"])
def test_pure_squeeze_matches_butenschoen(inlet):
    """Pure squeeze (no rotation), B/D = 1: So = F psi^2/(B D eta |deps/dt|) within 3 %.

    The squeeze film cavitates on the side the journal moves away from, whatever the inlet, so
    both inlet models must reproduce the table.
    """
    rows = _table("butenschoen_squeeze.csv")
    rate = 40.0  # 1/s
    with FilmModel(
        Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet=inlet), _self(), omega_ref=rate
    ) as model:
        for row in rows:
            eps = row["eccentricity_ratio"]
            direction = np.array([math.cos(-0.4), math.sin(-0.4)])
            result = model.solve(
                Kinematics(tuple(eps * C * direction), tuple(rate * C * direction), 0.0, 0.0)
            )
            So = result.load * (C / R) ** 2 / (2 * R * 2 * R * MU * rate)
            assert So == pytest.approx(row["So"], rel=0.03), f"eps = {eps}"
            # the film pushes the journal back along the line of centres
            assert np.dot(result.force, direction) < -0.999 * result.load


@pytest.mark.serial
def test_short_bearing_limit_matches_ocvirk():
    """B/D = 1/16, eps <= 0.6: load within 3 % of Ocvirk's closed form

    W = mu U B^3 eps / (4 c^2 (1 - eps^2)^2) sqrt(pi^2 (1 - eps^2) + 16 eps^2).

    The finite-length correction at B/D = 1/16 is below 1 % (it vanishes as B/D -> 0); the default
    mesh (10 elements across the half width) adds ~0.2 % (bench/bearing_mesh_convergence.py).
    """
    width = 2 * R / 16
    with FilmModel(
        Bearing(radius=R, width=width, clearance=C, viscosity=MU), _self(), omega_ref=OMEGA
    ) as model:
        for eps in (0.2, 0.4, 0.6):
            result = model.solve(Kinematics((eps * C, 0.0), (0.0, 0.0), OMEGA, 0.0))
            U = R * OMEGA
            W = (
                MU
                * U
                * width**3
                * eps
                / (4 * C**2 * (1 - eps**2) ** 2)
                * math.sqrt(math.pi**2 * (1 - eps**2) + 16 * eps**2)
            )
            assert result.load == pytest.approx(W, rel=0.03), f"eps = {eps}"


@pytest.mark.serial
def test_concentric_friction_torque_is_petroff():
    """Concentric journal: no pressure, torque on the journal -2 pi mu omega R^3 B / c (Petroff).

    The only discretisation error is the area of the faceted cylinder (relative ~h^2/12 = 2e-4 at
    h = 0.05 R), so the tolerance is 1e-3. The bushing feels the opposite torque.
    """
    width = 2 * R
    with FilmModel(
        Bearing(radius=R, width=width, clearance=C, viscosity=MU), _self(), omega_ref=OMEGA
    ) as model:
        result = model.solve(Kinematics((0.0, 0.0), (0.0, 0.0), OMEGA, 0.0))
    petroff = 2 * math.pi * MU * OMEGA * R**3 * width / C
    assert result.torque_journal == pytest.approx(-petroff, rel=1e-3)
    assert result.torque_bushing == pytest.approx(petroff, rel=1e-3)
    assert result.load < 1e-9 * petroff / R


@pytest.mark.serial
def test_load_eccentricity_load_round_trip():
    """Load -> equilibrium eccentricity -> load: the film force balances the load to 1e-6 relative,
    and the eccentricity lies where the Butenschoen table puts that So (within 3 % in So)."""
    width = 2 * R
    with FilmModel(
        Bearing(radius=R, width=width, clearance=C, viscosity=MU), _self(), omega_ref=OMEGA
    ) as model:
        So_target = 1.3146  # table: eps = 0.6 at B/D = 1
        load = So_target * width * 2 * R * MU * OMEGA / (C / R) ** 2
        W = (0.3 * load, -math.sqrt(1 - 0.09) * load)
        eq = equilibrium(model, W, omega_journal=OMEGA)
        again = model.solve(eq.kinematics)
    assert np.linalg.norm(np.add(again.force, W)) <= 1e-6 * load
    eps = math.hypot(*eq.kinematics.ecc) / C
    rows = [r for r in _table("butenschoen_rotation.csv") if r["width_to_diameter"] == 1.0]
    So_at_eps = np.interp(eps, [r["eccentricity_ratio"] for r in rows], [r["So"] for r in rows])
    assert So_at_eps == pytest.approx(So_target, rel=0.03)


@pytest.mark.serial
@pytest.mark.parametrize(
    "ratio, eps, motion",
    [(1 / 8, 0.95, "rotation"), (1 / 8, 0.6, "squeeze"), (1 / 4, 0.95, "squeeze"), (2, 0.95, "rotation")],
)
def test_default_mesh_is_within_one_percent_of_mesh_converged(ratio, eps, motion):
    """At the default element size (film.bearing.default_mesh_size: 0.07 R, and at least 10 elements
    across the half width) the load is within 1 % of its mesh-converged value for any B/D: here the
    hardest cases of bench/bearing_mesh_convergence.py (narrow, and eccentricity 0.95). The reference
    is the Richardson extrapolation of the default and the halved mesh with order 2 (the observed
    order of P1 with the midpoint rule is 1.9-2.1 in that study); with 0.07 R everywhere, B/D = 1/8
    lost 6-8 %, which this test would catch."""
    width = 2 * R * ratio
    loads = []
    for refine in (1, 2):
        size = default_mesh_size(width, R) / refine
        with FilmModel(
            Bearing(radius=R, width=width, clearance=C, viscosity=MU),
            _self(),
            omega_ref=OMEGA,
            mesh_size=size,
        ) as model:
            ecc = (0.0, -eps * C)
            kin = (
                Kinematics(ecc, (0.0, 0.0), OMEGA, 0.0)
                if motion == "rotation"
                else Kinematics(ecc, (0.0, -C * OMEGA), 0.0, 0.0)
            )
            loads.append(model.solve(kin).load)
    converged = loads[1] + (loads[1] - loads[0]) / 3
    assert loads[0] == pytest.approx(converged, rel=0.01)
    assert abs(loads[1] - loads[0]) > 1e-4 * converged  # the two meshes differ: the check can fail
