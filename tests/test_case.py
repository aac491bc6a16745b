"""Unit tests of solver.case: defaults = DESIGN 3.7 reference engine, units, validation messages."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from solver.case import (
    Case,
    Engine,
    Gas,
    SmallEnd,
    Solver,
    Surface,
    load_case,
)
from solver.dynamics.joint import surface_from_case
from solver.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def write_case(directory: Path, text: str) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "case.toml").write_text(text)
    return directory


def test_defaults_are_the_reference_engine_of_design_3_7(tmp_path):
    """The DESIGN 3.7 table, typed in again here, in SI."""
    case = load_case(write_case(tmp_path / "empty", ""))
    e, g, s, o, f = case.engine, case.gas, case.small_end, case.oil, case.surface
    assert case.name == "empty"
    assert (e.bore, e.crank_radius, e.rod_length) == pytest.approx((0.086, 0.043, 0.145))
    assert (e.rod_mass, e.rod_inertia, e.rod_cg_from_big_end) == pytest.approx((0.55, 2.2e-3, 0.035))
    assert (e.piston_mass, e.pin_offset) == pytest.approx((0.45, 0.0))
    assert e.speed == pytest.approx(2000.0 * 2.0 * math.pi / 60.0) and e.gravity is True
    assert g.model == "single-zone" and g.compression_ratio == 10.5 and g.peak_pressure == pytest.approx(6e6)
    assert g.imep is None and g.pressure_file is None
    assert (s.pin_radius, s.width, s.clearance) == pytest.approx((0.010, 0.020, 10e-6))
    assert o.viscosity == pytest.approx(0.010) and o.cavitation_pressure == 0.0
    assert (f.sigma_pin, f.sigma_bushing, f.peklenik_gamma) == pytest.approx((0.1e-6, 0.3e-6, 1.0))
    assert (f.eta_beta_sigma, f.sigma_over_beta, f.asperity_friction) == pytest.approx((0.05, 0.001, 0.1))
    assert (f.E_pin, f.nu_pin, f.E_bushing, f.nu_bushing) == pytest.approx((210e9, 0.3, 115e9, 0.33))
    # DESIGN 3.3: 1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2
    models = surface_from_case(f)  # the film's models of this section
    assert models.modulus == pytest.approx(1.0 / ((1 - 0.09) / 210e9 + (1 - 0.33**2) / 115e9), rel=1e-12)
    assert (
        models.sigma == pytest.approx(f.sigma, rel=1e-15) and models.asperity_friction == f.asperity_friction
    )
    assert f.sigma == pytest.approx(math.sqrt(0.1**2 + 0.3**2) * 1e-6)


def test_the_reference_case_directory_is_the_default_case():
    """cases/reference-2000rpm/case.toml spells out every default."""
    case = load_case(ROOT / "cases" / "reference-2000rpm")
    assert case.name == "reference-2000rpm"
    for section in ("engine", "gas", "small_end", "oil", "surface"):
        assert getattr(case, section) == type(getattr(case, section))(), section
    assert case.solver.step == pytest.approx(math.radians(1.0)) and case.solver.joint == "mixed-fem"


def test_units_are_converted_once(tmp_path):
    """Unit-suffixed keys become SI (rpm -> rad/s, mm -> m, bar -> Pa, deg -> rad, um -> m, GPa -> Pa)."""
    case = load_case(
        write_case(
            tmp_path / "c",
            """
        name = "units"
        [engine]
        speed_rpm = 3000
        bore_mm = 90.5
        pin_offset_mm = -1.5
        [gas]
        imep_bar = 12
        combustion_start_deg = 345
        crankcase_pressure_bar = 1.2
        [small_end]
        clearance_um = 5
        [surface]
        E_pin_GPa = 200
        composite_modulus_GPa = 120
        [solver]
        step_deg = 0.25
        joint = "short-bearing"
        max_cycles = 3
        field_angles_deg = [0, 375.5]
    """,
        )
    )
    assert case.name == "units"
    assert case.engine.speed == pytest.approx(100.0 * math.pi)
    assert case.engine.bore == pytest.approx(0.0905) and case.engine.pin_offset == pytest.approx(-1.5e-3)
    assert case.gas.imep == pytest.approx(12e5) and case.gas.peak_pressure is None
    assert case.gas.combustion_start == pytest.approx(math.radians(345.0))
    assert case.gas.crankcase_pressure == pytest.approx(1.2e5)
    assert case.small_end.clearance == pytest.approx(5e-6)
    assert case.surface.E_pin == pytest.approx(200e9)
    assert surface_from_case(case.surface).modulus == pytest.approx(120e9)
    assert case.solver.step == pytest.approx(math.radians(0.25))
    assert case.solver.joint == "short-bearing" and case.solver.max_cycles == 3
    assert case.solver.field_angles == pytest.approx((0.0, math.radians(375.5)))


def test_a_toml_file_can_be_given_instead_of_a_directory(tmp_path):
    """A TOML file path works too; the name defaults to its stem and the directory is its folder."""
    (tmp_path / "fast.toml").write_text("[engine]\nspeed_rpm = 6000\n")
    case = load_case(tmp_path / "fast.toml")
    assert case.name == "fast" and case.directory == tmp_path.resolve()


def test_pressure_file_is_resolved_against_the_case_directory(tmp_path):
    """A relative pressure_file is resolved against the case directory and selects the trace model."""
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "p.csv").write_text("crank_angle_deg,pressure_bar\n0,1\n360,40\n")
    case = load_case(write_case(tmp_path / "c", '[gas]\npressure_file = "p.csv"\n'))
    assert case.gas.model == "trace" and case.gas.pressure_file == (tmp_path / "c" / "p.csv").resolve()


@pytest.mark.parametrize(
    "text, message",
    [
        ("[engine]\nrod_mass_kg = -0.5\n", r"^engine.rod_mass_kg = -0.5 is out of range \(allowed: > 0\)$"),
        (
            "[engine]\nrod_inertia_kg_m2 = -1e-3\n",
            r"^engine.rod_inertia_kg_m2 = -0.001 is out of range \(allowed: > 0\)$",
        ),
        ("[engine]\npiston_mass_kg = 0\n", r"^engine.piston_mass_kg = 0 is out of range \(allowed: > 0\)$"),
        ("[engine]\ncrank_mass_kg = -1\n", r"^engine.crank_mass_kg = -1 is out of range \(allowed: >= 0\)$"),
        (
            "[engine]\nrod_length_mm = 44\npin_offset_mm = 2\n",
            r"^engine.rod_length_mm = 44 is out of range "
            r"\(allowed: > crank_radius_mm \+ \|pin_offset_mm\| = 45\)$",
        ),
        ("[engine]\nrod_cg_from_big_end_mm = 200\n", r"^engine.rod_cg_from_big_end_mm = 200 is out of range"),
        (
            "[engine]\nspeed_rpm = nan\n",
            r"^engine.speed_rpm = nan is out of range \(allowed: \(0, 30000\)\)$",
        ),
        ('[engine]\nbore_mm = "86"\n', r"^engine.bore_mm = '86' has the wrong type \(expected a number\)$"),
        ("[engine]\nbore_mm = true\n", r"^engine.bore_mm = True has the wrong type \(expected a number\)$"),
        ("[engine]\ngravity = 1\n", r"^engine.gravity = 1 has the wrong type \(expected true or false\)$"),
        ("[engine]\nbore = 86\n", r"unknown key engine.bore \(did you mean engine.bore_mm\?\)$"),
        ("[engin]\nbore_mm = 86\n", r"unknown section \[engin\] \(did you mean \[engine\]\?\)$"),
        ("speed_rpm = 2000\n", r"unknown key speed_rpm"),
        (
            "[gas]\ncombustion_start_deg = 460\ncombustion_duration_deg = 40\n",
            r"^gas.combustion_duration_deg = 40 is out of range "
            r"\(allowed: < 30 \(combustion must end before the exhaust opens",
        ),
        (
            "[gas]\ncombustion_start_deg = 100\n",
            r"^gas.combustion_start_deg = 100 is out of range \(allowed: \(180, 540\)\)$",
        ),
        (
            "[gas]\npeak_pressure_bar = 60\nimep_bar = 10\n",
            r"either gas.peak_pressure_bar or gas.imep_bar, not both",
        ),
        ('[gas]\nmodel = "trace"\n', r"gas.pressure_file is required with gas.model = \"trace\""),
        (
            '[gas]\nmodel = "magic"\n',
            r"^gas.model = 'magic' is out of range \(allowed: 'single-zone', 'motored'",
        ),
        ('[gas]\npressure_file = "missing.csv"\n', r"^gas.pressure_file = 'missing.csv': file not found"),
        (
            "[gas]\npolytropic_exponent = 1.8\n",
            r"^gas.polytropic_exponent = 1.8 is out of range \(allowed: \(1, 1.66667\)\)$",
        ),
        (
            "[small_end]\nclearance_um = 20000\n",
            r"^small_end.clearance_um = 20000 is out of range \(allowed: < pin_radius",
        ),
        ("[surface]\nsigma_pin_um = 0\nsigma_bushing_um = 0\n", r"composite roughness > 0"),
        ("[surface]\nnu_pin = 0.5\n", r"^surface.nu_pin = 0.5 is out of range \(allowed: \(-1, 0.5\)\)$"),
        ("[oil]\nviscosity_Pa_s = -0.01\n", r"^oil.viscosity_Pa_s = -0.01 is out of range \(allowed: > 0\)$"),
        ("[solver]\nstep_deg = 0.7\n", r"^solver.step_deg = 0.7 is out of range"),
        (
            "[solver]\nstep_deg = 0.5\nmax_step_deg = 1\n",
            r"^solver.max_step_deg = 1 is out of range \(allowed: \[0, step_deg = 0.5\] \(0: step_deg\)\)$",
        ),
        ("[solver]\nmax_step_deg = -1\n", r"^solver.max_step_deg = -1 is out of range"),
        ('[solver]\njoint = "glue"\n', r"^solver.joint = 'glue' is out of range \(allowed: 'mixed-fem'"),
        (
            "[solver]\nmax_cycles = 2.5\n",
            r"^solver.max_cycles = 2.5 has the wrong type \(expected an integer\)$",
        ),
        (
            "[solver]\nmax_cycles = 0\n",
            r"^solver.max_cycles = 0 is out of range \(allowed: an integer in \[1, 100\]\)$",
        ),
        ("[solver]\nfield_angles_deg = [10, 800]\n", r"^solver.field_angles_deg = .* is out of range"),
        ('[solver]\nfield_angles_deg = "all"\n', r"^solver.field_angles_deg = 'all' has the wrong type"),
        ("[solver]\nfuture_option = 1\n", r"unknown key solver.future_option"),
        ('[oil]\ninlet = "groove"\n', r"^oil.inlet = 'groove' is out of range"),
        (
            '[oil]\ninlet = "axial-groove"\ngroove_arc_deg = 360\n',
            r"^oil.groove_arc_deg = 360 is out of range \(allowed: \(0, 360\)\)$",
        ),
        (
            '[oil]\ninlet = "axial-groove"\ngroove_length_mm = 20\n',
            r"^oil.groove_length_mm = 20 is out of range "
            r"\(allowed: \(0, small_end.width_mm = 20\), inside the bushing\)$",
        ),
        (
            '[oil]\ninlet = "circumferential-groove"\ngroove_width_mm = 25\n',
            r"^oil.groove_width_mm = 25 is out of range \(allowed: \(0, small_end.width_mm = 20\)",
        ),
        ("[oil]\ngroove_width_mm = 0\n", r"^oil.groove_width_mm = 0 is out of range \(allowed: > 0\)$"),
        (
            '[oil]\ninlet = "hole"\nsupply_hole_diameter_mm = 12\n',
            (
                r"^oil.supply_hole_diameter_mm = 12 is out of range \(allowed: < min\(small_end.width_mm, "
                r"small_end.pin_radius_mm\) = 10\)$"
            ),
        ),
        ("[engine\nbore_mm = 86\n", r"invalid TOML"),
        (
            '[oil]\nviscosity_Pa_s = 0.01\ngrade = "5W-30"\n',
            r"give either oil.viscosity_Pa_s or the oil's data",
        ),
        ('[oil]\ngrade = "5W-31"\n', r"^oil.grade = '5W-31' is out of range \(allowed: '0W-20'"),
        ("[oil]\nkinematic_viscosity_40C_cSt = 68\n", r"together \(allowed: all three, or none\)"),
        (
            "[oil]\nkinematic_viscosity_40C_cSt = 10\nkinematic_viscosity_100C_cSt = 11\n"
            "density_15C_kg_m3 = 850\n",
            r"^oil.kinematic_viscosity_40C_cSt = 10(\.0)? is out of range "
            r"\(allowed: > oil.kinematic_viscosity_100C_cSt = 11",
        ),
        ('[oil]\ngrade = "5W-30"\ntemperature_C = 300\n', r"^oil.temperature_C = 300 is out of range"),
        (
            '[small_end]\nelastic = "fe"\neye_outer_radius_mm = 11\n',
            r"^small_end.eye_outer_radius_mm = 11 is out",
        ),
        ('[oil]\npiezoviscosity = "linear"\n', r"^oil.piezoviscosity = 'linear' is out of range"),
        ("[solver]\nmesh_edge_size = 2\n", r"^solver.mesh_edge_size = 2 is out of range"),
        ("[small_end]\nedge_relief_um = -1\n", r"^small_end.edge_relief_um = -1 is out of range"),
        (
            "[small_end]\nedge_relief_um = 3\nedge_relief_length_mm = 10\n",
            r"^small_end.edge_relief_length_mm = 10 is out of range \(allowed: \(0, 10\): less than half",
        ),
        ('[small_end]\nedge_relief_shape = "round"\n', r"^small_end.edge_relief_shape = 'round' is out"),
        (
            "[big_end]\nedge_relief_um = 2\n",
            r"^big_end.edge_relief_um = 2 shapes the finite-element film \(allowed with big_end.joint",
        ),
        (
            '[big_end]\njoint = "mixed-fem"\nedge_relief_um = 2\nedge_relief_length_mm = 10\n',
            r"^big_end.edge_relief_length_mm = 10 is out of range \(allowed: \(0, 10\)",
        ),
        (
            '[small_end]\nedge_relief_um = 3\n[solver]\njoint = "short-bearing"\n',
            r"^small_end.edge_relief_um = 3 shapes the finite-element film \(allowed with solver.joint",
        ),
    ],
)
def test_bad_values_give_one_line_errors_naming_the_field(tmp_path, text, message):
    """Each bad input gives one line naming section.key, its value in TOML units and the allowed range."""
    with pytest.raises(InputError, match=message) as caught:
        load_case(write_case(tmp_path / "bad", text))
    assert "\n" not in str(caught.value)


def test_missing_case_file(tmp_path):
    """A missing case directory is an InputError, not a traceback."""
    with pytest.raises(InputError, match=r"^case file not found: .*nowhere"):
        load_case(tmp_path / "nowhere")


def test_dataclasses_validate_when_built_in_python():
    """The same checks run in __post_init__, with the TOML field names in the messages."""
    with pytest.raises(InputError, match=r"^engine.rod_mass_kg = -1 is out of range"):
        Engine(rod_mass=-1.0)
    with pytest.raises(InputError, match=r"^engine.rod_length_mm = 40 is out of range"):
        dataclasses.replace(Engine(), rod_length=0.040)
    with pytest.raises(InputError, match=r"^small_end.width_mm = 0 is out of range"):
        SmallEnd(width=0.0)
    with pytest.raises(InputError, match=r"gas.imep_bar"):
        Gas(peak_pressure=None)
    assert Solver().step == pytest.approx(math.radians(1.0))
    assert Surface().composite_modulus is None
    assert Case(name="x", directory=Path(".")).engine == Engine()


def test_the_oil_from_its_data_sheet_gives_the_film_viscosity(tmp_path):
    """oil.grade, or the three data-sheet values, replace viscosity_Pa_s: the film's viscosity is the
    ASTM D341 viscosity at oil.temperature_C times the density there (solver.oil, tested against the
    standard in tests/test_oil.py); the same sheet given both ways gives the same viscosity (1e-12),
    and a hotter oil is thinner."""
    from solver.oil import oil_from_grade

    grade = load_case(write_case(tmp_path / "grade", '[oil]\ngrade = "5W-30"\ntemperature_C = 90\n'))
    sheet = oil_from_grade("5W-30")
    text = (
        f"[oil]\nkinematic_viscosity_40C_cSt = {sheet.kinematic_viscosity_40C}\n"
        f"kinematic_viscosity_100C_cSt = {sheet.kinematic_viscosity_100C}\n"
        f"density_15C_kg_m3 = {sheet.density_15C}\n"
        "temperature_C = 90\n"
    )
    data = load_case(write_case(tmp_path / "sheet", text))
    expected = sheet.kinematic_viscosity(90.0) * 1e-6 * sheet.density(90.0)
    assert grade.oil.viscosity == pytest.approx(expected, rel=1e-12)
    assert data.oil.viscosity == pytest.approx(expected, rel=1e-12)
    hot = load_case(write_case(tmp_path / "hot", '[oil]\ngrade = "5W-30"\ntemperature_C = 120\n'))
    assert hot.oil.viscosity < grade.oil.viscosity
    assert load_case(write_case(tmp_path / "plain", "")).oil.viscosity == 0.010  # the reference default


class _StandIn(RuntimeError):
    """Raised by the stand-in film factory once it has the spec: the joint's build stops there."""


