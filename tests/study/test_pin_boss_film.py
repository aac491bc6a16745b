"""The floating pin's bosses as a finite-element film (``pin_boss.joint = "mixed-fem"``) with its own surface
(``[pin_boss_surface]``).

References:

- Ocvirk's short bearing (solver.dynamics.joint.ShortBearingJoint) where it holds: narrow bosses (B/D = 1/8
  per film), smooth, the same kinematics (pure rotation, pure squeeze at eps 0.5); the short bearing leaves
  out the circumferential pressure flow and so overestimates the load by O((B/D)^2);
- two equal bosses are twice one boss (the same film solved once: exact);
- the energy audit of a floating-pin cycle with the finite-element boss (solver.study.energy);
- the case file itself for ``[pin_boss_surface]`` (a key given is its value, a key not given is
  ``[surface]``'s, typed in again here); bad keys and the refused JFO boss are one-line errors.
"""

from __future__ import annotations

import dataclasses
import math
import types
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.case import Case, Oil, PinBoss, PinBossSurface, SmallEnd, Solver, load_case
from solver.dynamics.joint import EqualFilmsJoint, FilmJoint, ShortBearingJoint, pin_boss_joint_from_case
from solver.errors import InputError
from solver.study.simulation import run_case
from tests.conftest import energy_balance, run_cli

C = 10e-6  # m, the bosses' clearance in these tests


def boss_case(joint: str, *, films: int = 2, width: float = 5e-3, mesh_size: float = 0.025, **oil) -> Case:
    """A floating pin of radius 10 mm in bosses of total ``width`` and clearance C, an all but smooth
    surface (sigma 1 nm: h / sigma >= 5000 at eps 0.5, no asperity contact, flow factors 1)."""
    return Case(
        name="boss",
        directory=Path("."),
        small_end=SmallEnd(pin="floating"),
        pin_boss=PinBoss(joint=joint, films=films, width=width, radius=10e-3, clearance=C),
        pin_boss_surface=PinBossSurface(sigma_pin=1e-9, sigma_bushing=1e-9),
        oil=Oil(**oil),
        solver=Solver(mesh_size=mesh_size),
    )


STATES = {  # (e', de'/dt, omega_rel) at eps 0.5
    "rotation": ((0.5 * C, 0.0), (0.0, 0.0), 300.0),
    "squeeze": ((0.0, -0.5 * C), (0.0, -0.5 * C * 300.0), 0.0),
}


@pytest.mark.serial
@pytest.mark.parametrize("kinematics", list(STATES))
def test_narrow_fe_bosses_approach_the_short_bearing_bosses(kinematics):
    """Two bosses of 2.5 mm on a pin of R 10 mm (B/D = 1/8 each), eps 0.5, the same oil: the FE film's force
    is within 3 % of Ocvirk's and below it, its journal torque within 0.1 %.

    The tolerance: the short bearing's own error at B/D = 1/8 (the converged FE film, mesh 0.0125 -> 0.00625
    R, sits 1.5 % (rotation) and 1.6 % (squeeze) below it; at B/D = 1/4, 5.4 and 6.0 %: the (B/D)^2 of the
    neglected circumferential flow; the closed-form squeeze of a finite bearing at eps -> 0, (1 - tanh(a)/a)
    / (a^2 / 3) with a = B/D, gives 0.7 % at 1/8) and the mesh's at 0.025 R (0.7 %): measured 2.2 and 2.3 %.
    The torque is the Couette shear's (the same integral in both) and the pressure moment's: measured 5e-5."""
    ecc, rate, omega = (np.asarray(v, dtype=float) if i < 2 else v for i, v in enumerate(STATES[kinematics]))
    fe = pin_boss_joint_from_case(boss_case("mixed-fem"))
    sb = pin_boss_joint_from_case(boss_case("short-bearing"))
    assert isinstance(fe, EqualFilmsJoint) and isinstance(sb, ShortBearingJoint)
    a, b = sb.forces(ecc, rate, omega, 0.0), fe.forces(ecc, rate, omega, 0.0)
    difference = np.linalg.norm(np.subtract(a.force, b.force)) / np.linalg.norm(a.force)
    shortfall = 1 - np.linalg.norm(b.force) / np.linalg.norm(a.force)
    print(f"{kinematics}: |F_fe - F_sb| / |F_sb| = {difference:.4f}, shortfall {shortfall:.4f}")
    assert difference < 0.03 and 0 < shortfall
    if omega:
        assert b.journal_torque == pytest.approx(a.journal_torque, rel=1e-3)
    # the outputs: h_min the rigid gap, p_max each film's own, F_hydro the force's magnitude
    out = fe.outputs(ecc, rate, omega, 0.0, b)
    assert out["h_min"] == pytest.approx(0.5 * C, rel=1e-12)
    assert out["F_hydro"] == pytest.approx(np.linalg.norm(b.force), rel=1e-9)
    assert out["F_asperity"] == 0.0
    assert out["p_max"] == pytest.approx(sb.peak_pressure(ecc, rate, omega)[0], rel=0.05)


