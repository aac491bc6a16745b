"""A case to its periodic state with the plain cycles and with the accelerated ones, side by side.

    .venv/bin/python3 bench/periodic_acceleration.py cases/reference-2000rpm-jfo
    .venv/bin/python3 bench/periodic_acceleration.py cases/reference-2000rpm-ehd-jfo --only film

Copies the case directory into a temporary directory once per ``solver.periodic_acceleration`` value
(``"none"``, then ``"mpe"`` and, for a mass-conserving film, ``"film"``; or those given with ``--only``;
the case's other keys as they are) and runs each with ``python3 -m solver run CASE --json`` (the command
line only). Prints, per run, the cycles to periodic, min h_min, the mean friction power, max p_max,
the wall time and the film solves (the coupled cycles' and the film alone's), and per cycle min h_min,
the friction, the change of each part of the state and the film cycles of the film alone (results.nc
``history.*``, ``timing.*``), then each accelerated run's differences from the plain one against the
case's own tolerances (``periodic_tolerance`` x clearance, ``periodic_friction_tolerance``).
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

from solver.case import load_case
from solver.study.periodic import ACCELERATIONS
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
        out["timing"] = {k[7:]: np.atleast_1d(v) for k, v in ds.attrs.items() if k.startswith("timing.")}
        out["clearance"] = ds.attrs["small_end.clearance_um"] * 1e-6
        out["h_tol"] = ds.attrs["solver.periodic_tolerance"]
        f_tol = ds.attrs.get("solver.periodic_friction_tolerance")
        out["f_tol"] = float(f_tol) if isinstance(f_tol, (int, float)) else float("nan")  # (absent: off)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", type=Path, help="the case directory")
    parser.add_argument("--only", nargs="+", choices=ACCELERATIONS, help="run these only")
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as work:
        jfo = load_case(args.case).oil.cavitation == "jfo"  # ("film" is for the mass-conserving film)
        for acceleration in args.only or [a for a in ACCELERATIONS if jfo or a != "film"]:
            out = run(with_acceleration(args.case.resolve(), Path(work), acceleration))
            results[acceleration] = out
            print(
                f"{acceleration}: {out['cycles']} cycles, periodic {out['periodic']}, min h_min "
                f"{out['h_min_min_m'] * 1e6:.5g} um, mean friction power "
                f"{out['friction_power_mean_W']:.5g} W, "
                f"max p_max {out['p_max_max_Pa'] / 1e6:.5g} MPa, {out['wall_time_s']:.0f} s, film solves "
                f"{np.nansum(out['timing']['film_solves']):.0f} in the cycles + "
                f"{np.nansum(out['timing'].get('film_alone_solves', [0])):.0f} alone"
            )
            history = out["history"]
            for k in range(len(history["h_min_min"])):
                parts = ", ".join(
                    f"{name} {history[f'state_change_{name}'][k]:.3g}"
                    for name in PARTS
                    if f"state_change_{name}" in history and np.isfinite(history[f"state_change_{name}"][k])
                )
                start = " (extrapolated start)" if history["extrapolated_start"][k] else ""
                alone = history.get("film_alone_cycles", np.zeros(k + 1))[k]
                after = f"; then {alone:.0f} film cycles of the film alone" if alone > 0 else ""
                print(
                    f"  cycle {k + 1}{start}: min h_min {history['h_min_min'][k] * 1e6:.5g} um, friction "
                    f"{history['friction_power_mean'][k]:.5g} W; change over the cycle: {parts}{after}"
                )
    plain = results.get("none")
    for name, out in results.items():
        if plain is None or name == "none":
            continue
        dh = abs(out["h_min_min_m"] - plain["h_min_min_m"]) / plain["clearance"]
        df = abs(out["friction_power_mean_W"] / plain["friction_power_mean_W"] - 1)
        print(
            f"{name} against none: {out['cycles']} against {plain['cycles']} cycles; min h_min {dh:.2g} of "
            f"the clearance (tolerance {plain['h_tol']:g}), friction {df:.2g} (tolerance {plain['f_tol']:g})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