@pytest.fixture
def film_spec(monkeypatch):
    """``film_spec(case, big_end=False)``: the FilmSpec the case's mixed-fem small end (or big end) hands to
    the film factory, recorded by a stand-in factory that then stops the build."""
    from mpi4py import MPI

    import solver.film.factory as factory
    from solver.dynamics.engine import engine_from_case
    from solver.dynamics.joint import big_end_joint_from_case, joint_from_case

    seen = []

    def record(spec, comm):
        seen.append(spec)
        raise _StandIn

    monkeypatch.setattr(factory, "make_film", record)

    def spec_of(case, big_end=False):
        with pytest.raises(_StandIn):
            if big_end:
                big_end_joint_from_case(case, engine_from_case(case), MPI.COMM_SELF)
            else:
                joint_from_case(case, engine_from_case(case), MPI.COMM_SELF, "mixed-fem")
        return seen[-1]

    return spec_of


def test_the_edge_mesh_size_reaches_the_films_mesh(tmp_path, film_spec):
    """``solver.mesh_edge_size`` is handed to the small end's film (its FilmSpec, through the film
    factory), absent: None (the uniform mesh, every case as it was)."""
    for k, (text, expected) in enumerate((("[solver]\nmesh_edge_size = 0.033\n", 0.033), ("", None))):
        case = load_case(write_case(tmp_path / f"c{k}", text))
        assert film_spec(case).mesh_edge_size == expected


