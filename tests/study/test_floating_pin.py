"""The full-floating piston pin (``small_end.pin = "floating"``): a body of its own between the small end's
film and the piston bosses' film (DESIGN 9), both short bearings here.

References:

- the fixed pin as the limit of a boss film that holds the pin (its viscosity x10 at each step): the
  small end's orbit and h_min approach the fixed-pin run's, the pin's speed falls as 1/viscosity;
- equal films (same geometry and oil in the small end and the bosses), a pin of negligible inertia: the pin
  turns at about the mean of the rod's and the piston's angular speeds (the piston's is zero), and exactly
  at the speed where the two films' closed-form torques balance (Couette ``mu R^3 B omega 2 pi / (c
  sqrt(1 - eps^2))`` and the pressure part ``-(e x F) / 2``: Hamrock, Fundamentals of Fluid Film
  Lubrication, ch. 16), with the outputs' eccentricities and forces;
- the moment balance on the pin ``J_pin dphi'/dt = T_small_end + T_boss`` between outputs (its trapezoidal
  quadrature at second order in the output step), and the energy audit of the cycle with both films;
- a stated fixed pin gives the answers of the case without the keys; bad keys are one-line errors.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.case import load_case
from solver.errors import InputError
from solver.study.simulation import run_case
from tests.conftest import energy_balance, run_cli

RPM = 2 * math.pi / 60


def make_case(directory: Path, solver: str, sections: str = "") -> Path:
    """A case of the reference engine (the defaults) with ``sections`` (TOML text) and a [solver] section
    with the short-bearing small end and ``solver`` keys."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "case.toml").write_text(
        f'name = "{directory.name}"\n{sections}\n[solver]\njoint = "short-bearing"\n{solver}'
    )
    return directory


