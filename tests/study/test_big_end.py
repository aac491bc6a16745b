"""The big end (crankpin in the rod's big eye) as a short-bearing clearance joint.

References:

- the orbit of the big end alone (small end ideal) against an independent integration of the same
  equations: the rod and piston reduced to the two free coordinates of the big eye's centre (the small
  end on the cylinder axis closes the loop), Lagrange's equations ``J^T M (J u'' + c) = J^T f + Q_film``
  written here by hand, Ocvirk's short-bearing force integrated by Gauss-Legendre quadrature over the
  exact pressurised half of the film (where ``g < 0``, a half period of a sinusoid), the friction torque
  from its closed form (Couette ``mu R^3 B omega 2 pi / (c sqrt(1 - eps^2))`` and the pressure part
  ``-(e x F) / 2``: Hamrock, Fundamentals of Fluid Film Lubrication, ch. 16), and scipy's Radau;
- the energy audit of a cycle with both joints lubricated (input work = dissipation in both films +
  change of mechanical energy);
- the film force against the ideal joint's reaction (the ideal mechanism solved to round-off);
- an existing case with ``[big_end] joint = "ideal"`` stated gives the answers of the case without it.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp

from solver.case import load_case
from solver.dynamics.engine import engine_from_case, simulate_ideal
from solver.errors import InputError
from solver.study.simulation import run_case
from tests.conftest import ROOT, energy_balance, run_cli

REFERENCE = ROOT / "cases" / "reference-2000rpm"


def make_case(directory: Path, solver: str, big_end: str = "") -> Path:
    """The reference case, without its [big_end] section, with other [solver] keys and a [big_end]
    section (if given)."""
    directory.mkdir(parents=True, exist_ok=True)
    head = (REFERENCE / "case.toml").read_text().split("[solver]")[0]
    before, after = head.split("[big_end]")
    head = before + "[oil]" + after.split("[oil]", 1)[1]
    (directory / "case.toml").write_text(
        head.replace('name = "reference-2000rpm"', f'name = "{directory.name}"')
        + (f"\n[big_end]\n{big_end}" if big_end else "")
        + "\n[solver]\n"
        + solver
    )
    return directory


@functools.cache
def gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1] (computed once)."""
    return np.polynomial.legendre.leggauss(nodes)


def ocvirk_force(ecc, ecc_rate, omega_rel, *, mu, R, B, c, nodes=400):
    """Force of the bushing on the journal (bushing frame) of the short bearing, half-Sommerfeld.

    Reynolds without the circumferential flow, ``d/dz(h^3/(12 mu) dp/dz) = omega/2 dh/dtheta + dh/dt
    = g``, p = 0 at z = +-B/2: ``p = 6 mu g (z^2 - B^2/4) / h^3``, kept where positive (g < 0), so
    ``int p dz = -mu B^3 g / h^3`` and ``F = -R int int p n dtheta dz = mu B^3 R int_{g<0} g n / h^3``.
    With h = c - e_x cos - e_y sin, ``g = a sin(theta) + b cos(theta) = K sin(theta + d)``: the film
    is pressurised on theta + d in (pi, 2 pi), integrated by Gauss-Legendre on that arc."""
    ex, ey = ecc
    a = 0.5 * omega_rel * ex - ecc_rate[1]
    b = -0.5 * omega_rel * ey - ecc_rate[0]
    if a == 0.0 and b == 0.0:
        return np.zeros(2)
    d = math.atan2(b, a)
    x, w = gauss_legendre(nodes)
    theta = (math.pi - d) + 0.5 * math.pi * (x + 1.0)
    w = 0.5 * math.pi * w
    h = c - ex * np.cos(theta) - ey * np.sin(theta)
    g = a * np.sin(theta) + b * np.cos(theta)
    weight = w * g / h**3
    return mu * B**3 * R * np.array([np.sum(weight * np.cos(theta)), np.sum(weight * np.sin(theta))])


