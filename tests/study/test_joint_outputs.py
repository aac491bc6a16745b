"""The joints' variables added to results.nc: the short bearing's peak pressure, where h_min is, the
deformation's angle in degrees.

References: the short-bearing (Ocvirk) pressure field p(theta, z) = 6 mu g (z^2 - B^2/4) / h^3 (g < 0,
Guembel) evaluated by brute force on a dense (theta, z) grid; for pure rotation Ocvirk's angle of the
peak, cos theta_m = (1 - sqrt(1 + 24 eps^2)) / (4 eps) from the maximum gap (Hamrock, Fundamentals of
Fluid Film Lubrication, ch. 16; NACA TN 2808), and its pressure there; the elastic film's thinnest point
from the film thickness field dolfinx interpolates from the film's UFL gap (another code path).
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.dynamics.joint import FilmJoint, ShortBearingJoint

R, B, C, MU = 0.01, 0.0025, 10e-6, 0.01


def brute_force_peak(ecc, rate, omega, n_theta=400_001, n_z=41):
    """max over a dense (theta, z) grid of the short-bearing pressure (positive part) and its angle."""
    theta = np.linspace(0.0, 2 * math.pi, n_theta, endpoint=False)
    z = np.linspace(-B / 2, B / 2, n_z)  # z = 0 is on the grid
    cos, sin = np.cos(theta), np.sin(theta)
    h = C - ecc[0] * cos - ecc[1] * sin
    g = 0.5 * omega * (ecc[0] * sin - ecc[1] * cos) - rate[0] * cos - rate[1] * sin
    p = np.maximum(6 * MU * g[:, None] * (z[None, :] ** 2 - B**2 / 4) / h[:, None] ** 3, 0.0)
    i, _ = np.unravel_index(np.argmax(p), p.shape)
    return float(p.max()), float(theta[i])


STATES = [  # (ecc, ecc_rate, omega_rel): rotation, rotation and squeeze, pure squeeze, both directions
    ((0.5 * C, 0.0), (0.0, 0.0), 300.0),
    ((0.3 * C, -0.6 * C), (0.2 * C * 300, 0.1 * C * 300), -200.0),
    ((-0.85 * C, 0.2 * C), (-0.05 * C * 300, 0.3 * C * 300), 150.0),
    ((0.5 * C, 0.0), (1e-3, 0.0), 0.0),
    ((0.1 * C, 0.9 * C), (0.0, -0.2 * C * 300), 500.0),
]


@pytest.mark.parametrize("state", STATES)
def test_short_bearing_peak_pressure_is_the_maximum_of_its_field(state):
    """p_max and its angle against the brute-force maximum of the same closed-form field on 400 001 x 41
    points (theta step 1.6e-5 rad: the grid's maximum is low by ~ (p''/p) dtheta^2 / 8 < 1e-7 of p_max
    at eps 0.9, hence 1e-6 relative; the angle within 1e-4 rad)."""
    ecc, rate, omega = state
    joint = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    p_max, angle = joint.peak_pressure(np.array(ecc), np.array(rate), omega)
    reference, reference_angle = brute_force_peak(ecc, rate, omega)
    assert p_max == pytest.approx(reference, rel=1e-6)
    assert abs((angle - reference_angle + math.pi) % (2 * math.pi) - math.pi) < 1e-4
    forces = joint.forces(np.array(ecc), np.array(rate), omega, 0.0)
    assert joint.outputs(ecc, rate, omega, 0.0, forces)["p_max"] == p_max


@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8, 0.95])
def test_short_bearing_peak_pressure_is_ocvirks_for_pure_rotation(eps):
    """Pure rotation: the peak is at Ocvirk's angle from the maximum gap, cos theta_m = (1 - sqrt(1 +
    24 eps^2)) / (4 eps), on the side the journal turns towards, and p_max = 3 mu omega B^2 / (4 c^2)
    eps sin theta_m / (1 + eps cos theta_m)^3 (the stationary point solved exactly: 1e-9 relative; the
    angle to the minimiser's 1e-10 rad tolerance, 1e-8)."""
    joint = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    omega, attitude = 300.0, 0.7  # the eccentricity's direction in the bushing frame
    ecc = eps * C * np.array([math.cos(attitude), math.sin(attitude)])
    p_max, angle = joint.peak_pressure(ecc, np.zeros(2), omega)
    theta_m = math.acos((1 - math.sqrt(1 + 24 * eps**2)) / (4 * eps))
    expected = (
        3 * MU * omega * B**2 / (4 * C**2) * eps * math.sin(theta_m) / (1 + eps * math.cos(theta_m)) ** 3
    )
    assert p_max == pytest.approx(expected, rel=1e-9)
    # the maximum gap is at attitude + pi; the converging film, where the pressure builds, lies
    # before the minimum gap in the journal's direction of rotation (counter-clockwise here)
    expected_angle = (attitude + math.pi + theta_m) % (2 * math.pi)
    assert abs((angle - expected_angle + math.pi) % (2 * math.pi) - math.pi) < 1e-8
    # the other direction of rotation mirrors the peak about the line of centres
    _, mirrored = joint.peak_pressure(ecc, np.zeros(2), -omega)
    expected_angle = (attitude + math.pi - theta_m) % (2 * math.pi)
    assert abs((mirrored - expected_angle + math.pi) % (2 * math.pi) - math.pi) < 1e-8


def test_short_bearing_without_a_pressurised_arc_has_zero_peak():
    """The centred pin without motion: g = 0 everywhere, no pressure (0); outside the clearance NaN."""
    joint = ShortBearingJoint(radius=R, width=B, clearance=C, viscosity=MU)
    assert joint.peak_pressure(np.zeros(2), np.zeros(2), 0.0)[0] == 0.0
    assert math.isnan(joint.peak_pressure(np.array([C, 0.0]), np.zeros(2), 100.0)[0])


@pytest.mark.serial
def test_elastic_film_h_min_angle_is_the_deformed_films_minimum():
    """Winkler bushing under a heavy squeeze (the deformation moves the thinnest point off the line of
    centres): h_min_angle is the angle of the least value of the film thickness field (pressure-
    deformed gap, interpolated by dolfinx from the film's UFL form: another code path), to the node
    (1e-9 deg), and the gap there is the film's h_min (1e-12 m); a rigid film's is the eccentricity's."""
    from solver.film.bushings import WinklerLayer
    from solver.film.factory import make_film
    from solver.film.spec import FilmSpec
    from solver.film.types import Bearing

    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    ecc, rate, omega = np.array([0.55 * C, 0.72 * C]), np.array([0.02, -0.01]), 300.0
    spec = FilmSpec(
        bearing=bearing,
        omega_ref=200.0,
        mesh_size=0.12,
        bushing=WinklerLayer(thickness=3e-3, E=20e9, nu=0.33),
    )
    with make_film(spec, MPI.COMM_SELF) as model:
        joint = FilmJoint(model)
        forces = joint.forces(ecc, rate, omega, 0.0)
        out = joint.outputs(ecc, rate, omega, 0.0, forces)
        thickness = model.fields_si()["film_thickness"].x.array
        V = model.V
        xy = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local, :2]
        i = int(np.argmin(thickness[: len(xy)]))
        reference = math.degrees(math.atan2(xy[i, 1], xy[i, 0]) + model.frame_angle) % 360.0
        assert abs(out["h_min_angle"] - reference) < 1e-9
        assert float(thickness[i]) == pytest.approx(out["h_min"], abs=1e-12)
        along = math.degrees(math.atan2(ecc[1], ecc[0]))
        assert abs(out["h_min_angle"] - along) > 1.0  # the deformation moved it (else the test proves little)
    with make_film(FilmSpec(bearing=bearing, omega_ref=200.0, mesh_size=0.12), MPI.COMM_SELF) as model:
        joint = FilmJoint(model)
        out = joint.outputs(ecc, rate, omega, 0.0, joint.forces(ecc, rate, omega, 0.0))
        assert out["h_min_angle"] == pytest.approx(math.degrees(math.atan2(ecc[1], ecc[0])), abs=1e-12)


def test_deformation_angle_in_degrees_beside_radians():
    """results.nc keeps deformation_max_angle [rad] and adds deformation_max_angle_deg = its degrees
    (exact conversion); h_min_angle is a variable with units degree."""
    from solver.case import load_case
    from solver.dynamics.engine import engine_from_case, simulate_ideal
    from solver.study.outputs import ideal_cycle_columns
    from solver.study.results import VARIABLES, build_dataset

    case = load_case("cases/reference-2000rpm")
    ideal = simulate_ideal(engine_from_case(case), step_deg=10.0)
    columns = ideal_cycle_columns(ideal)
    columns["deformation_max_angle"] = np.linspace(
        0.0, 2 * math.pi, len(columns["crank_angle"]), endpoint=False
    )
    ds = build_dataset(case, columns, ideal, attrs={})
    assert ds.deformation_max_angle.attrs["units"] == "rad"
    assert ds.deformation_max_angle_deg.attrs["units"] == "degree"
    np.testing.assert_allclose(
        ds.deformation_max_angle_deg.values, np.degrees(columns["deformation_max_angle"]), rtol=1e-15
    )
    assert VARIABLES["h_min_angle"][0] == "degree" and "h_min_angle" in ds
