"""Batch throughput: the same eight short cases on 1 and on 2 MPI ranks (parallel efficiency, cases/hour).

    .venv/bin/python3 bench/bench_batch.py [--ranks 1 2] [--cases 8] [--joint short-bearing] [--step-deg 5]

The cases are the reference engine with the analytic short-bearing small end, one 720 deg cycle, at
speeds from 1000 to 6000 rpm (so their run times differ and the dynamic schedule matters). Each rank
count runs ``mpirun -n N python3 -m mpi4py -m solver batch`` on a fresh copy of the cases.
Columns: wall time of the whole command (interpreter start-up and imports included) and of the batch
itself (batch_status.json), the sum of the case run times (the serial work), cases per hour, the
parallel efficiency E = T_1 / (N T_N) on both wall times, "busy" = case sum / (N x batch time) (the
share of the ranks' time spent in cases: what the scheduling achieves) and the case slowdown = case
sum / case sum on the first row (above 1 when the cases themselves run slower because the ranks share
cores with each other or with other work). E is about busy / slowdown. On a machine shared with other
work E is a lower bound: run it on idle cores.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEEDS = (1000, 6000, 1500, 5000, 2000, 4000, 2500, 3000, 3500, 4500, 5500, 1250)


def make_cases(root: Path, count: int, joint: str, step_deg: float) -> list[Path]:
    cases = []
    for i in range(count):
        speed = SPEEDS[i % len(SPEEDS)]
        case = root / f"case{i}-{speed}rpm"
        case.mkdir(parents=True)
        (case / "case.toml").write_text(
            f"[engine]\nspeed_rpm = {speed}\n"
            f'[solver]\njoint = "{joint}"\nmax_cycles = 1\nstep_deg = {step_deg:g}\n'
        )
        cases.append(case)
    return cases


def run(ranks: int, root: Path, mpirun: str) -> dict:
    env = {
        **os.environ,
        "OMPI_ALLOW_RUN_AS_ROOT": "1",
        "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
        "OMPI_MCA_rmaps_base_oversubscribe": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": str(ROOT),
    }
    command = [
        mpirun,
        "-n",
        str(ranks),
        sys.executable,
        "-m",
        "mpi4py",
        "-m",
        "solver",
        "batch",
        str(root),
        "--no-summary",
    ]
    start = time.perf_counter()
    result = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        sys.exit(f"batch on {ranks} rank(s) failed:\n{result.stderr}")
    status = json.loads((root / "batch_status.json").read_text())
    work = sum(r["wall_time_s"] for r in status["cases"])
    return {
        "ranks": ranks,
        "wall": wall,
        "batch": status["wall_time_s"],
        "work": work,
        "n": status["n_cases"],
        "per_rank": [sum(r["world_rank"] == k for r in status["cases"]) for k in range(ranks)],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--cases", type=int, default=8)
    parser.add_argument(
        "--joint", default="short-bearing", choices=("short-bearing", "ideal", "dry", "mixed-fem")
    )
    parser.add_argument("--step-deg", type=float, default=5.0)
    parser.add_argument("--mpirun", default="mpirun")
    parser.add_argument("--keep", action="store_true", help="keep the case directories (printed)")
    args = parser.parse_args()
    work_dir = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    rows = []
    try:
        for ranks in args.ranks:
            root = work_dir / f"ranks{ranks}"
            make_cases(root, args.cases, args.joint, args.step_deg)
            rows.append(run(ranks, root, args.mpirun))
    finally:
        if args.keep:
            print(f"# cases kept in {work_dir}")
        else:
            shutil.rmtree(work_dir, ignore_errors=True)
    print(
        f"# {args.cases} cases, {args.joint} joint, 1 cycle, step {args.step_deg:g} deg; "
        f"{os.cpu_count()} cores; "
        f"load average before the last run {os.getloadavg()[0]:.2f}"
    )
    print(
        f"{'ranks':>5} {'command [s]':>11} {'batch [s]':>9} {'case sum [s]':>12} {'cases/hour':>10} "
        f"{'E (command)':>11} {'E (batch)':>9} {'busy':>5} {'case slowdown':>13}  cases per rank"
    )
    base = rows[0]
    for row in rows:
        scale = row["ranks"] / base["ranks"]
        e_wall = base["wall"] / (scale * row["wall"])
        e_batch = base["batch"] / (scale * row["batch"])
        busy = row["work"] / (row["ranks"] * row["batch"])  # scheduling: share of rank time spent in cases
        slowdown = row["work"] / base["work"]  # > 1: the cases themselves ran slower (cores shared)
        print(
            f"{row['ranks']:5d} {row['wall']:11.1f} {row['batch']:9.1f} {row['work']:12.1f} "
            f"{row['n'] / row['wall'] * 3600:10.0f} {e_wall:11.2f} {e_batch:9.2f} {busy:5.2f} "
            f"{slowdown:13.2f}  "
            f"{row['per_rank']}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