def independent_orbit(case, angles_deg: np.ndarray) -> np.ndarray:
    """The big end's eccentricity (rod frame, m) at the crank angles, from the module docstring's
    equations: state (B, dB/dt) of the big eye's centre B, crank at constant speed, small end ideal."""
    engine = engine_from_case(case)
    be, mu = case.big_end, case.oil.viscosity
    r, l, a, l_g = engine.crank_radius, engine.rod_length, engine.pin_offset, engine.rod_cg_from_big_end
    m_r, I_r, m_p, grav = engine.rod_mass, engine.rod_inertia, engine.piston_mass, engine.gravity
    omega = engine.crank_motion.speed
    masses = np.diag([m_r, m_r, I_r, m_p])

    def pieces(t, y):
        Bx, By, vx, vy = y
        theta = omega * t
        phi = math.asin((a - By) / l)
        s, co = math.sin(phi), math.cos(phi)
        phi_y = -1.0 / (l * co)
        phi_yy = s / (l**2 * co**3)
        phi_dot = phi_y * vy
        # rows: G_x, G_y, phi, x_piston; columns: B_x, B_y
        J = np.array(
            [[1.0, -l_g * s * phi_y], [0.0, 1.0 + l_g * co * phi_y], [0.0, phi_y], [1.0, -l * s * phi_y]]
        )
        phi_c = phi_yy * vy**2
        c_terms = np.array(
            [
                -l_g * (s * phi_c + co * phi_dot**2),
                l_g * (co * phi_c - s * phi_dot**2),
                phi_c,
                -l * (s * phi_c + co * phi_dot**2),
            ]
        )
        A = np.array([[co, -s], [s, co]])
        crankpin = r * np.array([math.cos(theta), math.sin(theta)])
        crankpin_v = r * omega * np.array([-math.sin(theta), math.cos(theta)])
        ecc = A.T @ (crankpin - np.array([Bx, By]))
        ecc_rate = A.T @ (crankpin_v - np.array([vx, vy])) - phi_dot * np.array([-ecc[1], ecc[0]])
        return theta, phi_y, J, c_terms, A, ecc, ecc_rate, omega - phi_dot

    def rhs(t, y):
        theta, phi_y, J, c_terms, A, ecc, ecc_rate, omega_rel = pieces(t, y)
        eps = math.hypot(*ecc) / be.clearance
        if eps >= 1.0:  # a trial state outside the clearance: no film there (Radau shortens the step)
            return np.full(4, np.nan)
        F = ocvirk_force(ecc, ecc_rate, omega_rel, mu=mu, R=be.radius, B=be.width, c=be.clearance)
        couette = (
            mu * be.radius**3 * be.width * omega_rel * 2 * math.pi / (be.clearance * math.sqrt(1 - eps**2))
        )
        bushing_torque = couette - 0.5 * (ecc[0] * F[1] - ecc[1] * F[0])
        applied = np.array([-m_r * grav, 0.0, 0.0, -m_p * grav - float(engine.gas_force(theta))])
        q_film = -(A @ F) + bushing_torque * np.array([0.0, phi_y])
        accel = np.linalg.solve(J.T @ masses @ J, J.T @ (applied - masses @ c_terms) + q_film)
        return np.concatenate([y[2:], accel])

    # the start of the project's run: the ideal configuration at 0 deg, the joints centred, no relative
    # motion (the big eye moves with the crankpin)
    start = np.array([r, 0.0, 0.0, r * omega])
    times = np.radians(angles_deg) / omega
    solution = solve_ivp(rhs, (0.0, times[-1]), start, method="Radau", t_eval=times, rtol=1e-9, atol=1e-12)
    assert solution.success, solution.message
    return np.array([pieces(t, y)[5] for t, y in zip(solution.t, solution.y.T)])