def run(directory: Path) -> xr.Dataset:
    """Run the case; its results.nc loaded."""
    summary = run_case(directory, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        return ds.load()


def orbit_difference(ds: xr.Dataset, reference: xr.Dataset) -> tuple[float, float]:
    """(max |e - e_ref|, max |h_min - h_min_ref|) of the small end over the cycle, over its clearance."""
    c = float(ds.attrs["small_end.clearance_um"]) * 1e-6
    orbit = np.hypot(ds.ecc_x - reference.ecc_x, ds.ecc_y - reference.ecc_y).max()
    return float(orbit) / c, float(np.abs(ds.h_min - reference.h_min).max()) / c


@pytest.mark.slow
@pytest.mark.serial
def test_a_boss_film_that_holds_the_pin_gives_the_fixed_pin(tmp_path):
    """The boss viscosity x1, x10, x100, x1000 (one cycle from the centred start, 2 deg outputs): the small
    end's orbit and h_min approach the fixed-pin run's at every step; the pin's largest speed falls as
    1/viscosity once the boss holds it (x100 -> x1000: by 9.9, asserted > 8).

    Measured orbit differences 0.061, 0.018, 0.0020, 0.00045 of the clearance. The last is within the
    fixed-pin run's own integration error (the same run at rtol 1e-8 instead of 1e-6 moves its orbit by
    1.3e-3 and its h_min by 1.3e-3 of the clearance), hence the final tolerance 2e-3 on both; beyond
    x1000 the difference stays at that level (x1e4: 3.4e-3), the integrator's tolerance."""
    solver = "max_cycles = 1\nstep_deg = 2\n"
    fixed = run(make_case(tmp_path / "fixed", solver))
    orbits, h_mins, speeds = [], [], []
    for ratio in (1, 10, 100, 1000):
        ds = run(
            make_case(
                tmp_path / f"boss-x{ratio}",
                solver,
                f'[small_end]\npin = "floating"\n[pin_boss]\nviscosity_ratio = {ratio}\n',
            )
        )
        orbit, h_min = orbit_difference(ds, fixed)
        orbits.append(orbit)
        h_mins.append(h_min)
        speeds.append(float(np.abs(ds.pin_speed).max()))
    print(f"orbit {orbits}, h_min {h_mins}, pin speed {speeds}")
    assert all(b < a for a, b in zip(orbits, orbits[1:]))
    assert h_mins[2] < h_mins[1] < h_mins[0]
    assert orbits[-1] < 2e-3 and h_mins[-1] < 2e-3
    assert orbits[0] > 10 * orbits[-1]  # the floating pin's orbit differs: the trend is not noise
    assert speeds[2] / speeds[3] > 8


@pytest.mark.serial
def test_equal_films_turn_the_pin_at_the_mean_of_rod_and_piston(tmp_path):
    """Small end and bosses the same film (R 10 mm, B 20 mm, c 10 um, the same oil; the bosses as one film
    of their total width, ``films = 1``), a pin of 1/1000 of
    the default inertia (time constant J / (C_se + C_boss) ~ 3e-5 s, 0.4 deg: the pin follows its torque
    balance), inertia loads only (gas.model = "none": eccentricities <= 0.32), one cycle at 2 deg (through
    ``run --json``).

    - The pin turns at about half the rod's speed: rms(omega_pin - omega_rod / 2) from 30 deg on is within
      6 % of rms(omega_rod / 2) (measured 4.0 %), and its cycle mean within 2 % of max |omega_rod / 2|
      (measured 0.8 %, 2.5 rpm). Not closer because the films differ: the pin's eccentricities in the rod's
      eye and in the bosses are not the same (up to 0.32 and 0.26: their Couette coefficients differ by up
      to 1 %), and the pressure torques -(e x F)/2 of the two films, which carry the same load, add on the
      pin rather than cancel.
    - With both accounted for by the closed forms (module docstring, with the outputs' e and F), the pin's
      speed is the speed that balances them: rms difference within 1 % of rms(omega_rod / 2) (measured
      0.63 %; the rest is the pin's inertia, the films' quadrature on 1440 points and the output sampling).
    - ``run --json`` and ``compare --json`` give the pin's mean speed and the bosses' metrics as the results'
      own reductions (1e-12)."""
    case_dir = make_case(
        tmp_path / "equal",
        "max_cycles = 1\nstep_deg = 2\n",
        '[gas]\nmodel = "none"\n[small_end]\npin = "floating"\npin_inertia_kg_mm2 = 0.00736\n'
        "[pin_boss]\nradius_mm = 10\nwidth_mm = 20\nclearance_um = 10\nfilms = 1\n",
    )
    proc = run_cli("run", str(case_dir), "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    with xr.open_dataset(case_dir / "results" / "results.nc") as ds:
        ds = ds.load()
    w = ds.pin_speed.values
    rod = w - ds.omega_rel.values  # omega_rel: pin less rod
    half = 0.5 * rod
    later = ds.crank_angle.values >= 30

    def rms(x):
        return float(np.sqrt(np.mean(np.square(x))))

    mean = (ds.pin_angle.values[-1] - ds.pin_angle.values[0]) / (ds.time.values[-1] - ds.time.values[0])
    assert report["pin_speed_mean_rpm"] == pytest.approx(mean / RPM, rel=1e-12)
    assert report["pin_boss_h_min_min_m"] == pytest.approx(float(ds.pin_boss_h_min.min()), rel=1e-12)
    assert report["pin_boss_p_max_max_Pa"] == pytest.approx(float(ds.pin_boss_p_max.max()), rel=1e-12)
    angle = ds.crank_angle.values
    boss_friction = np.trapz(ds.pin_boss_friction_power.values, angle) / (angle[-1] - angle[0])
    assert report["pin_boss_friction_power_mean_W"] == pytest.approx(boss_friction, rel=1e-12)
    rod_mean = np.trapz(rod, ds.time.values) / (ds.time.values[-1] - ds.time.values[0])
    print(f"rms {rms((w - half)[later]) / rms(half):.4f}, mean {mean:.4g} rad/s, rod mean {rod_mean:.3g}")
    assert rms((w - half)[later]) < 0.06 * rms(half)
    assert abs(mean - 0.5 * rod_mean) < 0.02 * np.max(np.abs(half))
    # the closed-form balance of the two films' torques on the pin
    mu = float(ds.attrs["oil.viscosity_Pa_s"])
    R, B, c = 10e-3, 20e-3, 10e-6
    phi = ds.rod_angle.values
    ex, ey = ds.ecc_x.values, ds.ecc_y.values  # rod frame
    e_small = np.array([np.cos(phi) * ex - np.sin(phi) * ey, np.sin(phi) * ex + np.cos(phi) * ey])
    F_small = -np.array([ds.pin_force_x.values, ds.pin_force_y.values])  # rod on pin
    e_boss = np.array([ds.pin_boss_ecc_x.values, ds.pin_boss_ecc_y.values])  # piston frame = global
    F_boss = -np.array([ds.pin_boss_force_x.values, ds.pin_boss_force_y.values])  # piston on pin

    def couette(e):
        return mu * R**3 * B * 2 * math.pi / (c * np.sqrt(1 - (np.hypot(*e) / c) ** 2))

    def pressure(e, F):
        return -0.5 * (e[0] * F[1] - e[1] * F[0])

    C_small, C_boss = couette(e_small), couette(e_boss)
    # the torques reported are these closed forms (to the 1440-point quadrature: round-off here)
    T_small = -C_small * ds.omega_rel.values + pressure(e_small, F_small)
    assert np.allclose(ds.pin_torque_small_end.values, T_small, rtol=0, atol=1e-9 * np.abs(T_small).max())
    balance = (C_small * rod + pressure(e_small, F_small) + pressure(e_boss, F_boss)) / (C_small + C_boss)
    print(f"closed-form balance: rms {rms((w - balance)[later]) / rms(half):.4f}")
    assert rms((w - balance)[later]) < 0.01 * rms(half)
    # compare: the pin's mean speed and the bosses' film, as the results' own reductions
    proc = run_cli("compare", str(case_dir), "--json")
    assert proc.returncode == 0, proc.stderr
    row = json.loads(proc.stdout)["runs"][0]
    assert row["pin"] == "floating"
    assert row["pin_speed_mean_rpm"] == pytest.approx(mean / RPM, rel=1e-12)
    assert row["pin_boss_h_min_min_m"] == pytest.approx(float(ds.pin_boss_h_min.min()), rel=1e-12)
    assert row["pin_boss_p_max_max_Pa"] == pytest.approx(float(ds.pin_boss_p_max.max()), rel=1e-12)
    angle = ds.crank_angle.values
    friction = np.trapz(ds.pin_boss_friction_power.values, angle) / (angle[-1] - angle[0])
    assert row["pin_boss_friction_power_mean_W"] == pytest.approx(friction, rel=1e-12)
    assert run_cli("compare", str(case_dir)).stdout.count("floating pin: mean speed") == 1


def test_two_boss_films_carry_a_quarter_of_one_whole_width_film():
    """The bosses as two films of half the total width (``pin_boss.films = 2``, the default) against one
    film of the total width, at one state (eps 0.7 with squeeze and rotation): Ocvirk's force goes as
    B^3, so 2 (B/2)^3 = B^3 / 4 of the force; the Couette torque as B (the same), the side flow as B (the
    same), the peak pressure as B^2 (a quarter: each film's own). 1e-12: the same quadrature."""
    from pathlib import Path

    from solver.case import Case, PinBoss, SmallEnd
    from solver.dynamics.joint import pin_boss_joint_from_case

    def joint(films):
        case = Case(
            name="boss",
            directory=Path("."),
            small_end=SmallEnd(pin="floating"),
            pin_boss=PinBoss(films=films),
        )
        return pin_boss_joint_from_case(case)

    one, two = joint(1), joint(2)
    assert two.width == pytest.approx(one.width / 2, rel=1e-15) and two.films == 2
    state = ((0.0, -7e-6), (1e-4, -2e-3), 150.0)
    f1, f2 = one.forces(*state, 0.0), two.forces(*state, 0.0)
    assert np.allclose(f2.force, f1.force / 4, rtol=1e-12, atol=0)
    w = state[2]
    couette1 = (f1.bushing_torque - f1.journal_torque) / 2  # the pressure moments cancel
    couette2 = (f2.bushing_torque - f2.journal_torque) / 2
    assert couette2 == pytest.approx(couette1, rel=1e-12) and couette1 * w > 0
    assert two.side_flow(*state) == pytest.approx(one.side_flow(*state), rel=1e-12)
    assert two.peak_pressure(*state)[0] == pytest.approx(one.peak_pressure(*state)[0] / 4, rel=1e-9)


@pytest.mark.serial
def test_moment_balance_on_the_pin_and_the_energy_audit(tmp_path):
    """The reference engine (firing) with a floating pin of the default inertia, one cycle at 2 and 1 deg:

    - between outputs ``J (omega_(k+1) - omega_k) = int T_net dt``: the trapezoidal rule of pin_torque_net
      on the outputs, summed from the cycle's start, misses J (omega - omega_0) by 4.3e-3 (2 deg) and
      5.7e-4 (1 deg) of its largest value: asserted < 1e-3 at 1 deg and falling at least 3x on halving
      the step (second order: 4x; the residual is the quadrature's, where the torque varies within a
      degree near firing);
    - the energy audit (solver.study.energy) with both films at 1 deg: input work - change of mechanical
      energy (the pin's rotation included) = dissipated energy (small end + bosses) - drift work within
      1 % of the dissipated energy (measured 9e-4 at 2 deg); both films dissipate, and the stage integral
      is their output quadratures' sum to 2 %."""
    sections = '[small_end]\npin = "floating"\n'
    errors = []
    for step in (2, 1):
        ds = run(make_case(tmp_path / f"step{step}", f"max_cycles = 1\nstep_deg = {step}\n", sections))
        J = float(ds.attrs["small_end.pin_inertia_kg_mm2"]) * 1e-6
        assert J == pytest.approx(7.36e-6)
        t, w, T = ds.time.values, ds.pin_speed.values, ds.pin_torque_net.values
        assert np.allclose(T, ds.pin_torque_small_end.values + ds.pin_torque_boss.values, rtol=0, atol=1e-15)
        momentum = J * (w - w[0])
        impulse = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (T[1:] + T[:-1]))])
        errors.append(float(np.max(np.abs(momentum - impulse)) / np.max(np.abs(momentum))))
    print(f"moment balance residual {errors}")
    assert errors[1] < 1e-3
    assert errors[0] > 3 * errors[1]
    # the energy audit of the 1 deg run
    audit, dissipated = energy_balance(ds)[0], float(ds.dissipated_energy[-1])
    print(f"audit {audit:.3g} of the dissipated energy {dissipated:.4g} J")
    assert abs(audit) < 0.01
    small, boss = (
        float(np.trapz(ds[name].values, t)) for name in ("dissipated_power", "pin_boss_dissipated_power")
    )
    assert small > 0 and boss > 0
    assert dissipated == pytest.approx(small + boss, rel=0.02)
    # the boss's reported h_min is its rigid gap, and the pin's angle is the integral of its speed
    c_boss = float(ds.attrs["pin_boss.clearance_um"]) * 1e-6
    gap = c_boss - np.hypot(ds.pin_boss_ecc_x.values, ds.pin_boss_ecc_y.values)
    assert np.allclose(ds.pin_boss_h_min.values, gap, rtol=0, atol=1e-12)
    turned = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (w[1:] + w[:-1]))])
    assert np.max(np.abs(ds.pin_angle.values - ds.pin_angle.values[0] - turned)) < 1e-3 * np.max(
        np.abs(turned)
    )


