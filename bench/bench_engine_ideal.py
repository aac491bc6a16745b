"""Time one 720 deg cycle of the reference engine with ideal joints (the floor under the coupled run).

    /usr/bin/python3 bench/bench_engine_ideal.py [--case cases/reference-2000rpm] [--rtol 1e-6] [--repeat 3]

Rows: the kinematic evaluation (constraint equations per crank angle, 0.5 deg grid), the explicit
integrators (RK45, DOP853) and the implicit ones (ESDIRK32 with full Newton, scipy's Radau and BDF),
all writing outputs on the 0.5 deg grid. Columns: best wall time of ``--repeat`` runs, accepted steps,
force evaluations by the integrator (without / with Jacobian), evaluations for the outputs, and the
largest deviation of the pin force from the kinematic solution (relative to its peak; the grid points
at the gas-force jumps, 0/540/720 deg, are excluded). With a film, every force evaluation becomes a
finite-element solve, so the evaluation counts are what carries over.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver.case import load_case  # noqa: E402
from solver.dynamics.engine import engine_from_case, simulate_ideal  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default_case = Path(__file__).resolve().parents[1] / "cases" / "reference-2000rpm"
    parser.add_argument("--case", default=str(default_case))
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--step-deg", type=float, default=0.5)
    args = parser.parse_args()
    engine = engine_from_case(load_case(args.case))
    runs = [
        ("kinematic", None),
        ("explicit", "RK45"),
        ("explicit", "DOP853"),
        ("implicit", "ESDIRK32"),
        ("implicit", "Radau"),
        ("implicit", "BDF"),
    ]
    reference = simulate_ideal(engine, step_deg=args.step_deg)
    smooth = ~np.isin(reference.crank_angle, [0.0, 540.0, 720.0])
    peak = np.max(np.abs(reference.small_end_force))
    print(
        f"# {engine.name}: {engine.crank_motion.speed * 60 / (2 * np.pi):g} rpm, one 720 deg cycle, "
        f"outputs every {args.step_deg:g} deg, rtol {args.rtol:g}, best of {args.repeat}"
    )
    print(
        f"{'integrator':<12} {'time [s]':>9} {'steps':>6} {'f evals':>8} {'f+J evals':>9} "
        f"{'output evals':>12} {'pin force dev':>13}"
    )
    for integrator, method in runs:
        best, cycle = np.inf, None
        for _ in range(args.repeat):
            start = time.perf_counter()
            cycle = simulate_ideal(
                engine, step_deg=args.step_deg, integrator=integrator, method=method, rtol=args.rtol
            )
            best = min(best, time.perf_counter() - start)
        deviation = np.max(np.abs(cycle.small_end_force - reference.small_end_force)[smooth]) / peak
        print(
            f"{cycle.integrator:<12} {best:9.3f} {cycle.n_steps:6d} {cycle.n_force_evaluations:8d} "
            f"{cycle.n_jacobian_evaluations:9d} {cycle.n_output_evaluations:12d} {deviation:13.1e}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