@pytest.mark.serial
def test_big_end_orbit_matches_an_independent_integration(tmp_path):
    """The first cycle of the big end alone (from the centred start): its eccentricity ratio within 1 %
    of the clearance of the independent integration at every 2 deg output (the project's run at rtol
    1e-8; the difference is the two integrations' errors and the quadratures', measured ~1e-4)."""
    case_dir = make_case(
        tmp_path / "big-end-alone",
        'joint = "ideal"\nmax_cycles = 1\nstep_deg = 2\nrtol = 1e-8\n',
        'joint = "short-bearing"\n',
    )
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    case = load_case(case_dir)
    c = case.big_end.clearance
    reference = independent_orbit(case, ds.crank_angle.values)
    project = np.column_stack([ds.big_end_ecc_x.values, ds.big_end_ecc_y.values])
    error = np.max(np.hypot(*(project - reference).T)) / c
    eps_max = np.max(np.hypot(*reference.T)) / c
    print(f"max |e - e_ref| / c = {error:.3g}, max eps = {eps_max:.3f}")
    assert eps_max > 0.5  # a loaded orbit, not a centred journal
    assert error < 0.01
    # the reported h_min is the rigid gap of that orbit; the small end (ideal) reports no film
    assert np.allclose(ds.big_end_h_min.values, c - np.hypot(*project.T), rtol=0, atol=1e-12)
    assert np.all(np.isnan(ds.h_min.values))
    assert summary.big_end_h_min_min == pytest.approx(float(ds.big_end_h_min.min()), rel=1e-12)
    # the film carries the ideal joint's load (the ideal mechanism's reaction, solved to round-off):
    # the difference is the rod's inertia over its orbit in the clearance, a few N against a 33 kN peak;
    # within 1 % of the peak at every output after the start (measured 1.2e-4; at 0 deg the film of
    # the centred start carries nothing: 6.7 % of the peak)
    ideal = simulate_ideal(engine_from_case(case), step_deg=2.0)
    film = np.column_stack([ds.big_end_force_x.values, ds.big_end_force_y.values])
    peak = np.max(np.hypot(*ideal.big_end_force.T))
    assert np.max(np.hypot(*(film - ideal.big_end_force)[1:].T)) < 0.01 * peak


@pytest.mark.serial
def test_energy_audit_with_both_joints_lubricated(tmp_path):
    """Small end and big end both short bearings, one cycle: input work - change of mechanical energy
    = energy dissipated in both films - drift work, within 1 % of the dissipated energy (the audit of
    solver.study.energy; the small end alone closes to ~1e-3); both films dissipate."""
    case_dir = make_case(
        tmp_path / "both",
        'joint = "short-bearing"\nmax_cycles = 1\nstep_deg = 1\n',
        'joint = "short-bearing"\n',
    )
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    audit, dissipated = energy_balance(ds)[0], float(ds.dissipated_energy[-1])
    print(f"audit {audit:.3g} of the dissipated energy {dissipated:.4g} J")
    assert abs(audit) < 0.01
    # the stage integral holds both films: it exceeds each one's output quadrature (trapezoid) alone
    t = ds.time.values
    small, big = (
        float(np.trapz(ds[name].values, t)) for name in ("dissipated_power", "big_end_dissipated_power")
    )
    assert small > 0 and big > 0
    assert dissipated == pytest.approx(small + big, rel=0.02)
    assert math.isfinite(summary.h_min_min) and math.isfinite(summary.big_end_h_min_min)


