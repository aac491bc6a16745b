"""The big end as the finite-element film (``big_end.joint = "mixed-fem"``) or as dry contact (``"dry"``).

References:

- the FE big end's steady load capacity through the joint's ``forces`` against Butenschoen's finite
  bearing table (Sommerfeld number and attitude angle at B/D = 0.5, ../shared/data, as
  tests/film/test_bearing_tables.py);
- the mechanism's kinematics handed to the big end: the crankpin's eccentricity in the rod frame and
  ``omega_rel = omega_crank - omega_rod``, written here from the coordinates by hand;
- an engine cycle with both joints FE: the energy audit (input work = dissipation in both films +
  change of mechanical energy), and the big end's film force against the ideal big end's reaction (the
  ideal mechanism solved to round-off);
- the dry big end's contact force against the same reaction, with the shift its friction torque makes;
- bad keys: one-line errors naming the key.
"""

from __future__ import annotations

import csv
import math

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.case import load_case
from solver.dynamics.engine import CRANK, ROD, build_mechanism, engine_from_case, simulate_ideal
from solver.dynamics.joint import (
    FilmJoint,
    JournalFrameFilmJoint,
    _film_model,
    big_end_joint_from_case,
    crankpin_angle_to_rod,
)
from solver.dynamics.multibody import JointForces, rotation
from solver.errors import InputError
from solver.study.simulation import run_case
from tests.conftest import SHARED_DATA, energy_balance
from tests.study.test_big_end import make_case


def _butenschoen(ratio: float) -> list[dict[str, float]]:
    with open(SHARED_DATA / "butenschoen_rotation.csv") as f:
        rows = [line for line in f if not line.startswith("#")]
    table = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(rows)]
    return [row for row in table if row["width_to_diameter"] == ratio]


@pytest.mark.serial
def test_fe_big_end_load_capacity_matches_butenschoen(tmp_path):
    """The FE big end (crankpin 24 mm, width 24 mm: B/D = 0.5, the case's oil with the max-gap inlet
    the table assumes, the case's roughness and mesh 0.07 R), pure rotation at the crank speed, through
    the joint's ``forces``: So = F psi^2 / (B D eta omega) within 3 % of Butenschoen's for eps 0.1-0.9
    and the attitude within 2 deg for eps >= 0.4 (the tolerances of tests/film/test_bearing_tables.py;
    measured 0.5 %). Above eps 0.9 the gap (< 2.5 um) is within 8 sigma of the rough surfaces, whose flow
    factors and contact the smooth table does not have."""
    case_dir = make_case(
        tmp_path / "table",
        'joint = "ideal"\nmesh_size = 0.07\n',
        'joint = "mixed-fem"\nwidth_mm = 24.0\n',
    )
    text = (case_dir / "case.toml").read_text().replace('inlet = "none"', 'inlet = "max-gap"')
    (case_dir / "case.toml").write_text(text)
    case = load_case(case_dir)
    engine = engine_from_case(case)
    joint = big_end_joint_from_case(case, engine, MPI.COMM_SELF)
    assert isinstance(joint, FilmJoint)
    be, mu, omega = case.big_end, case.oil.viscosity, engine.crank_motion.speed
    c, R = be.clearance, be.radius
    direction = 2.2  # rad, off the mesh axes
    rows = [r for r in _butenschoen(0.5) if 0.1 <= r["eccentricity_ratio"] <= 0.9]
    assert len(rows) >= 9
    try:
        for row in rows:
            eps = row["eccentricity_ratio"]
            ecc = (eps * c * math.cos(direction), eps * c * math.sin(direction))
            forces = joint.forces(ecc, (0.0, 0.0), omega, 0.0)
            load = math.hypot(*forces.force)
            So = load * (c / R) ** 2 / (be.width * 2 * R * mu * omega)
            print(f"eps {eps}: So {So:.5g} table {row['So']:.5g} ({So / row['So'] - 1:+.2%})")
            assert So == pytest.approx(row["So"], rel=0.03), f"eps = {eps}"
            load_direction = math.atan2(-forces.force[1], -forces.force[0])
            attitude = abs((math.degrees(direction - load_direction) + 180) % 360 - 180)
            if eps >= 0.4:
                assert attitude == pytest.approx(row["beta_deg"], abs=2.0), f"eps = {eps}"
            # the journal turns against the bushing: the friction torque brakes it
            assert forces.journal_torque < 0
    finally:
        joint.model.close()


