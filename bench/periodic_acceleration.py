"""A case to its periodic state with the plain cycles and with the extrapolated ones, side by side.

    .venv/bin/python3 bench/periodic_acceleration.py cases/reference-2000rpm-jfo
    .venv/bin/python3 bench/periodic_acceleration.py cases/reference-2000rpm-ehd-jfo --only mpe

Copies the case directory twice into a temporary directory, sets ``solver.periodic_acceleration`` to
``"none"`` and to ``"mpe"`` (the case's other keys as they are) and runs each with ``python3 -m solver
run CASE --json`` (the command line only). Prints, per run, the cycles to periodic, min h_min, the mean
friction power, max p_max, the wall time, and per cycle min h_min, the friction and the change of
each part of the state (results.nc ``history.*``), then the two runs' differences against the case's
own tolerances (``periodic_tolerance`` x clearance, ``periodic_friction_tolerance``).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from solver.study.periodic import STATE_PARTS as PARTS  # the parts whose change each cycle logs


def with_acceleration(source: Path, work: Path, acceleration: str) -> Path:
    """A copy of the case directory with solver.periodic_acceleration = ``acceleration``."""
    case = work / acceleration / source.name
    shutil.copytree(source, case, ignore=shutil.ignore_patterns("results"))
    text = (case / "case.toml").read_text()
    text = re.sub(r"^periodic_acceleration\s*=.*$", "", text, flags=re.MULTILINE)
    key = f'periodic_acceleration = "{acceleration}"'
    text = (
        text.replace("[solver]", f"[solver]\n{key}", 1)
        if "[solver]" in text
        else text + f"\n[solver]\n{key}\n"
    )
    (case / "case.toml").write_text(text)
    return case


def run(case: Path) -> dict:
    """``python3 -m solver run CASE --json``: its JSON, and results.nc's per-cycle histories."""
    done = subprocess.run(
        [sys.executable, "-m", "solver", "run", str(case), "--json", "--quiet", "--restart"],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"{case}: exit {done.returncode}: {done.stderr.strip().splitlines()[-1:]}")
    out = json.loads(done.stdout)
    with xr.open_dataset(out["results"]) as ds:
        out["history"] = {k[8:]: np.atleast_1d(v) for k, v in ds.attrs.items() if k.startswith("history.")}
        out["clearance"] = ds.attrs["small_end.clearance_um"] * 1e-6
        out["h_tol"] = ds.attrs["solver.periodic_tolerance"]
        f_tol = ds.attrs.get("solver.periodic_friction_tolerance")
        out["f_tol"] = float(f_tol) if isinstance(f_tol, (int, float)) else float("nan")  # (absent: off)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", type=Path, help="the case directory")
    parser.add_argument("--only", choices=("none", "mpe"), help="run one of the two")
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as work:
        for acceleration in [args.only] if args.only else ["none", "mpe"]:
            out = run(with_acceleration(args.case.resolve(), Path(work), acceleration))
            results[acceleration] = out
            print(
                f"{acceleration}: {out['cycles']} cycles, periodic {out['periodic']}, min h_min "
                f"{out['h_min_min_m'] * 1e6:.5g} um, mean friction power "
                f"{out['friction_power_mean_W']:.5g} W, "
                f"max p_max {out['p_max_max_Pa'] / 1e6:.5g} MPa, {out['wall_time_s']:.0f} s"
            )
            history = out["history"]
            for k in range(len(history["h_min_min"])):
                parts = ", ".join(
                    f"{name} {history[f'state_change_{name}'][k]:.3g}"
                    for name in PARTS
                    if f"state_change_{name}" in history and np.isfinite(history[f"state_change_{name}"][k])
                )
                start = " (extrapolated start)" if history["extrapolated_start"][k] else ""
                print(
                    f"  cycle {k + 1}{start}: min h_min {history['h_min_min'][k] * 1e6:.5g} um, friction "
                    f"{history['friction_power_mean'][k]:.5g} W; change over the cycle: {parts}"
                )
    if len(results) == 2:
        plain, mpe = results["none"], results["mpe"]
        dh = abs(mpe["h_min_min_m"] - plain["h_min_min_m"]) / plain["clearance"]
        df = abs(mpe["friction_power_mean_W"] / plain["friction_power_mean_W"] - 1)
        print(
            f"mpe against none: {mpe['cycles']} against {plain['cycles']} cycles; min h_min {dh:.2g} of the "
            f"clearance (tolerance {plain['h_tol']:g}), friction {df:.2g} (tolerance {plain['f_tol']:g})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
