"""``compare``: the joint column, and labels that survive copying a results file elsewhere.

Reference: the attributes written into the small results files here (``name``, ``joint``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import xarray as xr

from tests.conftest import run_cli


def results_file(path: Path, name: str, joint: str) -> Path:
    angle = np.linspace(0.0, 720.0, 81)
    ds = xr.Dataset(
        {
            "h_min": ("crank_angle", (3 + np.cos(np.radians(angle))) * 1e-6),
            "p_max": ("crank_angle", 1e7 + 0 * angle),
            "F_asperity": ("crank_angle", 0 * angle),
            "friction_power": ("crank_angle", 1 + 0 * angle),
        },
        coords={"crank_angle": angle},
        attrs={"status": "complete", "name": name, "joint": joint},
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return path


def test_compare_labels_copied_files_by_their_case_and_shows_the_joint(tmp_path):
    """A case directory keeps its directory's name; a results.nc copied to another directory is
    labelled by the case name stored in it (not "results"); a ``run --output`` directory (results.nc
    directly inside) is accepted; every row and the table have the joint."""
    case = tmp_path / "reference-2000rpm"
    results_file(case / "results" / "results.nc", "reference-2000rpm", "mixed-fem")
    copied = tmp_path / "elsewhere" / "results.nc"
    copied.parent.mkdir()
    shutil.copy(results_file(tmp_path / "x" / "results" / "results.nc", "part-load", "short-bearing"), copied)
    output_dir = tmp_path / "runs" / "dry-run"
    results_file(output_dir / "results.nc", "reference-2000rpm", "dry")
    result = run_cli("compare", str(case), str(copied), str(output_dir), "--json")
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)["runs"]
    assert [r["run"] for r in rows] == ["reference-2000rpm", "part-load", "dry-run"]
    assert [r["joint"] for r in rows] == ["mixed-fem", "short-bearing", "dry"]
    table = run_cli("compare", str(case), str(copied))
    assert table.returncode == 0, table.stderr
    header, *lines = table.stdout.splitlines()
    assert "joint" in header.split()
    assert lines[1].split()[:2] == ["part-load", "short-bearing"]
