"""``python3 -m solver bearing --bushing-speed``: a turning bushing (a small end's swinging rod) under a
load fixed in space.

The load and the journal centre are fixed; the journal turns at omega_j, the bushing at omega_b. In the
frame of the load the film is steady and Reynolds' equation sees the mean surface speed
R (omega_j + omega_b) / 2 (the wedge), the Couette shear the sliding speed R (omega_j - omega_b). So
the pressure, the force and the equilibrium depend on the sum only, the Couette part of the friction
torques on the difference (it flips with it). The commands run in this process (one import for all).
"""

from __future__ import annotations

import contextlib
import io
import json
import math

import pytest

from solver.cli import main

R, C, MU = 0.01, 10e-6, 0.01  # m, m, Pa s
W_RPM = 300.0
W = W_RPM * 2 * math.pi / 60  # rad/s
EPS = 0.5
SHORT = ["--radius", str(R), "--width", str(R / 4), "--clearance", str(C), "--viscosity", str(MU)]  # B/D 1/8
LOAD_CASE = ["--radius", str(R), "--width", str(R / 2), "--clearance", str(C), "--viscosity", str(MU)]


def _bearing(*args: str) -> tuple[int, dict | None, str]:
    """Run ``bearing ARGS --json`` in this process: (exit status, the JSON report or None, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["bearing", *args, "--json"])
    return status, (json.loads(out.getvalue()) if status == 0 else None), err.getvalue()


_CACHE: dict[tuple[str, ...], dict] = {}


def _report(*args: str) -> dict:
    if args not in _CACHE:
        status, report, err = _bearing(*args)
        assert status == 0, err
        _CACHE[args] = report
    return _CACHE[args]


def _at_eccentricity(journal_rpm: float, bushing_rpm: float) -> dict:
    speeds = ["--speed", f"{journal_rpm:g}", "--bushing-speed", f"{bushing_rpm:g}"]
    return _report(*SHORT, *speeds, "--eccentricity", f"{EPS}")


@pytest.mark.serial
def test_oscillating_bushing_carries_the_ocvirk_load_of_the_summed_speeds():
    """B/D = 1/8, eps = 0.5: the film force with (journal, bushing) = (0, w), (w, 0) and (w/2, w/2) is
    the same, and it is Ocvirk's short-bearing force with U = R (omega_j + omega_b):

        F = mu U B^3 eps / (4 c^2 (1 - eps^2)^2) sqrt(pi^2 (1 - eps^2) + 16 eps^2),
        tan(attitude) = pi sqrt(1 - eps^2) / (4 eps).

    The three films solve the same discrete equations (the turning eccentricity's squeeze and the
    wedge enter the same form), so they agree to round-off: 1e-9. Against Ocvirk 3 %: the finite-length
    correction at B/D = 1/8 (the short-bearing law neglects the circumferential pressure flow; ~1.5 %,
    it vanishes as B/D -> 0) and the default mesh (10 elements across the half width, ~0.2 %,
    bench/bearing_mesh_convergence.py), as for the bushing at rest in tests/dynamics/test_joint.py;
    measured -1.6 %. The attitude within 0.5 deg (measured +0.1 deg).
    """
    bushing = _at_eccentricity(0.0, W_RPM)
    journal = _at_eccentricity(W_RPM, 0.0)
    both = _at_eccentricity(W_RPM / 2, W_RPM / 2)
    for other in (journal, both):
        assert bushing["load_N"] == pytest.approx(other["load_N"], rel=1e-9)
        assert bushing["force_x_N"] == pytest.approx(other["force_x_N"], rel=1e-9, abs=1e-9 * other["load_N"])
        assert bushing["force_y_N"] == pytest.approx(other["force_y_N"], rel=1e-9, abs=1e-9 * other["load_N"])
    B, U = R / 4, R * W  # U = R (omega_j + omega_b)
    ocvirk = (
        MU
        * U
        * B**3
        * EPS
        / (4 * C**2 * (1 - EPS**2) ** 2)
        * math.sqrt(math.pi**2 * (1 - EPS**2) + 16 * EPS**2)
    )
    assert bushing["load_N"] == pytest.approx(ocvirk, rel=0.03)
    attitude = math.degrees(math.atan(math.pi * math.sqrt(1 - EPS**2) / (4 * EPS)))
    assert bushing["attitude_deg"] == pytest.approx(attitude, abs=0.5)
    # the Sommerfeld number takes the summed speed, so it is the same for the three
    assert bushing["sommerfeld_So"] == pytest.approx(journal["sommerfeld_So"], rel=1e-9)
    assert both["sommerfeld_So"] == pytest.approx(journal["sommerfeld_So"], rel=1e-9)


@pytest.mark.serial
def test_friction_torques_flip_with_the_sliding_speed():
    """Same films (B/D = 1/8, eps = 0.5): the pressure is the same, so the torques differ by the Couette
    parts only, which follow the sliding speed R (omega_j - omega_b) (Reynolds cavitation keeps the full
    shear everywhere):

        T_j(w, 0) - T_j(0, w) = -2 mu R^3 B w integral dtheta / h = -2 mu R^3 B w 2 pi / (c sqrt(1 - eps^2)),

    and T_b the opposite. Tolerance 1e-3: the faceted cylinder's area error, ~h^2/12 (as for Petroff's
    torque in tests/film/test_bearing_tables.py; measured -5e-6). With the surfaces at the same speed
    (no sliding) the journal and the bushing carry the same torque (the pressure part, the mean of the
    two others to round-off, 1e-9). The torque on the journal opposes the sliding: it changes sign with
    it; the report gives the sliding speed R (omega_j - omega_b).
    """
    bushing = _at_eccentricity(0.0, W_RPM)
    journal = _at_eccentricity(W_RPM, 0.0)
    both = _at_eccentricity(W_RPM / 2, W_RPM / 2)
    B = R / 4
    couette = 2 * MU * R**3 * B * W * 2 * math.pi / (C * math.sqrt(1 - EPS**2))
    difference = journal["friction_torque_Nm"] - bushing["friction_torque_Nm"]
    assert difference == pytest.approx(-couette, rel=1e-3)
    difference_b = journal["friction_torque_bushing_Nm"] - bushing["friction_torque_bushing_Nm"]
    assert difference_b == pytest.approx(couette, rel=1e-3)
    assert journal["friction_torque_Nm"] < 0 < bushing["friction_torque_Nm"]
    assert journal["friction_torque_bushing_Nm"] > 0 > bushing["friction_torque_bushing_Nm"]
    mean = 0.5 * (journal["friction_torque_Nm"] + bushing["friction_torque_Nm"])
    assert both["friction_torque_Nm"] == pytest.approx(mean, rel=1e-9, abs=1e-12 * couette)
    assert both["friction_torque_bushing_Nm"] == pytest.approx(mean, rel=1e-9, abs=1e-12 * couette)
    assert journal["sliding_speed_m_per_s"] == pytest.approx(R * W, rel=1e-12)
    assert bushing["sliding_speed_m_per_s"] == pytest.approx(-R * W, rel=1e-12)
    assert both["sliding_speed_m_per_s"] == 0.0
    for report in (journal, bushing, both):
        assert report["entrainment_speed_m_per_s"] == pytest.approx(R * W / 2, rel=1e-12)


@pytest.mark.serial
def test_load_carried_by_the_bushing_alone_is_the_journal_equilibrium():
    """--speed 0 --bushing-speed 300 --load 20 (B/D = 1/4): the equilibrium converges (force residual
    <= 1e-7 of the load, the equilibrium search's tolerance) at the eccentricity of --speed 300 with the
    bushing at rest, on the same side of the load line: the mean surface speed has the same sign, so
    the attitude is the same (to the Newton tolerance, 1e-6; measured 1e-15), not mirrored. It is the
    mirror image (x -> -x) of --speed -300, where the mean speed is reversed (1e-4: the mesh is not
    symmetric about the load line; measured 3e-6)."""
    load = ["--load", "20"]
    bushing = _report(*LOAD_CASE, "--speed", "0", "--bushing-speed", "300", *load)
    journal = _report(*LOAD_CASE, "--speed", "300", *load)
    reverse = _report(*LOAD_CASE, "--speed", "-300", *load)
    assert bushing["force_residual_N"] <= 1e-7 * 20
    assert 0.3 < bushing["eccentricity"] < 0.95  # a real equilibrium, not the start or the limit
    assert bushing["eccentricity"] == pytest.approx(journal["eccentricity"], rel=1e-6)
    assert bushing["ecc_x_m"] == pytest.approx(journal["ecc_x_m"], rel=1e-6)
    assert bushing["ecc_y_m"] == pytest.approx(journal["ecc_y_m"], rel=1e-6)
    assert bushing["ecc_x_m"] > 0  # ahead of the load line in the direction of the mean surface speed
    assert bushing["ecc_x_m"] == pytest.approx(-reverse["ecc_x_m"], rel=1e-4)
    assert bushing["ecc_y_m"] == pytest.approx(reverse["ecc_y_m"], rel=1e-4)
    # the sliding (and so the friction) is reversed: the journal drags the other way
    assert bushing["friction_torque_Nm"] > 0 > journal["friction_torque_Nm"]


@pytest.mark.serial
@pytest.mark.parametrize(
    "args, fragments",
    [
        (["--speed", "0", "--load", "100"], ("--speed = 0 and --bushing-speed = 0 with --load",)),
        (
            ["--speed", "300", "--bushing-speed", "-300", "--load", "100"],
            ("--bushing-speed = -300", "counter-rotation", "carries no steady load"),
        ),
        (["--speed", "0", "--eccentricity", "0.5"], ("nothing moves", "--bushing-speed")),
        (
            ["--bushing-speed", "300", "--eccentricity", "0.5", "--cavitation", "jfo"],
            ("--bushing-speed = 300 with --cavitation jfo",),
        ),
        (
            ["--bushing-speed", "300", "--eccentricity", "0.5", "--elastic", "winkler"],
            ("--bushing-speed = 300 with --elastic winkler",),
        ),
    ],
)
def test_speeds_that_carry_no_steady_load_are_refused(args, fragments):
    """One line naming the flags, exit 2, nothing on stdout."""
    status, _, err = _bearing(*LOAD_CASE, *args)
    assert status == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for fragment in fragments:
        assert fragment in lines[0]


@pytest.mark.serial
def test_counter_rotation_at_an_eccentricity_carries_nothing():
    """--speed 300 --bushing-speed -300 --eccentricity 0.5 (no wedge): no pressure, no force (below 1e-9
    of the force at the summed speed 600 rpm, round-off), and the journal feels the Couette torque of
    the sliding speed 2 R w alone, -mu R^3 B 2 w 2 pi / (c sqrt(1 - eps^2)) (1e-3, the faceted area);
    no Sommerfeld number (null)."""
    report = _at_eccentricity(W_RPM, -W_RPM)
    reference = _at_eccentricity(W_RPM, 0.0)
    assert report["load_N"] <= 1e-9 * reference["load_N"]
    B = R / 4
    couette = MU * R**3 * B * 2 * W * 2 * math.pi / (C * math.sqrt(1 - EPS**2))
    assert report["friction_torque_Nm"] == pytest.approx(-couette, rel=1e-3)
    assert report["friction_torque_bushing_Nm"] == pytest.approx(couette, rel=1e-3)
    assert report["sommerfeld_So"] is None
