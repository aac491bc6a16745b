"""``python3 -m solver compare``: finished runs side by side.

Reference: the numbers of two small results files written here (a cosine film thickness, a Gaussian
pressure peak), reduced with numpy in the test (min, max, the trapezoidal cycle mean over 720 deg).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from tests.conftest import assert_one_line_error, run_cli


def fake_run(directory: Path, scale: float, elastic: str, complete: bool = True) -> Path:
    """A case directory with a results file in the layout of the run command's."""
    angle = np.linspace(0.0, 720.0, 145)
    h = (5 + 4 * np.cos(np.radians(angle))) * 1e-6 * scale
    p = 1e6 + 3e8 * np.exp(-(((angle - 380) / 20) ** 2)) / scale
    variables = {
        "h_min": h,
        "p_max": p,
        "F_asperity": 100 * np.exp(-(((angle - 500) / 60) ** 2)) / scale,
        "friction_power": 1 + np.sin(np.radians(angle)) ** 2 / scale,
        "deformation_max": 1e-6 * scale * p / p.max(),
        "cavitated_area_ratio": 0.2 + 0.1 * np.cos(np.radians(angle)) ** 2 * scale,
    }
    ds = xr.Dataset(
        {k: ("crank_angle", v) for k, v in variables.items()},
        coords={"crank_angle": angle},
        attrs={
            "status": "complete" if complete else "running",
            "small_end.elastic": elastic,
            "oil.piezoviscosity": "none",
            "oil.cavitation": "jfo" if scale > 1 else "reynolds",
        },
    )
    (directory / "results").mkdir(parents=True)
    ds.to_netcdf(directory / "results" / "results.nc")
    return directory


def test_compare_reports_each_runs_extremes_and_writes_the_plot(tmp_path):
    """The JSON rows hold min h_min, max p_max, max asperity force, max deformation (exact: the same
    values), the trapezoidal cycle means of the friction power and of the cavitated area (1e-12
    relative) and the cavitation model; the PNG is written."""
    rigid = fake_run(tmp_path / "rigid", 1.0, "none")
    elastic = fake_run(tmp_path / "elastic", 2.0, "fe")
    png = tmp_path / "compare.png"
    result = run_cli(
        "compare", str(rigid), str(elastic / "results" / "results.nc"), "--output", str(png), "--json"
    )
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)["runs"]
    assert [r["elastic"] for r in rows] == ["none", "fe"]
    assert [r["cavitation"] for r in rows] == ["reynolds", "jfo"]
    for row, path in zip(rows, (rigid, elastic)):
        with xr.open_dataset(path / "results" / "results.nc") as ds:
            angle = ds.crank_angle.values
            assert row["h_min_min_m"] == float(ds.h_min.min())
            assert row["p_max_max_Pa"] == float(ds.p_max.max())
            assert row["F_asperity_max_N"] == float(ds.F_asperity.max())
            assert row["deformation_max_m"] == float(ds.deformation_max.max())
            mean = float(
                np.sum((ds.friction_power.values[1:] + ds.friction_power.values[:-1]) / 2 * np.diff(angle))
                / 720
            )
            assert abs(row["friction_power_mean_W"] - mean) <= 1e-12 * mean
            c = ds.cavitated_area_ratio.values
            mean = float(np.sum((c[1:] + c[:-1]) / 2 * np.diff(angle)) / 720)
            assert abs(row["cavitated_area_mean"] - mean) <= 1e-12 * mean
    assert png.stat().st_size > 10_000


def test_compare_refuses_an_unfinished_run(tmp_path):
    """A run without a complete results file: one line naming the RUN, exit 2."""
    unfinished = fake_run(tmp_path / "unfinished", 1.0, "none", complete=False)
    assert_one_line_error(run_cli("compare", str(unfinished)), "RUN", "unfinished", "finished run")