@pytest.mark.serial
def test_stated_fixed_pin_gives_the_same_answers(tmp_path):
    """The short-bearing reference engine with and without ``small_end.pin = "fixed"`` and a [pin_boss]
    section: every variable of results.nc the same to the bit (a fixed pin ignores the bosses), the pin's
    variables NaN."""
    solver = "max_cycles = 1\nstep_deg = 5\n"
    plain = run(make_case(tmp_path / "plain", solver))
    stated = run(
        make_case(
            tmp_path / "stated",
            solver,
            '[small_end]\npin = "fixed"\npin_mass_g = 90\n[pin_boss]\nwidth_mm = 25\nviscosity_ratio = 3\n',
        )
    )
    assert stated.attrs["small_end.pin"] == "fixed"
    for name in plain.data_vars:
        np.testing.assert_array_equal(stated[name].values, plain[name].values, err_msg=name)
    for name in ("pin_speed", "pin_torque_net", "pin_boss_h_min", "pin_boss_force_x"):
        assert np.all(np.isnan(plain[name].values)), name


@pytest.mark.parametrize(
    ("sections", "field"),
    [
        ('[small_end]\npin = "loose"\n', "small_end.pin"),
        ('[small_end]\npin = "floating"\npin_mass_g = 450\n', "small_end.pin_mass_g"),
        ("[small_end]\npin_inertia_kg_mm2 = -1\n", "small_end.pin_inertia_kg_mm2"),
        ('[small_end]\npin = "floating"\n[pin_boss]\njoint = "ideal"\n', "pin_boss.joint"),
        ('[pin_boss]\njoint = "dry"\n', "pin_boss.joint"),
        ("[pin_boss]\nwidth_mm = -1\n", "pin_boss.width_mm"),
        ("[pin_boss]\nfilms = 3\n", "pin_boss.films"),
        ("[pin_boss]\nclearance_um = 25000\n", "pin_boss.clearance_um"),
        ("[pin_boss]\nradius = 10\n", "pin_boss.radius"),
        ("[pin_boss]\nviscosity_ratio = 0\n", "pin_boss.viscosity_ratio"),
    ],
)
def test_bad_floating_pin_keys_are_one_line_errors(tmp_path, sections, field):
    """A wrong floating-pin value or combination: an InputError of one line naming the key (and its
    allowed range); a pin as heavy as the piston assembly (0.45 kg) is refused."""
    with pytest.raises(InputError) as error:
        load_case(make_case(tmp_path / "bad", "", sections))
    text = str(error.value)
    assert field in text and "\n" not in text