@pytest.mark.serial
def test_stated_ideal_big_end_gives_the_same_answers(tmp_path):
    """The reference engine with the short-bearing small end, with and without ``[big_end] joint =
    "ideal"``: every variable of results.nc the same to the bit (the default is the ideal big end)."""
    solver = 'joint = "short-bearing"\nmax_cycles = 1\nstep_deg = 5\n'
    runs = []
    for name, big_end in (("plain", ""), ("stated", 'joint = "ideal"\n')):
        summary = run_case(make_case(tmp_path / name, solver, big_end), MPI.COMM_SELF)
        with xr.open_dataset(summary.results) as ds:
            runs.append(ds.load())
    plain, stated = runs
    assert stated.attrs["big_end.joint"] == "ideal"
    for name in plain.data_vars:
        np.testing.assert_array_equal(stated[name].values, plain[name].values, err_msg=name)
    # the ideal big end's force on the rod is reported: the crankpin's reaction
    assert np.all(np.isfinite(plain.big_end_force_x.values)) and np.all(np.isnan(plain.big_end_h_min.values))


@pytest.mark.parametrize(
    ("keys", "field"),
    [
        ('joint = "mixed"\n', "big_end.joint"),
        ("clearance_um = 25000\n", "big_end.clearance_um"),
        ("width_mm = -1\n", "big_end.width_mm"),
        ("radius = 24\n", "big_end.radius"),
    ],
)
def test_bad_big_end_keys_are_one_line_errors(tmp_path, keys, field):
    """A wrong [big_end] value: an InputError of one line naming the key (and its allowed range)."""
    case_dir = make_case(tmp_path / "bad", 'joint = "ideal"\n', keys)
    with pytest.raises(InputError) as error:
        load_case(case_dir)
    text = str(error.value)
    assert field in text and "\n" not in text


@pytest.mark.serial
def test_batch_summary_carries_the_big_ends_metrics(tmp_path):
    """``batch`` over a case with a lubricated big end and one with an ideal big end (both small ends
    short bearings, one cycle): summary.nc's ``big_end_h_min_min``, ``big_end_p_max_max`` and
    ``big_end_friction_power_mean`` are the results' own cycle minimum, maximum and trapezoidal cycle
    mean (1e-12), NaN for the ideal big end; the batch record of the lubricated one has them too."""
    import json

    solver = 'joint = "short-bearing"\nmax_cycles = 1\nstep_deg = 5\n'
    lubricated = make_case(tmp_path / "a", solver, 'joint = "short-bearing"\n')
    ideal = make_case(tmp_path / "b", solver, "")
    proc = run_cli("batch", str(lubricated), str(ideal), "--output", str(tmp_path / "batch"))
    assert proc.returncode == 0, proc.stderr
    with (
        xr.open_dataset(tmp_path / "batch" / "summary.nc") as summary,
        xr.open_dataset(lubricated / "results" / "results.nc") as ds,
    ):
        angle = ds.crank_angle.values
        expected = {
            "big_end_h_min_min": np.nanmin(ds.big_end_h_min.values),
            "big_end_p_max_max": np.nanmax(ds.big_end_p_max.values),
            "big_end_F_asperity_max": np.nanmax(ds.big_end_F_asperity.values),  # (a smooth film: 0)
            "big_end_friction_power_mean": np.trapz(ds.big_end_friction_power.values, angle)
            / (angle[-1] - angle[0]),
        }
        for name, value in expected.items():
            assert float(summary[name].values[0]) == pytest.approx(value, rel=1e-12, abs=1e-300), name
            assert math.isnan(float(summary[name].values[1])), name
    record = json.loads((tmp_path / "batch" / "batch_status.json").read_text())["cases"][0]
    assert record["metrics"]["big_end_h_min_min"] == pytest.approx(expected["big_end_h_min_min"], rel=1e-12)
    # compare: the same three numbers per run, and the big end's line in its table
    proc = run_cli("compare", str(lubricated), str(ideal), "--json")
    assert proc.returncode == 0, proc.stderr
    rows = json.loads(proc.stdout)["runs"]
    assert [r["big_end_joint"] for r in rows] == ["short-bearing", "ideal"]
    for key, name in (
        ("big_end_h_min_min_m", "big_end_h_min_min"),
        ("big_end_p_max_max_Pa", "big_end_p_max_max"),
        ("big_end_F_asperity_max_N", "big_end_F_asperity_max"),
        ("big_end_friction_power_mean_W", "big_end_friction_power_mean"),
    ):
        assert rows[0][key] == pytest.approx(expected[name], rel=1e-12, abs=1e-300), key
        assert rows[1][key] is None or math.isnan(rows[1][key]), key
    table = run_cli("compare", str(lubricated), str(ideal)).stdout
    assert table.count("big end short-bearing: min h_min") == 1
    # the plot gains the big end's panels: its force on the rod for both runs (the ideal one's reaction)
    from solver.cli.compare import BIG_END_PANELS, _panel_values, plot

    with (
        xr.open_dataset(lubricated / "results" / "results.nc") as a,
        xr.open_dataset(ideal / "results" / "results.nc") as b,
    ):
        force = _panel_values(b, "big_end_force")
        assert np.allclose(force, np.hypot(b.big_end_force_x.values, b.big_end_force_y.values), rtol=1e-15)
        assert all(_panel_values(a, name) is not None for name, _, _ in BIG_END_PANELS)
        plot({"a": a, "b": b}, tmp_path / "compare.png")
    assert (tmp_path / "compare.png").stat().st_size > 0


