"""Benchmark (not a test): an engine case from its ideal-joint start to a crank angle, for the cost of the
film solves in a window of the first cycle (a whole cycle of the elastic JFO case takes minutes).

    PYTHONPATH=CHECKOUT .venv/bin/python3 bench/bench_engine_window.py CASE --to DEG

Integrates CASE (a case directory, or a name under cases/) as ``python3 -m solver run`` does its first
cycle and stops at the first output at or past DEG degrees of crank angle. Prints the film solves, their
Newton (VI) iterations, the cpu seconds of the whole window (``time.process_time``), the seconds in the
film solves per solve (the film's own counters) and the small end's min h_min and the mean friction power
over the window: equal answers, equal work; two versions of the code are compared with PYTHONPATH, one
after the other on one core.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from solver.case import load_case
from solver.study import cycles
from solver.study.simulation import Run

ROOT = Path(__file__).resolve().parents[1]


class _Reached(Exception):
    """The window's end."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", help="a case directory, or a name under cases/")
    parser.add_argument("--to", type=float, required=True, help="crank angle to stop at [deg]")
    args = parser.parse_args()
    path = Path(args.case) if Path(args.case).is_dir() else ROOT / "cases" / args.case
    run = Run(load_case(path), MPI.COMM_SELF, "mixed-fem")
    model = run.model
    before = model.stats.copy()
    rows: list[tuple[float, float]] = []

    def progress(cycle, angle, h_min):
        rows.append((angle, h_min))
        if angle >= args.to:
            raise _Reached

    saved = cycles.CHUNK_DEG
    cycles.CHUNK_DEG = 1.0  # a report at every output (of 1 deg)
    start = time.process_time()
    try:
        run.integrate_cycle(0, *run.em.initial_state(0.0), progress=progress)
    except _Reached:
        pass
    finally:
        cycles.CHUNK_DEG = saved
    cpu = time.process_time() - start
    after = dataclasses.asdict(model.stats)
    stats = {key: after[key] - value for key, value in dataclasses.asdict(before).items()}
    h_min = min(h for _, h in rows)
    solves = stats["solves"]
    print(
        f"{path.name} to {rows[-1][0]:g} deg: cpu {cpu:.1f} s; {solves} film solves, "
        f"{stats['vi_iterations'] / solves:.2f} iterations, {stats['solve_seconds'] / solves * 1e3:.2f} "
        f"ms per solve, {stats['jacobians']} Jacobians; min h_min {h_min:.10e} m, "
        f"h_min sum {np.sum([h for _, h in rows]):.12e}"
    )


if __name__ == "__main__":
    main()