@pytest.mark.serial
def test_two_equal_fe_bosses_are_twice_one():
    """``films = 2``: one film of half the total width (built as ``films = 1`` of that width gives the same
    film), its force, torques, Jacobian and summed outputs counted twice, its p_max and h_min its own (the
    same film solved once: 1e-12)."""
    two = pin_boss_joint_from_case(boss_case("mixed-fem", films=2, width=10e-3, mesh_size=0.1))
    one = pin_boss_joint_from_case(boss_case("mixed-fem", films=1, width=5e-3, mesh_size=0.1))
    assert isinstance(one, FilmJoint) and two.films == 2
    assert two.model.bearing.width == pytest.approx(5e-3, rel=1e-15) == one.model.bearing.width
    state = (np.array([0.3 * C, -0.4 * C]), np.array([0.2 * C * 300, 0.1 * C * 300]), -200.0)
    f2, f1 = two.forces(*state, 0.0, jacobian=True), one.forces(*state, 0.0, jacobian=True)
    assert np.allclose(f2.force, 2 * np.asarray(f1.force), rtol=1e-12, atol=0)
    assert f2.journal_torque == pytest.approx(2 * f1.journal_torque, rel=1e-12)
    assert f2.bushing_torque == pytest.approx(2 * f1.bushing_torque, rel=1e-12)
    assert np.allclose(
        f2.jacobian, 2 * np.asarray(f1.jacobian), rtol=1e-12, atol=1e-12 * np.abs(f1.jacobian).max()
    )
    o2, o1 = two.outputs(*state, 0.0, f2), one.outputs(*state, 0.0, f1)
    for name in ("F_hydro", "side_flow"):
        assert o2[name] == pytest.approx(2 * o1[name], rel=1e-12), name
    for name in ("p_max", "h_min", "cavitated_area_ratio"):
        assert o2[name] == pytest.approx(o1[name], rel=1e-12), name


SURFACE = (
    "[surface]\nsigma_pin_um = 0.1\nsigma_bushing_um = 0.4\nE_bushing_GPa = 100.0\nasperity_friction = 0.12\n"
)


