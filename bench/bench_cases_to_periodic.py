"""Benchmark (not a test): shipped cases run from a fresh start to their periodic answer, side by side.

    .venv/bin/python3 bench/bench_cases_to_periodic.py CASE [CASE ...] [--rounds K]

Each round runs every case once, in the order given, through the command line only (``python3 -m solver
run CASE --json --restart`` on a copy of the case directory, so nothing shipped is written), and prints its
wall time to the periodic state (the run's ``wall_time_s``, set-up included), the number of cycles, whether
it is periodic, and its answers (min h_min, max p_max, mean friction power); then the median wall time of
each case over the rounds and its ratio to the first case's. E.g. issue 33's target, the floating-pin case
to periodic within the cost of the elastic reference case::

    bench/bench_cases_to_periodic.py cases/reference-2000rpm-ehd cases/reference-2000rpm-floating-pin

The machine's speed drifts: compare only the runs of one sitting.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_once(case: Path, work: Path) -> dict:
    """One run of a copy of ``case`` from a fresh start; the run's --json report."""
    copy = work / case.name
    if copy.exists():
        shutil.rmtree(copy)
    copy.mkdir(parents=True)
    shutil.copy(case / "case.toml", copy / "case.toml")
    for extra in case.iterdir():  # pressure traces or speed files the case refers to
        if extra.is_file() and extra.name != "case.toml":
            shutil.copy(extra, copy / extra.name)
    proc = subprocess.run(
        [sys.executable, "-m", "solver", "run", str(copy), "--json", "--restart"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        raise SystemExit(f"error: {case.name} failed: {proc.stderr.strip().splitlines()[-1:]}")
    return json.loads(proc.stdout)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("cases", nargs="+", type=Path)
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args()
    times: dict[str, list[float]] = {case.name: [] for case in args.cases}
    with tempfile.TemporaryDirectory(prefix="bench-periodic-") as tmp:
        for k in range(args.rounds):
            for case in args.cases:
                report = run_once(case.resolve(), Path(tmp))
                times[case.name].append(report["wall_time_s"])
                print(
                    f"round {k + 1} {case.name:<36} {report['wall_time_s']:8.1f} s  "
                    f"{report['cycles']} cycles  "
                    f"periodic {report['periodic']}  min h_min {report['h_min_min_m'] * 1e6:.4f} um  "
                    f"max p_max {report['p_max_max_Pa'] / 1e6:.2f} MPa  friction "
                    f"{report['friction_power_mean_W']:.4f} W",
                    flush=True,
                )
    first = statistics.median(times[args.cases[0].name])
    for name, values in times.items():
        median = statistics.median(values)
        print(
            f"{name:<36} median {median:8.1f} s over {len(values)} run(s), {median / first:.2f} x the first"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