class _Recorder:
    """A clearance joint that records what the mechanism hands it and returns no force."""

    def __init__(self):
        self.calls = []

    def forces(self, ecc, ecc_rate, omega_rel, t, jacobian=False):
        self.calls.append((np.array(ecc, dtype=float), float(omega_rel)))
        return JointForces(np.zeros(2), 0.0, 0.0, np.zeros((4, 5)) if jacobian else None)

    def set_viscosity(self, viscosity):
        pass


@pytest.mark.serial
def test_big_end_gets_crankpin_in_rod_frame_and_crank_minus_rod_speed(tmp_path):
    """The big end's journal is the crankpin (crank point (r, 0)), its bushing the big eye (rod point
    (-l_g, 0)): the joint gets e' = A_rod^T (r_crankpin - r_eye) and omega_rel = omega_crank - omega_rod
    (to round-off), at a state off the ideal configuration."""
    case = load_case(make_case(tmp_path / "kinematics", 'joint = "ideal"\n'))
    engine = engine_from_case(case)
    recorder = _Recorder()
    em = build_mechanism(engine, None, recorder)
    t, q, qd = em.initial_state(0.7)
    rng = np.random.default_rng(3)
    q = q + 1e-5 * rng.standard_normal(q.size)
    qd = qd + rng.standard_normal(qd.size)
    em.mechanism.forces(q, qd, t)
    ecc, omega_rel = recorder.calls[-1]
    r, l_g = engine.crank_radius, engine.rod_cg_from_big_end
    crank_angle, rod_angle = q[3 * CRANK + 2], q[3 * ROD + 2]
    crankpin = q[3 * CRANK : 3 * CRANK + 2] + rotation(crank_angle) @ np.array([r, 0.0])
    eye = q[3 * ROD : 3 * ROD + 2] + rotation(rod_angle) @ np.array([-l_g, 0.0])
    np.testing.assert_allclose(ecc, rotation(rod_angle).T @ (crankpin - eye), rtol=0, atol=1e-15)
    assert omega_rel == pytest.approx(qd[3 * CRANK + 2] - qd[3 * ROD + 2], rel=1e-14)
    # the crankpin's frame relative to the rod's (its hole's turn): crank angle less the ideal rod angle
    ideal = simulate_ideal(engine, step_deg=10.0)
    phi = crankpin_angle_to_rod(engine)
    turn = np.array([phi(time) for time in ideal.time])
    np.testing.assert_allclose(turn, np.radians(ideal.crank_angle) - ideal.rod_angle, rtol=0, atol=1e-9)


