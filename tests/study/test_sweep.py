"""Sweep files (solver.study.sweep): expansion order, ranges, names, files, reproducibility, bad input.

Every test works in pytest's per-process ``tmp_path`` and runs on one rank (the expansion is done by
one rank in a batch).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solver.case import RPM, load_case
from solver.errors import InputError
from solver.study.sweep import case_name, expand, is_sweep_file, load_sweep

ROOT = Path(__file__).resolve().parents[2]


def base_case(tmp_path: Path, extra: str = "", files: dict[str, str] | None = None) -> Path:
    base = tmp_path / "base"
    base.mkdir(exist_ok=True)
    (base / "case.toml").write_text(
        'name = "base"\ndescription = "the base"\n[solver]\njoint = "ideal"\n' + extra
    )
    for name, text in (files or {}).items():
        (base / name).parent.mkdir(parents=True, exist_ok=True)
        (base / name).write_text(text)
    return base


def sweep_file(tmp_path: Path, body: str, name: str = "study.toml", base: str = "base") -> Path:
    path = tmp_path / name
    path.write_text(f'[sweep]\nbase = "{base}"\n' + body)
    return path


PRODUCT = """
[sweep.set]
"solver.max_cycles" = 1
[sweep.parameters]
"engine.speed_rpm" = [1000, 2000, 3000]
"small_end.clearance_um" = {start = 5, stop = 15, num = 3}
"""


def test_product_order_names_and_values(tmp_path):
    """First parameter slowest, last fastest; names key-value; case files hold base + overrides."""
    base_case(tmp_path)
    sweep = load_sweep(sweep_file(tmp_path, PRODUCT))
    assert sweep.cases_dir == (tmp_path / "study").resolve()
    assert sweep.keys == ["engine.speed_rpm", "small_end.clearance_um"]
    names = sweep.names()
    assert names[:4] == [
        "speed_rpm-1000_clearance_um-5",
        "speed_rpm-1000_clearance_um-10",
        "speed_rpm-1000_clearance_um-15",
        "speed_rpm-2000_clearance_um-5",
    ]
    assert len(names) == 9
    dirs = expand(sweep)
    assert [d.name for d in dirs] == names
    case = load_case(dirs[5])  # speed 2000, clearance 15
    assert case.name == "speed_rpm-2000_clearance_um-15"
    assert case.engine.speed == pytest.approx(2000 * RPM, rel=1e-15)
    assert case.small_end.clearance == pytest.approx(15e-6, rel=1e-15)
    assert case.solver.max_cycles == 1 and case.solver.joint == "ideal"  # set and base keys kept
    assert "engine.speed_rpm = 2000" in case.description and "the base" in case.description
    manifest = json.loads((sweep.cases_dir / "sweep.json").read_text())
    assert manifest["parameters"] == sweep.keys
    assert [c["name"] for c in manifest["cases"]] == names
    assert manifest["cases"][5]["values"] == {"engine.speed_rpm": 2000, "small_end.clearance_um": 15.0}


def test_zip_mode(tmp_path):
    base_case(tmp_path)
    body = """