def test_the_edge_relief_reaches_the_films_spec(tmp_path, film_spec):
    """``small_end.edge_relief_*`` reach the small end's film as an EdgeRelief in SI units; absent (or a
    depth of 0), none: a cylindrical bore, every case as it was."""
    text = '[small_end]\nedge_relief_um = 4\nedge_relief_length_mm = 2.5\nedge_relief_shape = "linear"\n'
    for k, (text, expected) in enumerate(
        (
            (text, (4e-6, 2.5e-3, "linear")),
            ("", None),
            ("[small_end]\nedge_relief_um = 0\n", None),
        )
    ):
        relief = film_spec(load_case(write_case(tmp_path / f"c{k}", text))).edge_relief
        if expected is None:
            assert relief is None
            continue
        assert relief.depth == pytest.approx(expected[0], rel=1e-12)
        assert relief.length == pytest.approx(expected[1], rel=1e-12)
        assert relief.shape == expected[2]


def test_the_big_end_s_edge_relief_reaches_its_film(tmp_path, film_spec):
    """``big_end.edge_relief_*`` reach the mixed-fem big end's film (with and without its supply hole, whose
    film is solved in the crankpin's frame: the relief depends on z only); the small end's stays None."""
    relief = '[big_end]\njoint = "mixed-fem"\nedge_relief_um = 5\nedge_relief_length_mm = 4\n'
    for k, text in enumerate((relief, relief + 'supply = "hole"\n[oil]\ninlet = "none"\n')):
        case = load_case(write_case(tmp_path / f"c{k}", text))
        assert case.small_end.edge_relief_depth == 0.0
        spec = film_spec(case, big_end=True)
        assert spec.joint == "big_end"
        assert spec.edge_relief.depth == pytest.approx(5e-6, rel=1e-12)
        assert spec.edge_relief.length == pytest.approx(4e-3, rel=1e-12)
        assert spec.edge_relief.section == "big_end"