@pytest.mark.serial
def test_crankpin_hole_solved_in_the_crankpin_frame_matches_the_hole_turned_into_the_rod_frame(tmp_path):
    """The big end with a hole in the crankpin (JournalFrameFilmJoint: the film in the crankpin's frame,
    the surfaces exchanged) against the rod-frame film of the small end's kind with the hole fixed where
    the crankpin's is at that time (angle + crank angle - rod angle): the Reynolds film is instantaneous,
    so both are the same film seen from two frames. Rotation, squeeze and a loaded state, with the
    rougher eye's shear flow: forces within 1e-3 of their size and the friction torques on crankpin and
    eye within 1e-3 (the two meshes are the same mesh turned: measured 1e-5), the supply flow within
    1 % (measured 3e-3), h_min's angle to 1e-9 deg; the Jacobian against central differences within
    1e-4 of each column's size (measured 2e-7)."""
    case_dir = make_case(
        tmp_path / "hole",
        'joint = "ideal"\nmesh_size = 0.1\n',
        'joint = "mixed-fem"\nsupply = "hole"\nsupply_pressure_bar = 3.0\nsupply_hole_angle_deg = 30.0\n',
    )
    case = load_case(case_dir)
    engine = engine_from_case(case)
    be = case.big_end
    joint = big_end_joint_from_case(case, engine, MPI.COMM_SELF)
    assert isinstance(joint, JournalFrameFilmJoint)
    t = 0.013  # s: the crankpin turned by 163 deg against the rod
    turn = crankpin_angle_to_rod(engine)(t)
    supply = {
        "supply_pressure": be.supply_pressure,
        "supply_hole_angle": math.remainder(be.supply_hole_angle + turn, 2 * math.pi),
        "supply_hole_diameter": be.supply_hole_diameter,
    }
    plain = FilmJoint(
        _film_model(
            case,
            engine,
            MPI.COMM_SELF,
            radius=be.radius,
            width=be.width,
            clearance=be.clearance,
            supply=supply,
            bushing=None,
        )
    )
    c, omega_rel = be.clearance, 180.0
    states = [
        ((0.5 * c, 0.3 * c), (0.0, 0.0)),
        ((-0.7 * c, 0.2 * c), (0.01, -0.02)),
        ((0.85 * c * math.cos(1.0), 0.85 * c * math.sin(1.0)), (0.003, 0.001)),
    ]
    try:
        for ecc, rate in states:
            a = joint.forces(ecc, rate, omega_rel, t)
            b = plain.forces(ecc, rate, omega_rel, t)
            size = np.hypot(*b.force)
            assert np.hypot(*(np.asarray(a.force) - b.force)) < 1e-3 * size
            assert a.journal_torque == pytest.approx(b.journal_torque, rel=1e-3)
            assert a.bushing_torque == pytest.approx(b.bushing_torque, rel=1e-3)
            out_a = joint.outputs(ecc, rate, omega_rel, t, a)
            out_b = plain.outputs(ecc, rate, omega_rel, t, b)
            assert out_a["supply_flow"] == pytest.approx(out_b["supply_flow"], rel=0.01)
            assert out_a["p_max"] == pytest.approx(out_b["p_max"], rel=1e-3)
            assert out_a["h_min_angle"] == pytest.approx(out_b["h_min_angle"], abs=1e-9)
        ecc, rate = np.array([0.6 * c, -0.3 * c]), np.array([0.004, 0.002])
        exact = joint.forces(ecc, rate, omega_rel, t, jacobian=True).jacobian
        z = np.concatenate([ecc, rate, [omega_rel]])
        steps = [1e-4 * c, 1e-4 * c, 1e-5, 1e-5, 1e-3]
        columns = []
        for k, step in enumerate(steps):
            values = []
            for sign in (1, -1):
                zk = z.copy()
                zk[k] += sign * step
                f = joint.forces(zk[:2], zk[2:4], zk[4], t)
                values.append(np.r_[f.force, f.journal_torque, f.bushing_torque])
            columns.append((values[0] - values[1]) / (2 * step))
        numeric = np.array(columns).T
        scale = np.max(np.abs(numeric), axis=0)
        assert np.all(np.max(np.abs(numeric - exact), axis=0) < 1e-4 * scale)
    finally:
        joint.model.close()
        plain.model.close()


@pytest.mark.serial
@pytest.mark.slow
@pytest.mark.parametrize("supply", ["none", "hole"])
def test_engine_cycle_with_both_joints_fe(tmp_path, supply):
    """Small end and big end both FE films (mesh 0.2 R, 5 deg outputs, one cycle from the centred start;
    the big end without a supply, or with the crankpin's hole at 3 bar): the energy audit closes within
    1 % of the energy dissipated in both films (measured 4e-4 and 2e-4); both films carry the load (their
    film forces reach 90 % of the ideal joints' peak); the big end's film force is the ideal big end's
    reaction within 1 % of its peak at every output after the start (the difference is the rod's and
    piston's inertia on the crankpin's orbit in its 25 um clearance, c / R = 1e-3: measured 2.5e-4; at
    0 deg the film of the centred start carries nothing)."""
    case_dir = make_case(
        tmp_path / "both-fe",
        'joint = "mixed-fem"\nmesh_size = 0.2\nmax_cycles = 1\nstep_deg = 5\nfield_step_deg = 0\n'
        "field_angles_deg = []\n",
        f'joint = "mixed-fem"\nsupply = "{supply}"\nsupply_pressure_bar = 3.0\n',
    )
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    audit, dissipated = energy_balance(ds)[0], float(ds.dissipated_energy[-1])
    print(f"audit {audit:.3g} of the dissipated energy {dissipated:.4g} J")
    assert abs(audit) < 0.01
    t = ds.time.values
    small, big = (
        float(np.trapz(ds[name].values, t)) for name in ("dissipated_power", "big_end_dissipated_power")
    )
    assert small > 0 and big > 0
    assert dissipated == pytest.approx(small + big, rel=0.02)
    case = load_case(case_dir)
    ideal = simulate_ideal(engine_from_case(case), step_deg=5.0)
    peak_big = np.max(np.hypot(*ideal.big_end_force.T))
    peak_small = np.max(np.hypot(ideal.pin_force_x, ideal.pin_force_y))
    assert np.nanmax(ds.big_end_F_hydro.values) > 0.9 * peak_big
    assert np.nanmax(ds.F_hydro.values) > 0.9 * peak_small
    film = np.column_stack([ds.big_end_force_x.values, ds.big_end_force_y.values])
    error = np.max(np.hypot(*(film - ideal.big_end_force)[1:].T)) / peak_big
    print(f"big end: max |F - F_ideal| / peak = {error:.3g}")
    assert error < 0.01
    # the FE big end's own variables are reported (the small end's names, prefixed)
    for name in ("big_end_p_max", "big_end_F_asperity", "big_end_cavitated_area_ratio", "big_end_h_min"):
        assert np.all(np.isfinite(ds[name].values)), name
    # the run's summary (run --json, batch): each joint's reductions of its own variables (1e-12)
    assert summary.big_end_h_min_min == pytest.approx(float(ds.big_end_h_min.min()), rel=1e-12)
    assert summary.big_end_p_max_max == pytest.approx(float(ds.big_end_p_max.max()), rel=1e-12)
    assert summary.big_end_F_asperity_max == pytest.approx(float(ds.big_end_F_asperity.max()), rel=1e-12)
    assert int(ds.attrs["big_end_film_dofs"]) > 0
    flow = ds.big_end_supply_flow.values
    if supply == "none":
        assert np.all(flow == 0.0)
    else:  # the hole feeds the film (and takes oil back where the loaded film passes over it)
        assert np.max(flow) > 0 and np.min(ds.big_end_p_max.values) >= 3e5 * (1 - 1e-9)