mode = "zip"
[sweep.parameters]
"engine.speed_rpm" = [1000, 4000]
"gas.peak_pressure_bar" = [40, 80]
"""
    sweep = load_sweep(sweep_file(tmp_path, body))
    assert sweep.names() == ["speed_rpm-1000_peak_pressure_bar-40", "speed_rpm-4000_peak_pressure_bar-80"]
    bad = sweep_file(tmp_path, body.replace("[40, 80]", "[40, 60, 80]"), name="bad.toml")
    with pytest.raises(InputError, match="same length"):
        load_sweep(bad)


@pytest.mark.parametrize(
    "spec, expected",
    [
        ("{start = 0.005, stop = 0.02, step = 0.005}", [0.005, 0.01, 0.015, 0.02]),  # stop included
        ("{start = 0.1, stop = 0.7, step = 0.2}", [0.1, 0.3, 0.5, 0.7]),  # 0.1 + 0.2 written as 0.3
        ("{start = 0.01, stop = 0.02, num = 3}", [0.01, 0.015, 0.02]),
        ("{start = 0.01, stop = 0.02, num = 1}", [0.01]),
        ("{start = 0.02, stop = 0.005, step = -0.005}", [0.02, 0.015, 0.01, 0.005]),
        ("{start = 0.01, stop = 0.025, step = 0.01}", [0.01, 0.02]),  # stop not on the grid
    ],
)
def test_ranges(tmp_path, spec, expected):
    base_case(tmp_path)
    sweep = load_sweep(sweep_file(tmp_path, f'[sweep.parameters]\n"oil.viscosity_Pa_s" = {spec}\n'))
    values = sweep.parameters[0][1]
    assert list(values) == expected  # exact: values are rounded to 12 significant digits


def test_integer_ranges_stay_integers(tmp_path):
    base_case(tmp_path)
    body = (
        '[sweep.parameters]\n"engine.speed_rpm" = {start = 1000, stop = 3000, step = 1000}\n'
        '"solver.max_cycles" = {start = 1, stop = 3, num = 3}\n'
    )
    sweep = load_sweep(sweep_file(tmp_path, body))
    assert [type(v) for v in sweep.parameters[0][1]] == [int] * 3
    assert sweep.parameters[1][1] == (1, 2, 3)
    assert sweep.names()[0] == "speed_rpm-1000_max_cycles-1"


def test_dotted_keys_and_subtables_mean_the_same(tmp_path):
    base_case(tmp_path)
    quoted = load_sweep(
        sweep_file(
            tmp_path,
            '[sweep.parameters]\n"engine.speed_rpm" = [1000]\n"oil.viscosity_Pa_s" = [0.01]\n',
            name="a.toml",
        )
    )
    dotted = load_sweep(
        sweep_file(
            tmp_path,
            "[sweep.parameters]\nengine.speed_rpm = [1000]\noil.viscosity_Pa_s = [0.01]\n",
            name="b.toml",
        )
    )
    table = load_sweep(
        sweep_file(
            tmp_path,
            "[sweep.parameters.engine]\nspeed_rpm = [1000]\n"
            "[sweep.parameters.oil]\nviscosity_Pa_s = [0.01]\n",
            name="c.toml",
        )
    )
    assert quoted.parameters == dotted.parameters == table.parameters


def test_names_use_the_section_when_keys_clash_and_sanitise_strings():
    assert (
        case_name({"surface.nu_pin": 0.3, "solver.joint": "short-bearing"})
        == "nu_pin-0.3_joint-short-bearing"
    )
    assert (
        case_name({"oil.viscosity_Pa_s": 1e-5, "engine.gravity": False})
        == "viscosity_Pa_s-1e-05_gravity-false"
    )
    assert case_name({"gas.pressure_file": "traces/p 4000.csv"}) == "pressure_file-p-4000"


def test_expansion_is_reproducible_and_idempotent(tmp_path):
    """Two expansions give the same bytes; expanding again keeps existing case directories (and results)."""
    base_case(tmp_path)
    path = sweep_file(tmp_path, PRODUCT)
    first = expand(load_sweep(path, cases_dir=tmp_path / "one"))
    second = expand(load_sweep(path, cases_dir=tmp_path / "two"))
    for a, b in zip(first, second):
        assert (a / "case.toml").read_bytes() == (b / "case.toml").read_bytes()
    assert (tmp_path / "one" / "sweep.json").read_bytes() == (tmp_path / "two" / "sweep.json").read_bytes()
    results = first[0] / "results"
    results.mkdir()
    (results / "results.nc").write_text("kept")
    before = (first[0] / "case.toml").stat().st_mtime_ns
    again = expand(load_sweep(path, cases_dir=tmp_path / "one"))
    assert again == first
    assert (results / "results.nc").read_text() == "kept"
    assert (first[0] / "case.toml").stat().st_mtime_ns == before
    assert not [p for p in (tmp_path / "one").iterdir() if p.name.startswith(".")]  # no staging left


def test_changed_base_is_an_error_not_an_overwrite(tmp_path):
    base = base_case(tmp_path)
    path = sweep_file(tmp_path, PRODUCT)
    dirs = expand(load_sweep(path))
    (base / "case.toml").write_text((base / "case.toml").read_text() + "[oil]\nviscosity_Pa_s = 0.02\n")
    with pytest.raises(InputError, match="differs from the expansion") as info:
        expand(load_sweep(path))
    assert "\n" not in str(info.value)
    assert "viscosity" not in (dirs[0] / "case.toml").read_text()


def test_data_files_are_copied(tmp_path):
    """A pressure trace named by the base (in a sub-directory) is copied beside each case.toml."""
    trace = "crank_angle_deg,pressure_bar\n" + "".join(f"{a},{1 + 0.01 * a}\n" for a in range(0, 721, 10))
    base_case(tmp_path, '[gas]\nmodel = "trace"\npressure_file = "traces/p.csv"\n', {"traces/p.csv": trace})
    dirs = expand(load_sweep(sweep_file(tmp_path, '[sweep.parameters]\n"engine.speed_rpm" = [1000, 2000]\n')))
    for directory in dirs:
        assert (directory / "p.csv").read_text() == trace
        assert 'pressure_file = "p.csv"' in (directory / "case.toml").read_text()
        assert load_case(directory).gas.pressure_file == (directory / "p.csv").resolve()


@pytest.mark.parametrize(
    "body, fragments",
    [
        (
            '[sweep.parameters]\n"engine.sped_rpm" = [1]\n',
            ["unknown case key engine.sped_rpm", "engine.speed_rpm"],
        ),
        (
            '[sweep.parameters]\n"motor.speed_rpm" = [1]\n',
            ["unknown case key motor.speed_rpm", "engine.speed_rpm"],
        ),
        ('[sweep.parameters]\n"xyz.abc" = [1]\n', ["unknown case key xyz.abc", "section of engine"]),
        ('[sweep.parameters]\n"engine.speed_rpm" = ["fast"]\n', ["engine.speed_rpm", "expected a number"]),
        ('[sweep.parameters]\n"solver.joint" = ["wet"]\n', ["solver.joint", "allowed"]),
        (
            '[sweep.parameters]\n"engine.speed_rpm" = {start = 1, stop = 2}\n',
            ["engine.speed_rpm", "num", "step"],
        ),
        (
            '[sweep.parameters]\n"engine.speed_rpm" = {start = 1, stop = 2, step = -1}\n',
            ["step", "out of range"],
        ),
        ('[sweep.parameters]\n"engine.speed_rpm" = 1000\n', ["engine.speed_rpm", "list"]),
        (
            '[sweep.parameters]\n"solver.field_angles_deg" = [[0]]\n',
            ["solver.field_angles_deg", "cannot be swept"],
        ),
        ('[sweep.parameters]\nname = ["a"]\n', ["name", "cannot be set"]),
        ("[sweep.parameters]\n", ["sweep.parameters", "required"]),
        ('[sweep.parameters]\n"engine.speed_rpm" = [1]\n[sweep.set]\n"engine.speed_rpm" = 2\n', ["both"]),
        ('mdoe = "zip"\n[sweep.parameters]\n"engine.speed_rpm" = [1]\n', ["sweep.mdoe", "sweep.mode"]),
    ],
)
def test_bad_sweep_is_one_line_naming_the_key(tmp_path, body, fragments):
    base_case(tmp_path)
    with pytest.raises(InputError) as info:
        load_sweep(sweep_file(tmp_path, body))
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_invalid_case_value_writes_nothing(tmp_path):
    """A value out of the case's range is reported with the case and the key; no directory is written."""
    base_case(tmp_path)
    path = sweep_file(tmp_path, '[sweep.parameters]\n"small_end.clearance_um" = [10, 20000]\n')
    with pytest.raises(InputError) as info:
        expand(load_sweep(path))
    assert "clearance_um-20000" in str(info.value) and "small_end.clearance_um" in str(info.value)
    assert not [p for p in (tmp_path / "study").iterdir()]


def test_missing_base_and_duplicate_names(tmp_path):
    with pytest.raises(InputError, match="case file not found"):
        load_sweep(sweep_file(tmp_path, '[sweep.parameters]\n"engine.speed_rpm" = [1]\n', base="nowhere"))
    base_case(tmp_path)
    sweep = load_sweep(
        sweep_file(tmp_path, '[sweep.parameters]\n"engine.speed_rpm" = [1000, 1000.0000000000001]\n')
    )
    with pytest.raises(InputError, match="both get the name speed_rpm-1000"):
        expand(sweep)


def test_is_sweep_file(tmp_path):
    base = base_case(tmp_path)
    assert is_sweep_file(sweep_file(tmp_path, PRODUCT))
    assert not is_sweep_file(base / "case.toml")
    assert not is_sweep_file(base)


@pytest.mark.serial
def test_cli_bad_sweep_is_exit_2_one_line(tmp_path):
    base_case(tmp_path)
    path = sweep_file(tmp_path, '[sweep.parameters]\n"engine.sped_rpm" = [1000]\n')
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_"))}
    result = subprocess.run(
        [sys.executable, "-m", "solver", "batch", str(path), "--list"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "engine.sped_rpm" in lines[0], result.stderr
