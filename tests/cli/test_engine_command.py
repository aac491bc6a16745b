"""The ``engine`` command: bad input is one line ``error: ...`` with exit status 2; good input runs.

Bad-input tests run ``python3 -m solver engine ...`` in a subprocess (the real entry point, exit
status and stderr); they are serial because every rank would print the same and spawn processes.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import assert_one_line_error

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "cases" / "reference-2000rpm"


def run_cli(*arguments: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "solver", "engine", *arguments]
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)


def case_dir(tmp_path: Path, toml: str, files: dict[str, str] | None = None) -> Path:
    directory = tmp_path / "case"
    directory.mkdir()
    (directory / "case.toml").write_text(toml)
    for name, text in (files or {}).items():
        (directory / name).write_text(text)
    return directory


BAD_CASES = {
    "negative rod mass": ("[engine]\nrod_mass_kg = -0.55\n", {}, ("engine.rod_mass_kg", "allowed: > 0")),
    "negative piston mass": (
        "[engine]\npiston_mass_kg = -0.45\n",
        {},
        ("engine.piston_mass_kg", "allowed: > 0"),
    ),
    "negative rod inertia": (
        "[engine]\nrod_inertia_kg_m2 = -2.2e-3\n",
        {},
        ("engine.rod_inertia_kg_m2", "allowed: > 0"),
    ),
    "rod shorter than crank plus offset": (
        "[engine]\nrod_length_mm = 45\npin_offset_mm = 3\n",
        {},
        ("engine.rod_length_mm", "crank_radius_mm + |pin_offset_mm| = 46"),
    ),
    "missing pressure file": (
        '[gas]\npressure_file = "p.csv"\n',
        {},
        ("gas.pressure_file", "file not found"),
    ),
    "non-monotone crank angles": (
        '[gas]\npressure_file = "p.csv"\n',
        {"p.csv": "crank_angle_deg,pressure_bar\n0,1\n20,2\n10,3\n"},
        ("gas.pressure_file", "line 4", "strictly increasing"),
    ),
    "NaN in the trace": (
        '[gas]\npressure_file = "p.csv"\n',
        {"p.csv": "crank_angle_deg,pressure_bar\n0,1\n10,NaN\n20,3\n"},
        ("gas.pressure_file", "line 3", "not finite"),
    ),
    "wrong columns": (
        '[gas]\npressure_file = "p.csv"\n',
        {"p.csv": "deg,p\n0,1\n10,2\n"},
        ("gas.pressure_file", "line 1", "expected crank_angle_deg,pressure_bar"),
    ),
    "NaN in a speed trace": (
        '[engine]\nspeed_file = "n.csv"\n',
        {"n.csv": "crank_angle_deg,speed_rpm\n0,2000\n90,nan\n"},
        ("engine.speed_file", "line 3", "not finite"),
    ),
    "unknown key": ("[engine]\nbore_cm = 8.6\n", {}, ("unknown key engine.bore_cm",)),
    "peak below motored": (
        "[gas]\npeak_pressure_bar = 5\n",
        {},
        ("gas.peak_pressure_bar = 5", "motored peak"),
    ),
}


@pytest.mark.serial
@pytest.mark.parametrize("name", BAD_CASES)
def test_bad_case_input_is_one_line_error_with_exit_2(tmp_path, name):
    """Issue 3 bad inputs: negative mass or inertia, rod shorter than crank plus offset, missing pressure
    file, non-monotone angles or NaN in a trace, wrong columns: exit 2, one stderr line naming the field."""
    toml, files, fragments = BAD_CASES[name]
    assert_one_line_error(run_cli(str(case_dir(tmp_path, toml, files))), *fragments)


@pytest.mark.serial
@pytest.mark.parametrize(
    "arguments, fragments",
    [
        (["--rpm", "-100"], ("--rpm = -100 is out of range",)),
        (["--rpm", "nan"], ("--rpm = nan",)),
        (["--step-deg", "0.7"], ("--step-deg = 0.7 is out of range",)),
        (["--rpm", "fast"], ("invalid float value: 'fast'",)),
    ],
)
def test_bad_arguments_are_one_line_errors_with_exit_2(arguments, fragments):
    """Bad command-line values (through the cli's argparse and our own checks): exit 2, one line."""
    assert_one_line_error(run_cli(str(REFERENCE), *arguments), *fragments)


@pytest.mark.serial
def test_missing_case_directory(tmp_path):
    """A case directory that does not exist: exit 2, one line."""
    assert_one_line_error(run_cli(str(tmp_path / "nowhere")), "case file not found")


@pytest.mark.serial
def test_json_summary_of_the_reference_case(tmp_path):
    """One JSON object; the numbers are the reference engine's (DESIGN 3.7: ideal small-end force peaks
    near 33 kN; peak gas force = (60 - 1) bar x pi 0.086^2 / 4 = 34.27 kN)."""
    result = run_cli(str(REFERENCE), "--json", "--step-deg", "1", "--output", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["case"] == "reference-2000rpm" and summary["step_deg"] == 1.0
    assert 32e3 < summary["peak_small_end_force_N"] < 35e3
    assert summary["peak_gas_force_N"] == pytest.approx(59e5 * 3.141592653589793 * 0.086**2 / 4, rel=2e-3)
    assert summary["mean_crank_torque_N_m"] < 0.0
    png = (tmp_path / "out" / "engine_ideal.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    csv = (tmp_path / "out" / "engine_ideal.csv").read_text().splitlines()
    assert csv[0].startswith("crank_angle [degree],time [s],x_piston [m]")
    assert "ideal_pin_force_x [N]" in csv[0]
    assert len(csv) == 1 + 721


@pytest.mark.serial
def test_text_summary_in_process(capsys):
    """The CLI's main() in-process: rpm override and the summary lines."""
    from solver.cli import main

    assert main(["engine", str(REFERENCE), "--rpm", "6000", "--step-deg", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("case reference-2000rpm: 6000 rpm, 361 points every 2 deg, kinematic")
    labels = ("peak small-end force", "peak gas force", "peak side thrust", "mean crank torque", "run time")
    for label in labels:
        assert label in out
