"""summary.nc as xarray reads it: integer ``cycles``, 0/1 ``periodic`` flags, finished cases ``complete``
whether or not they ran again (``ran_this_invocation`` says which), cumulative ``run_time``.

References: the cases' own results files (their ``cycles``, ``periodic``, ``wall_time_s`` attributes)
and the batch's own records; the ideal joint (about a second a case) suffices.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from solver.cli import main

IDEAL = '[solver]\njoint = "ideal"\nstep_deg = 9\n'


def write(root: Path, cases: dict[str, str]) -> list[Path]:
    for name, text in cases.items():
        (root / name).mkdir(parents=True)
        (root / name / "case.toml").write_text(text)
    return [root / name for name in cases]


def summary(root: Path) -> xr.Dataset:
    with xr.open_dataset(root / "summary.nc") as ds:
        return ds.load()


@pytest.mark.serial
def test_summary_types_flags_and_finished_cases(tmp_path):
    cases = write(
        tmp_path,
        {
            "a": IDEAL,
            "b-invalid": IDEAL + "[small_end]\nclearance_um = 20000\n",
            "c": IDEAL.replace("[solver]", "[engine]\nspeed_rpm = 3000\n[solver]"),
        },
    )
    assert main(["batch", *map(str, cases)]) == 1
    ds = summary(tmp_path)
    # integers, as netCDF stores them and xarray gives them back (no fill value turning them to floats)
    assert ds.cycles.dtype == np.int32 and ds.periodic.dtype == np.int8
    assert ds.ran_this_invocation.dtype == np.int8
    for name in ("cycles", "periodic", "ran_this_invocation"):
        assert "_FillValue" not in ds[name].encoding or ds[name].encoding["_FillValue"] is None
    assert list(ds.periodic.attrs["flag_values"]) == [0, 1]
    assert ds.periodic.attrs["flag_meanings"] == "not_periodic periodic"
    with xr.open_dataset(cases[0] / "results" / "results.nc") as res:  # the ideal run: 1 cycle, periodic
        assert (res.attrs["cycles"], res.attrs["periodic"]) == (1, "true")
    assert list(ds.cycles.values) == [1, 0, 1] and list(ds.periodic.values) == [1, 0, 1]
    assert list(ds.status.values) == ["complete", "invalid", "complete"]
    assert list(ds.ran_this_invocation.values) == [1, 1, 1]
    # an old reader's idioms still work on the integers
    assert float(ds.periodic[0]) == 1.0 and int(ds.periodic.sum()) == 2 and not np.isnan(ds.cycles).any()

    # a rerun: the finished cases are complete (not re-run now), the invalid one ran again
    assert main(["batch", *map(str, cases)]) == 1
    ds = summary(tmp_path)
    assert list(ds.status.values) == ["complete", "invalid", "complete"]
    assert list(ds.ran_this_invocation.values) == [0, 1, 0]
    assert ds.attrs["n_complete"] == 2 and ds.attrs["n_skipped"] == 2
    document = json.loads((tmp_path / "batch_status.json").read_text())  # the records keep "skipped"
    assert [r["status"] for r in document["cases"]] == ["skipped", "invalid", "skipped"]
    assert [r["ran_this_invocation"] for r in document["cases"]] == [False, True, False]

    # run_time is the results' wall_time_s (every invocation), the last invocation's part beside it
    for case, (total, last) in zip((cases[0], cases[2]), ((12.5, 4.25), (3.0, 3.0))):
        path = case / "results" / "results.nc"
        with xr.open_dataset(path) as res:
            res = res.load()
        res.attrs.update(wall_time_s=total, wall_time_last_invocation_s=last)
        res.to_netcdf(path)
    assert main(["batch", "--summary-only", *map(str, cases)]) == 1  # b never finishes
    ds = summary(tmp_path)
    assert list(ds.run_time.values[[0, 2]]) == [12.5, 3.0]
    assert list(ds.run_time_last_invocation.values[[0, 2]]) == [4.25, 3.0]
    assert ds.run_time_last_invocation.attrs["units"] == "s"
    assert list(ds.ran_this_invocation.values) == [0, 0, 0]  # --summary-only runs nothing