@pytest.mark.parametrize(
    ("sections", "options", "field"),
    [
        ('[small_end]\npin = "floating"\n', ("--joint", "ideal"), "small_end.pin"),
        ('[small_end]\npin = "floating"\n[oil]\ngrade = "5W-30"\nthermal = "effective"\n', (), "oil.thermal"),
    ],
)
def test_floating_pin_combinations_refused_by_run(tmp_path, sections, options, field):
    """``run`` refuses a floating pin with an ideal small end (the pin turns in the small end's film) and
    with the effective film temperature (the small end's film alone): exit 2, one line naming the key."""
    case_dir = make_case(tmp_path / "bad", "max_cycles = 1\n", sections)
    proc = run_cli("run", str(case_dir), *options)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0] and "Traceback" not in proc.stderr


@pytest.mark.serial
def test_batch_summary_carries_the_pins_metrics(tmp_path):
    """``batch`` over a floating-pin case and a fixed-pin one (short-bearing small ends, inertia loads, one
    cycle at 5 deg): summary.nc's ``pin_boss_h_min_min`` and ``pin_speed_mean`` are the results' own cycle
    minimum and turn over the cycle's duration (1e-12), NaN for the fixed pin; the batch record has them
    too."""
    solver = "max_cycles = 1\nstep_deg = 5\n"
    floating = make_case(tmp_path / "a", solver, '[gas]\nmodel = "none"\n[small_end]\npin = "floating"\n')
    fixed = make_case(tmp_path / "b", solver, '[gas]\nmodel = "none"\n')
    proc = run_cli("batch", str(floating), str(fixed), "--output", str(tmp_path / "batch"))
    assert proc.returncode == 0, proc.stderr
    with (
        xr.open_dataset(tmp_path / "batch" / "summary.nc") as summary,
        xr.open_dataset(floating / "results" / "results.nc") as ds,
    ):
        t, angle = ds.time.values, ds.pin_angle.values
        expected = {
            "pin_boss_h_min_min": float(np.nanmin(ds.pin_boss_h_min.values)),
            "pin_speed_mean": float((angle[-1] - angle[0]) / (t[-1] - t[0])),
        }
        for name, value in expected.items():
            assert float(summary[name].values[0]) == pytest.approx(value, rel=1e-12), name
            assert math.isnan(float(summary[name].values[1])), name
    record = json.loads((tmp_path / "batch" / "batch_status.json").read_text())["cases"][0]
    assert record["metrics"]["pin_speed_mean"] == pytest.approx(expected["pin_speed_mean"], rel=1e-12)