@pytest.mark.serial
@pytest.mark.slow
def test_engine_cycle_with_a_dry_big_end(tmp_path):
    """The dry big end (Hertz stiffness from [surface]'s moduli, Coulomb friction 0.1), small end short
    bearing, one cycle at 5 deg outputs: runs; the energy audit within 1 % (measured 8e-4); where in
    contact (penetration > 0) its force is the ideal reaction to within the shift of its friction torque:
    the torque mu R |F| on the rod moves the forces at its ends by up to mu R / l |F| (1.7 % of the load),
    so at the ideal reaction's peak |F - F_ideal| < (mu R / l + 1 %) of it (measured 2.0 % against 2.7 %),
    and over the contact outputs the median difference is below 1 % of the peak (measured 0.56 %; the soft
    contact's impacts at light load reach 5 %)."""
    case_dir = make_case(
        tmp_path / "dry", 'joint = "short-bearing"\nmax_cycles = 1\nstep_deg = 5\n', 'joint = "dry"\n'
    )
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    assert abs(energy_balance(ds)[0]) < 0.01
    case = load_case(case_dir)
    ideal = simulate_ideal(engine_from_case(case), step_deg=5.0)
    force = np.column_stack([ds.big_end_force_x.values, ds.big_end_force_y.values])
    magnitude = np.hypot(*ideal.big_end_force.T)
    error = np.hypot(*(force - ideal.big_end_force).T)
    contact = ds.big_end_h_min.values < 0
    k = int(np.argmax(magnitude))
    assert contact[k]
    shift = case.surface.asperity_friction * case.big_end.radius / case.engine.rod_length
    print(f"at the peak {error[k] / magnitude[k]:.3g} (bound {shift + 0.01:.3g})")
    assert error[k] < (shift + 0.01) * magnitude[k]
    assert np.median(error[contact]) < 0.01 * magnitude[k]
    # all of its force is contact: big_end_F_asperity is the force on the rod, no film
    np.testing.assert_allclose(ds.big_end_F_asperity.values, np.hypot(*force.T), rtol=1e-12)
    assert np.all(ds.big_end_F_hydro.values == 0.0)


HOLE = 'joint = "mixed-fem"\nsupply = "hole"\n'


