"""What a new user tripped over (issue 31): unit slips on the command line, negative numbers in scientific
notation, the flags in the film rules' messages, smooth-by-default surfaces in --help, the JSON's final
newline, the sections a run took from the defaults and the half-width ParaView fields."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from tests.cli.test_bearing_command import GOOD
from tests.conftest import assert_one_line_error, run_cli

QUICK = ["--eccentricity", "0.5", "--mesh-size", "0.2"]


# the new user's small end typed in mm (R 12, B 22, c 0.012)
IN_MM = ["--radius", "12", "--width", "22", "--clearance", "0.012", "--viscosity", "0.01"]


def _with(args: list[str], flag: str, value: str) -> list[str]:
    out = list(args)
    out[out.index(flag) + 1] = value
    return out


@pytest.mark.serial
@pytest.mark.parametrize(
    "command, args, fragments",
    [
        # the bearing in mm: R = 12 m > 1 m
        (
            "bearing",
            IN_MM + ["--speed", "3000"] + QUICK,
            ["--radius = 12 is out of range (allowed: [0.0001, 1] m; if you meant 12 mm: --radius 0.012)"],
        ),
        # the clearance alone in mm: c/R = 1.2 > 1e-2; R = 0.01 m -> c in [1e-6, 1e-4] m
        (
            "bearing",
            _with(GOOD, "--clearance", "0.012") + QUICK,
            ["--clearance = 0.012 is out of range (allowed: [1e-06, 0.0001] m", "if you meant 0.012 mm: "],
        ),
        # the roughness in um: sigma = 0.3 m is above c = 10 um
        (
            "bearing",
            GOOD + QUICK + ["--sigma-bushing", "0.3"],
            ["--clearance = 1e-05 is below the composite roughness", "if you meant 0.3 um: 3e-07 m"],
        ),
        # c/R = 1e-4 is plausible, sigma = 2 um is not below it: no unit slip to name
        (
            "bearing",
            _with(GOOD, "--clearance", "1e-6") + QUICK + ["--sigma-bushing", "2e-6"],
            [
                "--clearance = 1e-06 is below the composite roughness sqrt(--sigma-journal^2 + "
                "--sigma-bushing^2) = 2e-06 (allowed: clearance > composite roughness)"
            ],
        ),
        # a width in mm: B/R = 2000
        ("bearing", _with(GOOD, "--width", "20") + QUICK, ["--width = 20 is out of range", "--width 0.02"]),
        (
            "bearing",
            GOOD + QUICK + ["--elastic", "winkler", "--bushing-thickness", "1.5", "--inlet", "none"],
            ["--bushing-thickness = 1.5 is out of range (allowed: [0, 0.01] m, at most the radius)"],
        ),
        # the stribeck command had no geometry check at all
        (
            "stribeck",
            IN_MM + ["--load", "100", "--points", "2"],
            ["--radius = 12 is out of range", "--radius 0.012"],
        ),
    ],
    ids=["radius-mm", "clearance-mm", "sigma-um", "below-roughness", "width-mm", "bushing", "stribeck"],
)
def test_an_implausible_bearing_is_one_line_naming_the_flag_and_the_unit(tmp_path, command, args, fragments):
    # (in tmp_path: were it not refused, stribeck would write ./stribeck)
    assert_one_line_error(run_cli(command, *args, cwd=tmp_path), *fragments)


@pytest.mark.serial
def test_negative_numbers_in_scientific_notation_are_values():
    """argparse (3.11) reads '-0.9e5' as a flag unless told otherwise; the parse gives the numbers."""
    from solver.cli import _parser

    args = _parser().parse_args(
        ["bearing", *GOOD, "--eccentricity", "0.5", "--cavitation-pressure", "-0.9e5", "--attitude", "-1E1"]
        + ["--eccentricity-rate", "-.5e-1"]
    )
    assert (args.cavitation_pressure, args.attitude, args.eccentricity_rate) == (-90000.0, -10.0, -0.05)


@pytest.mark.serial
def test_a_negative_cavitation_pressure_runs_as_with_an_equals_sign():
    """The flooded-edge JFO film that needs p_cav < 0: '--cavitation-pressure -0.9e5' is the same run as
    '--cavitation-pressure=-0.9e5' (the same film: bit for bit); the JSON is one line with its newline."""
    base = [*GOOD, *QUICK, "--cavitation", "jfo", "--inlet", "none", "--json"]
    spaced = run_cli("bearing", *base, "--cavitation-pressure", "-0.9e5")
    joined = run_cli("bearing", *base, "--cavitation-pressure=-0.9e5")
    assert spaced.returncode == 0 and joined.returncode == 0, spaced.stderr
    drop = ("solve_time_s", "setup_time_s")
    a, b = ({k: v for k, v in json.loads(p.stdout).items() if k not in drop} for p in (spaced, joined))
    assert a == b and a["cavitation"] == "jfo" and a["load_N"] > 0
    assert spaced.stdout.endswith("}\n") and spaced.stdout.count("\n") == 1


@pytest.mark.serial
def test_the_jfo_rule_names_the_flag_on_the_command_line():
    """The JFO film with inlet none and no supply needs p_cav < 0: the bearing command's message names
    --cavitation-pressure with its value in Pa (the case loader's, oil.cavitation_pressure_bar in bar)."""
    assert_one_line_error(
        run_cli("bearing", *GOOD, *QUICK, "--cavitation", "jfo", "--inlet", "none"),
        "(--cavitation-pressure 0 Pa)",
        "(--cavitation jfo)",
    )


@pytest.mark.serial
def test_stribeck_uses_the_cavitation_law(tmp_path):
    """stribeck took --cavitation and swept the Reynolds film whatever it said: the JFO film's rule (no
    supply, edges at p_cav = 0, inlet none) now refuses it as the bearing command does, before any mesh."""
    no_speed = GOOD[: GOOD.index("--speed")]
    assert_one_line_error(
        run_cli(
            "stribeck",
            *no_speed,
            *["--load", "100", "--cavitation", "jfo", "--inlet", "none", "--points", "2"],
            cwd=tmp_path,  # (were it not refused: ./stribeck)
        ),
        "(--cavitation-pressure 0 Pa)",
        "(--cavitation jfo)",
    )


@pytest.mark.serial
def test_help_says_the_bearing_is_smooth_by_default_unlike_an_engine_case():
    """The engine case's defaults (solver.case.FIELDS: 0.1 and 0.3 um) are quoted in the sigma flags' help."""
    proc = run_cli("bearing", "--help")
    assert proc.returncode == 0
    text = " ".join(proc.stdout.split())
    assert "smooth by default, unlike an engine case" in text
    assert "surface.sigma_pin_um = 0.1 um" in text and "surface.sigma_bushing_um = 0.3 um" in text


@pytest.mark.serial
def test_an_empty_case_file_logs_that_it_is_all_defaults(tmp_path):
    """An empty case.toml is the reference engine: the terminal and run.log say so (--joint ideal: one
    cycle of the ideal mechanism, seconds)."""
    (tmp_path / "case.toml").write_text("")
    proc = run_cli("run", str(tmp_path), "--joint", "ideal", "--quiet")
    assert proc.returncode == 0, proc.stderr
    note = "the case file has no section: every default is used, the reference engine ([engine], [gas]"
    assert note in proc.stderr
    assert note in (tmp_path / "results" / "run.log").read_text()


@pytest.mark.serial
def test_the_paraview_fields_log_says_they_hold_the_half_width(tmp_path, caplog):
    """write_fields of a concentric rotating film (two states): the files and one log line saying the mesh
    is the half film z >= 0; the mesh's z spans [0, B/2] in metres."""
    from mpi4py import MPI

    from solver.film.factory import make_film
    from solver.film.spec import FilmSpec
    from solver.film.types import Bearing
    from solver.study.fields import write_fields

    bearing = Bearing(radius=0.01, width=0.02, clearance=10e-6, viscosity=0.01, inlet="none")
    omega = 300.0
    with make_film(FilmSpec(bearing=bearing, omega_ref=omega, mesh_size=0.3), MPI.COMM_SELF) as model:
        columns = {
            "crank_angle": np.array([0.0, 1.0]),
            "time": np.array([0.0, 1e-3]),
            "ecc_x": np.array([5e-6, 5e-6]),
            "ecc_y": np.zeros(2),
            "ecc_rate_x": np.zeros(2),
            "ecc_rate_y": np.zeros(2),
            "omega_rel": np.array([omega, omega]),
        }
        z = model.mesh.geometry.x[:, 2] * bearing.radius  # (the film's mesh is in units of R)
        with caplog.at_level(logging.INFO, logger="solver.study.fields"):
            paths = write_fields(
                tmp_path, model, columns, [], step_deg=1.0, field_step=math.radians(1.0), field_angles=[0.0]
            )
    assert [p.name for p in paths] == ["film_series.xdmf", "film_000.0deg.xdmf"]
    assert z.min() == pytest.approx(0.0, abs=1e-12) and z.max() == pytest.approx(0.01, rel=1e-12)
    lines = [r.getMessage() for r in caplog.records if r.name == "solver.study.fields"]
    assert len(lines) == 1 and "film_series.xdmf, film_000.0deg.xdmf" in lines[0]
    assert "the half film z >= 0" in lines[0]