@pytest.mark.slow
@pytest.mark.serial
def test_an_interrupted_floating_pin_run_resumes_to_the_same_answers(tmp_path, monkeypatch):
    """The reference engine with the floating pin (both films short bearings, 5 deg outputs, three cycles:
    the periodic tolerance 1e-12 is never met), run straight and stopped at the start of the second cycle
    then resumed from its checkpoint (the pin's position, angle and speed in the state, the bosses' cycle
    minima of h_min for the periodic test): the same last cycle, exactly (pin speed and angle, both
    films' eccentricities, the bosses' h_min history)."""
    from tests.conftest import interrupt_and_resume

    solver = "max_cycles = 3\nstep_deg = 5\nperiodic_tolerance = 1e-12\n"
    sections = '[small_end]\npin = "floating"\n'
    straight = run_case(make_case(tmp_path / "straight", solver, sections), MPI.COMM_SELF)
    resumed = interrupt_and_resume(make_case(tmp_path / "resumed", solver, sections), monkeypatch, 1)
    assert straight.cycles == resumed.cycles == 3
    with xr.open_dataset(straight.results) as a, xr.open_dataset(resumed.results) as b:
        for name in ("pin_speed", "pin_angle", "ecc_x", "ecc_y", "pin_boss_ecc_x", "pin_boss_ecc_y"):
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
        np.testing.assert_array_equal(
            np.asarray(a.attrs["history.pin_boss_h_min_min"]),
            np.asarray(b.attrs["history.pin_boss_h_min_min"]),
        )