@pytest.mark.parametrize(
    ("big_end", "oil", "field"),
    [
        ('joint = "short-bearing"\nelastic = "winkler"\n', "", "big_end.elastic"),
        ('joint = "short-bearing"\nelastic = "fe"\n', "", "big_end.elastic"),
        ('joint = "mixed-fem"\nelastic = "fe"\n', 'inlet = "max-gap"\n', "big_end.elastic"),
        (
            'joint = "mixed-fem"\nelastic = "fe"\neye_outer_radius_mm = 25.8\n',
            "",
            "big_end.eye_outer_radius_mm",
        ),
        (
            'joint = "mixed-fem"\nelastic = "fe"\ncompliance_grid_theta = 12\ncompliance_grid_z = 2\n'
            "compliance_modes = 25\n",
            "",
            "big_end.compliance_modes",
        ),
        (
            'joint = "mixed-fem"\nelastic = "fe"\nshank_half_angle_deg = 90\n',
            "",
            "big_end.shank_half_angle_deg",
        ),
        ('joint = "mixed-fem"\nelastic = "fe"\ncompliance_basis = "modal"\n', "", "big_end.compliance_basis"),
        ('joint = "mixed-fem"\nelastic = "fe"\nE_eye_GPa = 0\n', "", "big_end.E_eye_GPa"),
        ('joint = "mixed-fem"\nelastic = "winkler"\n', 'inlet = "max-gap"\n', "big_end.elastic"),
        (
            'joint = "mixed-fem"\nelastic = "winkler"\nbushing_thickness_mm = 30\n',
            "",
            "big_end.bushing_thickness_mm",
        ),
        (
            'joint = "mixed-fem"\n',
            'cavitation = "jfo"\ncavitation_pressure_bar = 0.0\ninlet = "hole"\n',
            "oil.cavitation_pressure_bar",
        ),
        ('joint = "hydro"\n', "", "big_end.joint"),
        ('joint = "short-bearing"\nsupply = "hole"\n', "", "big_end.supply"),
        (HOLE, 'inlet = "max-gap"\n', "big_end.supply"),
        (HOLE + "supply_hole_diameter_mm = 30\n", "", "big_end.supply_hole_diameter_mm"),
        (HOLE + "supply_pressure_bar = -1\n", "", "big_end.supply_pressure_bar"),
        ('joint = "mixed-fem"\nsupply = "groove"\n', "", "big_end.supply"),
    ],
)
def test_bad_big_end_film_keys_are_one_line_errors(tmp_path, big_end, oil, field):
    """An elastic big end (Winkler or the FE eye) without the FE film or with the max-gap inlet, a shell
    thicker than the crankpin's radius; an eye no thicker than the bore and its shell, more modes
    than the compliance grid's nodes, a clamp of 90 deg half angle or more, an unknown basis, a zero
    modulus; a JFO big end whose edges are sealed (cavitation pressure 0, no supply of its own: the small
    end's hole does not feed it); an unknown model, a crankpin hole without the FE film or with the
    max-gap inlet, too wide or below ambient, an unknown supply: an InputError of one line naming the
    key."""
    case_dir = make_case(tmp_path / "bad", 'joint = "ideal"\n', big_end)
    if oil:
        text = (case_dir / "case.toml").read_text()
        keys = [line.split("=")[0].strip() for line in oil.splitlines()]
        text = "\n".join(line for line in text.split("\n") if not any(line.startswith(k + " ") for k in keys))
        text = text.replace("[oil]\n", "[oil]\n" + oil, 1)
        (case_dir / "case.toml").write_text(text)
    with pytest.raises(InputError) as error:
        load_case(case_dir)
    text = str(error.value)
    assert field in text and "\n" not in text


class _TwoRanks:
    """A communicator's size as the film's rules read it (solver.film.factory checks before it builds)."""

    size = 2


def test_an_elastic_big_end_on_several_ranks_names_the_big_ends_key(tmp_path, monkeypatch):
    """The elastic film runs on one rank (solver.film_rules): a Winkler big end's film on two ranks is
    refused with one line naming big_end.elastic, not the small end's key (it did before); the big end's
    film specification names its joint (the rigid one passes that rule: its build is stopped after the
    check)."""
    winkler = load_case(
        make_case(tmp_path / "w", 'joint = "ideal"\n', 'joint = "mixed-fem"\nelastic = "winkler"\n')
    )
    with pytest.raises(InputError) as error:
        big_end_joint_from_case(winkler, comm=_TwoRanks())
    text = str(error.value)
    assert text.startswith("big_end.elastic = 'winkler'") and "serial P1 film" in text
    assert "small_end" not in text and "\n" not in text

    import solver.film.factory

    checked = []

    def check_only(spec, comm):
        spec.check(ranks=comm.size)
        checked.append(spec.joint)
        raise RuntimeError("checked")

    monkeypatch.setattr(solver.film.factory, "make_film", check_only)
    rigid = load_case(make_case(tmp_path / "r", 'joint = "ideal"\n', 'joint = "mixed-fem"\n'))
    with pytest.raises(RuntimeError, match="checked"):
        big_end_joint_from_case(rigid, comm=_TwoRanks())
    assert checked == ["big_end"]
