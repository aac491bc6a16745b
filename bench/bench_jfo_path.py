"""Benchmark (not a test): the cpu time of a JFO film solve along a path of committed transient states.

    PYTHONPATH=CHECKOUT .venv/bin/python3 bench/bench_jfo_path.py CASE [--states N] [--profile SORT]

Builds the small end's film of CASE (a case directory, or a name under cases/) as the engine run does
(solver.dynamics.joint.joint_from_case), then solves N states (default 200) 20 us apart, each committed
as the film's history (the JFO film fraction's and the deformation's rates), the eccentricity ratio
going from 0.5 to 0.97 and back while its angle turns by 0.3 rad, with squeeze and both surfaces
turning (0.3 and -0.2 of 2000 rpm); a Jacobian every fifth state. Prints the median and mean cpu time
of a solve (``time.process_time``: less sensitive than wall time to other work on the machine), the
mean Newton iterations and a checksum of the results (equal checksums: equal answers); with
``--profile`` a cProfile of the solves, sorted by SORT (``cumulative``, ``tottime``). The first five
states are left out of the statistics. Another checkout's code is measured with PYTHONPATH=CHECKOUT.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from solver.case import load_case
from solver.dynamics.engine import engine_from_case
from solver.dynamics.joint import joint_from_case
from solver.film.bearing import Kinematics

ROOT = Path(__file__).resolve().parents[1]
SKIP = 5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", help="a case directory, or a name under cases/")
    parser.add_argument("--states", type=int, default=200)
    parser.add_argument("--profile", choices=("cumulative", "tottime"))
    args = parser.parse_args()
    path = Path(args.case) if Path(args.case).is_dir() else ROOT / "cases" / args.case
    case = load_case(path)
    _, model = joint_from_case(case, engine_from_case(case), MPI.COMM_SELF, "mixed-fem")
    C, omega, dt, n = model.bearing.clearance, 2000 * 2 * np.pi / 60, 2e-5, args.states
    eps = np.concatenate([np.linspace(0.5, 0.97, n // 2), np.linspace(0.97, 0.5, n - n // 2)])
    cpu, iterations, checksum = [], [], 0.0
    profile = cProfile.Profile() if args.profile else None
    with model:
        for k, e in enumerate(eps):
            angle = -1.4 + 0.3 * k / n
            rate = (eps[min(k + 1, n - 1)] - e) * C / dt
            direction = np.array([np.cos(angle), np.sin(angle)])
            kin = Kinematics(tuple(e * C * direction), tuple(rate * direction), 0.3 * omega, -0.2 * omega)
            if profile is not None and k >= SKIP:
                profile.enable()
            start = time.process_time()
            result = model.solve(kin, k * dt)
            cpu.append(time.process_time() - start)
            if k % 5 == 0:
                model.jacobian()
            if profile is not None:
                profile.disable()
            iterations.append(result.iterations)
            checksum += result.h_min + result.p_max * 1e-15 + result.torque_journal
            model.commit_history(model.history_state(), k * dt)
    print(
        f"{path.name}: {n} solves, cpu per solve median {1e3 * statistics.median(cpu[SKIP:]):.2f} ms, "
        f"mean {1e3 * statistics.mean(cpu[SKIP:]):.2f} ms; {np.mean(iterations[SKIP:]):.2f} Newton "
        f"iterations; checksum {checksum!r}"
    )
    if profile is not None:
        pstats.Stats(profile).sort_stats(args.profile).print_stats(30)


if __name__ == "__main__":
    main()