@pytest.mark.slow
@pytest.mark.serial
def test_extrapolated_cycles_of_a_floating_pin_reach_the_plain_periodic_state(tmp_path):
    """The floating pin (both films short bearings, 5 deg outputs) to periodic, plainly and with the cycle
    map's extrapolation (``solver.periodic_acceleration = "mpe"``; the map's state holds the pin's speed,
    not its turning angle): both periodic, at the same state within the periodic test's tolerances (min
    h_min of the small end and the bosses within 2 x periodic_tolerance x their clearances, the friction
    within 1 % (the run's own test: 0.1 % a cycle), the pin's mean speed within 1 rpm: it settles with the
    friction); tolerances tightened (2e-5 of the clearance) so that the runs take enough cycles for the
    extrapolation to act."""
    solver = "max_cycles = 10\nstep_deg = 5\nperiodic_tolerance = 2e-5\nperiodic_friction_tolerance = 0.001\n"
    sections = '[small_end]\npin = "floating"\n'
    plain = run_case(make_case(tmp_path / "plain", solver, sections), MPI.COMM_SELF)
    mpe = run_case(
        make_case(tmp_path / "mpe", solver + 'periodic_acceleration = "mpe"\n', sections), MPI.COMM_SELF
    )
    case = load_case(tmp_path / "plain")
    print(f"cycles plain {plain.cycles}, mpe {mpe.cycles}")
    assert plain.periodic and mpe.periodic
    with xr.open_dataset(mpe.results) as ds:  # the extrapolation acted (a cycle started from it)
        assert np.max(np.asarray(ds.attrs["history.extrapolated_start"])) == 1
    tolerance = case.solver.periodic_tolerance
    assert abs(plain.h_min_min - mpe.h_min_min) < 2 * tolerance * case.small_end.clearance
    assert abs(plain.pin_boss_h_min_min - mpe.pin_boss_h_min_min) < 2 * tolerance * case.pin_boss.clearance
    assert mpe.friction_power_mean == pytest.approx(plain.friction_power_mean, rel=0.01)
    assert abs(plain.pin_speed_mean - mpe.pin_speed_mean) < 1.0 * RPM