def make_case(directory: Path, sections: str, solver: str = "", pin_boss: str = "") -> Path:
    """The reference engine with a floating pin in FE bosses (and ``pin_boss`` keys), ``sections`` (TOML)
    and [solver] keys."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "case.toml").write_text(
        f'name = "{directory.name}"\n[small_end]\npin = "floating"\n[pin_boss]\njoint = "mixed-fem"\n'
        f'{pin_boss}{sections}\n[solver]\njoint = "short-bearing"\n{solver}'
    )
    return directory


@pytest.fixture
def captured_specs(monkeypatch):
    """The FilmSpecs the film factory is asked for (no film built)."""
    specs = []

    def fake_make_film(spec, comm):
        specs.append(spec)
        return types.SimpleNamespace(spec=spec, has_history=False)

    monkeypatch.setattr("solver.film.factory.make_film", fake_make_film)
    return specs


@pytest.mark.serial
def test_the_boss_film_takes_the_pin_boss_surface_and_the_boss_oil(tmp_path, captured_specs):
    """Without [pin_boss_surface] the bosses' surface is [surface]'s (given and default keys); with it, a key
    given is its own, the others [surface]'s; the film takes its roughness and contact, the oil viscosity
    times pin_boss.viscosity_ratio, the bosses' radius, half width and clearance, a rigid bushing."""
    plain = load_case(make_case(tmp_path / "plain", SURFACE))
    assert dataclasses.asdict(plain.pin_boss_surface) == dataclasses.asdict(plain.surface)
    assert "pin_boss_surface" not in plain.defaulted
    case = load_case(
        make_case(
            tmp_path / "own",
            SURFACE + "[pin_boss_surface]\nsigma_bushing_um = 0.25\nasperity_friction = 0.08\n",
            pin_boss="viscosity_ratio = 2.5\nwidth_mm = 24\n",
        )
    )
    boss, surface = case.pin_boss_surface, case.surface
    assert (boss.sigma_bushing, boss.asperity_friction) == pytest.approx((0.25e-6, 0.08), rel=1e-15)
    assert (boss.sigma_pin, boss.E_bushing) == pytest.approx((0.1e-6, 100e9), rel=1e-15)
    assert (surface.sigma_bushing, surface.asperity_friction) == pytest.approx((0.4e-6, 0.12), rel=1e-15)
    assert case.pin_boss.viscosity_ratio == 2.5
    joint = pin_boss_joint_from_case(case, comm=object())
    (spec,) = captured_specs
    assert isinstance(joint, EqualFilmsJoint) and joint.films == 2
    assert (spec.roughness.sigma_journal, spec.roughness.sigma_bushing) == pytest.approx(
        (0.1e-6, 0.25e-6), rel=1e-15
    )
    assert spec.contact.sigma == pytest.approx(math.hypot(0.1e-6, 0.25e-6), rel=1e-15)
    bearing = spec.bearing
    assert bearing.viscosity == pytest.approx(2.5 * case.oil.viscosity, rel=1e-15)
    assert (bearing.radius, bearing.width, bearing.clearance) == pytest.approx(
        (case.pin_boss.radius, 12e-3, case.pin_boss.clearance), rel=1e-15
    )
    assert spec.bushing is None and bearing.supply is None and spec.joint == "pin_boss"


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        (
            "[pin_boss_surface]\nsigma_pin_um = -0.1\n",
            r"^pin_boss_surface.sigma_pin_um = -0.1 is out of range",
        ),
        ("[pin_boss_surface]\nnu_bushing = 0.7\n", r"^pin_boss_surface.nu_bushing = 0.7 is out of range"),
        ("[pin_boss_surface]\nsigma_pin = 0.1\n", r"unknown key pin_boss_surface.sigma_pin \(did you mean"),
        (
            '[oil]\ncavitation = "jfo"\ncavitation_pressure_bar = -0.5\n',
            r"^pin_boss.joint = \"mixed-fem\" with",
        ),
    ],
)
def test_bad_boss_surface_keys_and_the_jfo_boss_are_one_line_errors(tmp_path, sections, message):
    """One line naming pin_boss_surface.<key> (not surface.<key>); the FE boss with the JFO film refused."""
    with pytest.raises(InputError, match=message) as error:
        load_case(make_case(tmp_path / "bad", sections))
    assert "\n" not in str(error.value)


def test_the_jfo_boss_is_refused_by_run(tmp_path):
    """``run`` on the FE boss with the JFO film: exit 2, one line naming pin_boss.joint, no traceback."""
    case_dir = make_case(tmp_path / "jfo", '[oil]\ncavitation = "jfo"\ncavitation_pressure_bar = -0.5\n')
    proc = run_cli("run", str(case_dir))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "pin_boss.joint" in lines[0] and "Traceback" not in proc.stderr


@pytest.mark.slow
@pytest.mark.serial
def test_energy_audit_of_a_floating_pin_cycle_with_fe_bosses(tmp_path):
    """The reference engine (firing), a floating pin in FE bosses (the defaults: two of 15 mm, R 10 mm,
    c 10 um; coarse film 0.25 R), the short-bearing small end, one cycle at 1 deg: input work - change of
    mechanical energy = dissipated energy (small end + bosses) - drift work within 1 % of the dissipated
    energy (as tests/study/test_floating_pin.py's audit with the short-bearing bosses); both films dissipate
    and the stage integral is their output quadratures' sum to 2 %; the bosses' results are filled."""
    case_dir = make_case(tmp_path / "cycle", "", "max_cycles = 1\nstep_deg = 1\nmesh_size = 0.25\n")
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    assert ds.attrs["pin_boss.joint"] == "mixed-fem"
    assert ds.attrs["pin_boss_surface.sigma_pin_um"] == ds.attrs["surface.sigma_pin_um"]
    audit, _ = energy_balance(ds)  # over the dissipated energy
    dissipated = float(ds.dissipated_energy[-1])
    print(f"audit {audit:.3g} of the dissipated energy {dissipated:.4g} J")
    assert abs(audit) < 0.01
    t = ds.time.values
    small, boss = (
        float(np.trapz(ds[name].values, t)) for name in ("dissipated_power", "pin_boss_dissipated_power")
    )
    assert small > 0 and boss > 0
    assert dissipated == pytest.approx(small + boss, rel=0.02)
    for name in (
        "pin_boss_h_min",
        "pin_boss_p_max",
        "pin_boss_F_hydro",
        "pin_boss_F_asperity",
        "pin_boss_side_flow",
    ):
        assert np.all(np.isfinite(ds[name].values)), name
    assert float(ds.pin_boss_p_max.max()) > 0
