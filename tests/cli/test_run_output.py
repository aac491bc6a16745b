"""``run --output DIR`` and the refusal to overwrite another case's or joint's results without --force.

The ideal joint (no film, no cycles: about a second a run) is enough: the check is made before the run.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import xarray as xr

from tests.conftest import assert_one_line_error, run_cli

IDEAL = '[solver]\njoint = "ideal"\nstep_deg = 9\n'


def make_case(root: Path, name: str) -> Path:
    (root / name).mkdir(parents=True)
    (root / name / "case.toml").write_text(f'name = "{name}"\n{IDEAL}')
    return root / name


def owner(path: Path) -> tuple[str, str]:
    with xr.open_dataset(path) as ds:
        return ds.attrs["name"], ds.attrs["joint"]


@pytest.mark.slow
def test_run_writes_into_output_and_refuses_to_overwrite_another_joint_or_case(tmp_path):
    """--output DIR gets the results (the case's results/ nothing); the same DIR with another joint or
    another case is bad input naming --output and --force (exit 2, the file untouched); --force
    overwrites; the default directory is protected the same way."""
    case, other = make_case(tmp_path, "a"), make_case(tmp_path, "b")
    out = tmp_path / "runs" / "a-ideal"
    result = run_cli("run", str(case), "--output", str(out), "--json")
    assert result.returncode == 0, result.stderr
    assert (out / "results.nc").is_file() and not (case / "results").exists()
    assert owner(out / "results.nc") == ("a", "ideal")
    before = (out / "results.nc").stat().st_mtime_ns

    refused = run_cli("run", str(case), "--joint", "short-bearing", "--output", str(out))
    assert_one_line_error(refused, "--output", "--force", "joint ideal", "short-bearing")
    refused = run_cli("run", str(other), "--output", str(out))
    assert_one_line_error(refused, "--output", "--force", "case a")
    assert (out / "results.nc").stat().st_mtime_ns == before

    again = run_cli("run", str(case), "--output", str(out), "--json")  # the same case and joint: a rerun
    assert again.returncode == 0, again.stderr
    forced = run_cli("run", str(other), "--output", str(out), "--force", "--json")
    assert forced.returncode == 0, forced.stderr
    assert owner(out / "results.nc") == ("b", "ideal")

    default = run_cli("run", str(case), "--json")
    assert default.returncode == 0 and (case / "results" / "results.nc").is_file()
    refused = run_cli("run", str(case), "--joint", "dry")
    assert_one_line_error(refused, "--output", "--force")
    assert owner(case / "results" / "results.nc") == ("a", "ideal")


def test_output_that_is_a_file_is_bad_input(tmp_path):
    case = make_case(tmp_path, "a")
    (tmp_path / "file").write_text("x")
    assert_one_line_error(run_cli("run", str(case), "--output", str(tmp_path / "file")), "--output")