def test_the_periodic_test_follows_every_lubricated_joint(tmp_path):
    """Small end and big end short bearings, 5 deg outputs, until periodic (at most 4 cycles): the
    results' ``history.big_end_h_min_min`` holds each cycle's minimum of the big end's film thickness
    (the last cycle's equals the results' own, 1e-12), and the run is called periodic only when the big
    end's last change is below ``periodic_tolerance`` x its own clearance, as the small end's."""
    case_dir = make_case(
        tmp_path / "both",
        'joint = "short-bearing"\nmax_cycles = 4\nstep_deg = 5\nperiodic_tolerance = 1e-4\n'
        "field_step_deg = 0\nfield_angles_deg = []\n",
        'joint = "short-bearing"\n',
    )
    summary = run_case(case_dir, MPI.COMM_SELF)
    case = load_case(case_dir)
    with xr.open_dataset(summary.results) as ds:
        big = np.asarray(ds.attrs["history.big_end_h_min_min"], dtype=float)
        small = np.asarray(ds.attrs["history.h_min_min"], dtype=float)
        assert len(big) == len(small) == summary.cycles
        assert big[-1] == pytest.approx(float(ds.big_end_h_min.min()), rel=1e-12)
    assert summary.periodic
    tolerance = case.solver.periodic_tolerance
    assert abs(big[-1] - big[-2]) < tolerance * case.big_end.clearance
    assert abs(small[-1] - small[-2]) < tolerance * case.small_end.clearance


def test_a_checkpoint_keeps_the_other_joints_histories(tmp_path):
    """The checkpoint's ``joint_histories`` (the big end's and the bosses' cycle minima of h_min) are
    read back as written (exactly), and an older checkpoint without them reads as none."""
    from solver.study import io

    checkpoint = io.Checkpoint(
        fingerprint="f",
        cycles=2,
        t=0.1,
        q=np.zeros(3),
        qd=np.zeros(3),
        h_min_history=[3e-7, 3.1e-7],
        friction_history=[2.0, 2.1],
        timings=[],
        joint_histories={"big_end": [1.6e-6, 1.61e-6], "pin_boss": [1.07e-6, 1.071e-6]},
    )
    path = tmp_path / "checkpoint.npz"
    io.write_checkpoint(path, checkpoint)
    back = io.read_checkpoint(path, "f")
    assert back.joint_histories == checkpoint.joint_histories
    with np.load(path) as data:  # the same file without the key: a checkpoint of the code before
        older = {key: data[key] for key in data.files if key != "joint_histories"}
    np.savez(path, **older)
    assert io.read_checkpoint(path, "f").joint_histories == {}
