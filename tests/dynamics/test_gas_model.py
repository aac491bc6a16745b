"""Verification of the cylinder-pressure models of solver.dynamics.gas.

References written independently here: the slider-crank volume, the polytropic law p V^n = const,
the closed integral of p dV by composite Simpson quadrature, and the DESIGN 3.7 description of the
reference engine (peak about 6 MPa near 375-385 deg).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import simpson

from solver.dynamics.gas import CylinderGeometry, SingleZoneModel, load_pressure_trace, single_zone_model
from solver.errors import InputError

BORE, R, L, CR = 0.086, 0.043, 0.145, 10.5


def volume(theta_deg, offset=0.0):
    """Cylinder volume of the offset slider-crank (own formula: pin height above the crank centre)."""
    theta = np.radians(theta_deg)
    area = math.pi * BORE**2 / 4.0
    x = R * np.cos(theta) + np.sqrt(L**2 - (offset - R * np.sin(theta)) ** 2)
    x_top, x_bottom = math.sqrt((L + R) ** 2 - offset**2), math.sqrt((L - R) ** 2 - offset**2)
    swept = area * (x_top - x_bottom)
    return swept / (CR - 1.0) + area * (x_top - x), swept


def geometry(offset=0.0):
    return CylinderGeometry(bore=BORE, crank_radius=R, rod_length=L, pin_offset=offset, compression_ratio=CR)


def closed_integral_of_p_dV(model, offset=0.0, points=40001):
    """Composite Simpson over the three smooth pieces (the pressure jumps at 540 and 720 deg)."""
    work = 0.0
    for start, end in ((0.0, 180.0), (180.0, 540.0), (540.0, 720.0)):
        theta = np.linspace(start, end, points)
        theta_inside = theta.copy()
        theta_inside[-1] = np.nextafter(end, -np.inf)  # left limit at the piece's end
        V, _ = volume(theta, offset)
        work += simpson(model.pressure(np.radians(theta_inside)), x=V)
    return work


@pytest.mark.parametrize("n", [1.25, 1.32, 1.4])
def test_motored_compression_and_expansion_follow_p_V_to_the_n(n):
    """Without heat release p V^n = p_intake V(180 deg)^n from 180 to 540 deg (to round-off, 1e-12)."""
    model = SingleZoneModel(geometry=geometry(), polytropic_exponent=n, heat_release=0.0)
    theta = np.linspace(180.0, 539.9, 3600)
    V, _ = volume(theta)
    invariant = model.pressure(np.radians(theta)) * V**n
    V_ivc, _ = volume(180.0)
    assert np.max(np.abs(invariant / (1e5 * V_ivc**n) - 1.0)) < 1e-12


def test_gas_exchange_pressures_are_the_given_constants():
    """Intake 0-180 deg at p_intake, exhaust 540-720 deg at p_exhaust (DESIGN 3.7 simple gas exchange)."""
    model = single_zone_model(geometry(), peak_pressure=60e5, intake_pressure=0.9e5, exhaust_pressure=1.2e5)
    assert np.all(model.pressure(np.radians(np.linspace(0.0, 179.9, 50))) == 0.9e5)
    assert np.all(model.pressure(np.radians(np.linspace(540.0, 719.9, 50))) == 1.2e5)
    assert model.pressure(np.radians(720.0)) == 0.9e5  # periodic


@pytest.mark.parametrize("a, m", [(5.0, 2.0), (6.9, 1.0), (3.0, 3.0)])
def test_heat_release_fraction_rises_monotonically_from_zero_to_one(a, m):
    """x_b = 0 up to the start, non-decreasing, = 1 from start + duration on; halfway it is the
    normalised Wiebe value (1 - exp(-a 0.5^(m+1))) / (1 - exp(-a)) (Heywood 1988, eq. 9.23, normalised)."""
    model = SingleZoneModel(
        geometry=geometry(),
        combustion_start=math.radians(345.0),
        combustion_duration=math.radians(55.0),
        wiebe_a=a,
        wiebe_m=m,
        heat_release=1.0,
    )
    theta = np.radians(np.linspace(0.0, 720.0, 72001)[:-1])  # one cycle; 720 deg starts the next
    x_b = model.burn_fraction(theta)
    assert np.all(np.diff(x_b) >= 0.0)
    assert np.all(x_b[theta <= math.radians(345.0)] == 0.0)
    assert np.all(np.abs(x_b[theta >= math.radians(400.0)] - 1.0) < 1e-15)
    halfway = (1.0 - math.exp(-a * 0.5 ** (m + 1.0))) / (1.0 - math.exp(-a))
    assert float(model.burn_fraction(math.radians(372.5))) == pytest.approx(halfway, rel=1e-13)


@pytest.mark.parametrize("offset", [0.0, 1.5e-3])
@pytest.mark.parametrize("imep", [8e5, 15e5])
def test_imep_from_the_closed_integral_of_p_dV_equals_the_target(imep, offset):
    """IMEP = (closed integral of p dV over 720 deg) / V_d, by Simpson on 3 x 40001 points.

    The pressure is smooth within each piece except the kink of the heat-release rate at the end of
    combustion (dp/dtheta jumps), which limits Simpson to ~h^2 there: < 1e-7 relative at h = 0.009 deg.
    Tolerance 1e-6 relative.
    """
    model = single_zone_model(geometry(offset), imep=imep)
    _, swept = volume(0.0, offset)
    assert closed_integral_of_p_dV(model, offset) / swept == pytest.approx(imep, rel=1e-6)


def test_peak_pressure_target_is_met():
    """max p on a 0.005 deg grid equals the target (grid error ~ p'' h^2/8 ~ 1e-8 relative; tol 1e-6)."""
    model = single_zone_model(geometry(), peak_pressure=75e5, combustion_start=math.radians(355.0))
    theta = np.radians(np.arange(340.0, 420.0, 0.005))
    assert np.max(model.pressure(theta)) == pytest.approx(75e5, rel=1e-6)


def test_reference_engine_peaks_near_6_MPa_between_375_and_385_deg():
    """DESIGN 3.7: single-zone model, compression ratio 10.5, peak about 6 MPa near 375-385 deg."""
    model = single_zone_model(geometry(), peak_pressure=60e5)  # the case defaults
    theta = np.arange(300.0, 460.0, 0.01)
    p = model.pressure(np.radians(theta))
    assert 375.0 <= theta[np.argmax(p)] <= 385.0
    assert np.max(p) == pytest.approx(60e5, rel=1e-6)


def test_pressure_derivative_matches_finite_differences():
    """dp/dtheta (used in the gas-force Jacobian) against central differences away from the jumps."""
    model = single_zone_model(geometry(), peak_pressure=60e5)
    theta = np.radians(np.linspace(181.0, 539.0, 700))
    step = 1e-6
    reference = (model.pressure(theta + step) - model.pressure(theta - step)) / (2.0 * step)
    assert np.max(np.abs(model.derivative(theta) - reference)) < 1e-5 * np.max(np.abs(reference))


def test_targets_below_the_motored_cycle_are_rejected():
    """A peak pressure below the motored peak, or an IMEP below the motored IMEP, needs negative heat."""
    expected = r"gas.peak_pressure_bar = 10 is out of range \(allowed: > the motored peak"
    with pytest.raises(InputError, match=expected):
        single_zone_model(geometry(), peak_pressure=10e5)
    with pytest.raises(InputError, match=r"gas.imep_bar = -5 is out of range"):
        single_zone_model(geometry(), imep=-5e5)


# --------------------------------------------------------------------------------------------------
# Pressure traces
# --------------------------------------------------------------------------------------------------
def write(path, text):
    path.write_text(text)
    return path


def test_trace_interpolates_its_points_periodically(tmp_path):
    """The trace passes through its points, is 720-deg periodic, and PCHIP does not overshoot."""
    angles = np.arange(0.0, 720.0, 10.0)
    bar = 1.0 + 40.0 * np.exp(-(((angles - 370.0) / 25.0) ** 2))
    rows = "".join(f"{a},{p}\n" for a, p in zip(angles, bar))
    text = "# a measured trace\ncrank_angle_deg,pressure_bar\n" + rows
    trace = load_pressure_trace(write(tmp_path / "p.csv", text))
    assert np.allclose(trace.pressure(np.radians(angles)), bar * 1e5, rtol=1e-14)
    fine = np.radians(np.linspace(0.0, 720.0, 7201))
    assert np.allclose(trace.pressure(fine + 4 * math.pi), trace.pressure(fine), rtol=1e-13)
    assert np.max(trace.pressure(fine)) <= np.max(bar) * 1e5 * (1 + 1e-14)
    assert np.min(trace.pressure(fine)) >= 1e5 * (1 - 1e-14)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "crank_angle_deg,pressure_bar\n0,1\n10,2\n10,3\n",
            r"line 4: crank angles must be strictly increasing",
        ),
        ("crank_angle_deg,pressure_bar\n0,1\n10,nan\n20,3\n", r"line 3: pressure_bar = nan is not finite"),
        (
            "angle,pressure\n0,1\n10,2\n",
            r"line 1: header is 'angle,pressure', expected crank_angle_deg,pressure_bar",
        ),
        ("crank_angle_deg,pressure_bar\n0,1\n10,2,3\n", r"line 3: expected 2 columns"),
        ("crank_angle_deg,pressure_bar\n0,1\n10,abc\n", r"line 3: '10,abc' is not two numbers"),
        ("crank_angle_deg,pressure_bar\n0,1\n800,2\n", r"line 3: crank_angle_deg = 800 is out of range"),
        ("crank_angle_deg,pressure_bar\n0,1\n360,2\n720,3\n", r"line 4: the point at 720 deg must repeat"),
        ("crank_angle_deg,pressure_bar\n0,1\n360,-2\n", r"negative"),
        ("crank_angle_deg,pressure_bar\n", r"needs at least 2 data lines"),
    ],
)
def test_bad_trace_files_give_one_line_errors_naming_the_field(tmp_path, text, message):
    """Trace-file errors are one line naming gas.pressure_file, the line number and the problem."""
    path = write(tmp_path / "bad.csv", text)
    with pytest.raises(InputError, match=message) as caught:
        load_pressure_trace(path)
    assert str(caught.value).startswith("gas.pressure_file = ") and "\n" not in str(caught.value)


def test_missing_trace_file(tmp_path):
    """A missing trace file names the field and says so."""
    with pytest.raises(InputError, match=r"gas.pressure_file = '.*nowhere.csv': file not found"):
        load_pressure_trace(tmp_path / "nowhere.csv")


SMOOTH = dict(
    exhaust_opening=math.radians(490.0),
    blowdown_duration=math.radians(70.0),
    valve_overlap=math.radians(40.0),
)


def test_gas_exchange_with_blowdown_and_overlap_has_no_jump():
    """With the exhaust opening at 490 deg, a 70 deg blowdown and a 40 deg overlap the pressure is
    continuous with a bounded derivative over the whole cycle, 720 -> 0 included: on a 0.001 deg grid
    no step exceeds the largest |dp/dtheta| times the grid step (x 1.01, the mean value theorem);
    the step model's drop at 540 deg (about 3 bar) would exceed it a thousandfold. The pressure is
    the closed-cylinder one up to 490, p_exhaust after 560 to 700 and p_intake from 20 to 180 deg."""
    model = single_zone_model(geometry(), peak_pressure=60e5, **SMOOTH)
    theta = np.radians(np.linspace(0.0, 720.0, 720001))
    p = model.pressure(theta)
    slope = np.max(np.abs(model.derivative(theta)))
    assert np.max(np.abs(np.diff(p))) <= 1.01 * slope * np.radians(0.001)
    assert p[0] == pytest.approx(p[-1], rel=1e-12)  # periodic
    step = single_zone_model(geometry(), peak_pressure=60e5)
    closed = np.radians(np.linspace(180.0, 489.9, 500))
    assert np.allclose(model.pressure(closed), step.pressure(closed), rtol=1e-9)
    assert np.all(model.pressure(np.radians(np.linspace(560.01, 700.0, 50))) == model.exhaust_pressure)
    assert np.all(model.pressure(np.radians(np.linspace(20.0, 179.9, 50))) == model.intake_pressure)


def test_smooth_gas_exchange_derivative_matches_finite_differences():
    """dp/dtheta through the blowdown and the overlap (and the closed part) against central
    differences (step 1e-6 rad: truncation ~1e-10 relative); tolerance 1e-5 of the largest slope."""
    model = single_zone_model(geometry(), peak_pressure=60e5, **SMOOTH)
    theta = np.radians(np.concatenate([np.linspace(181.0, 719.0, 900), np.linspace(1.0, 19.0, 30)]))
    step = 1e-6
    reference = (model.pressure(theta + step) - model.pressure(theta - step)) / (2.0 * step)
    assert np.max(np.abs(model.derivative(theta) - reference)) < 1e-5 * np.max(np.abs(reference))


@pytest.mark.parametrize("imep", [8e5, 15e5])
def test_smooth_gas_exchange_imep_is_the_closed_integral_of_p_dV(imep):
    """The IMEP target with the blowdown and overlap: Simpson over the whole (smooth) cycle on 200001
    points against the target, 1e-6 (the pressure is C1; the heat-release kink limits Simpson to h^2)."""
    model = single_zone_model(geometry(), imep=imep, **SMOOTH)
    theta = np.linspace(0.0, 720.0, 200001)
    V, swept = volume(theta)
    assert simpson(model.pressure(np.radians(theta)), x=V) / swept == pytest.approx(imep, rel=1e-6)


@pytest.mark.parametrize("smooth", [False, True], ids=["step", "blowdown-overlap"])
def test_scalar_pressure_equals_the_array_pressure(smooth):
    """The mechanism asks for the pressure one angle at a time (scalar paths: the constant phases and the
    closed cylinder); the array evaluation is the reference: equal to 4e-16 relative (the same
    operations; numpy's scalar and array kernels may round the last bit differently), over two cycles
    and at the phase boundaries (intake closing at 180 deg, the combustion's start and end, the
    exhaust opening, the blowdown's end, the overlap)."""
    model = single_zone_model(geometry(), peak_pressure=60e5, **(SMOOTH if smooth else {}))
    edges = [
        math.pi,
        model.combustion_start,
        model.combustion_start + model.combustion_duration,
        model.exhaust_opening,
        model.exhaust_opening + model.blowdown_duration,
        4 * math.pi - 0.2,
        0.2,
    ]
    theta = np.concatenate(
        [np.linspace(-0.5, 8 * math.pi, 7001), edges, np.nextafter(edges, 0.0), np.nextafter(edges, 10.0)]
    )
    array = model.pressure(theta)
    scalar = np.array([model.pressure(float(t)) for t in theta])
    assert np.max(np.abs(scalar - array) / array) <= 4e-16
    assert np.ptp(array) > 50e5  # (the whole cycle: intake to the peak)
