"""Benchmark (not a test): the film solves and Jacobians of one engine cycle, replayed on a fresh film.

    .venv/bin/python3 bench/bench_film_cycle.py [--calls FILE] [--repeat N]

The first run integrates two cycles of the reference case (cases/reference-2000rpm) and records every
call of the second (periodic) cycle to the film: the kinematics of each solve, in order, and where a
Jacobian was asked for (FILE, default /tmp/tribo-film-calls.npy; kept for the next runs). Then it
replays them on a fresh film model, in the same order, so that every solve has the warm start it had
in the run, and prints the time per solve and per Jacobian (median of N replays), the VI iterations
per solve and a checksum of the results (sums of h_min, p_max, torques and Jacobian entries: equal
checksums mean equal answers). Unlike the whole engine run, the replay does not depend on the
integrator's path, so two versions of the film code are compared on the very same states.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from solver.case import load_case
from solver.dynamics.engine import engine_from_case
from solver.dynamics.joint import joint_from_case

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "reference-2000rpm"


def record(path: Path) -> None:
    from solver.study import simulation

    run = simulation.Run(load_case(CASE), MPI.COMM_SELF, "mixed-fem")
    model = run.model
    calls: list[tuple] = []
    solve, jacobian = model.solve, model.jacobian

    def recorded_solve(kin, time_s=None):
        calls.append((0.0, *kin.ecc, *kin.ecc_rate, kin.omega_journal, kin.omega_bushing))
        return solve(kin, time_s)

    def recorded_jacobian():
        calls.append((1.0,) + (0.0,) * 6)
        return jacobian()

    model.solve, model.jacobian = recorded_solve, recorded_jacobian
    state = run.em.initial_state(0.0)
    _, state = run.integrate_cycle(0, *state)
    calls.clear()
    run.integrate_cycle(1, *state)
    np.save(path, np.array(calls))


def replay(calls: np.ndarray) -> tuple[float, float, float, np.ndarray]:
    from solver.film.bearing import Kinematics

    case = load_case(CASE)
    _, model = joint_from_case(case, engine_from_case(case), MPI.COMM_SELF, "mixed-fem")
    checksum = np.zeros(5)
    with model:
        for row in calls:
            if row[0] == 0.0:
                r = model.solve(Kinematics(tuple(row[1:3]), tuple(row[3:5]), row[5], row[6]))
                checksum[:4] += (r.h_min, r.p_max, r.torque_journal, r.torque_bushing)
            else:
                checksum[4] += float(np.sum(model.jacobian().matrix))
        s = model.stats
        return (
            1e3 * s.solve_seconds / s.solves,
            1e3 * s.jacobian_seconds / max(1, s.jacobians),
            s.vi_iterations / s.solves,
            checksum,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=Path, default=Path("/tmp/tribo-film-calls.npy"))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    if not args.calls.exists():
        start = time.perf_counter()
        record(args.calls)
        print(
            f"recorded the film calls of the periodic cycle in {time.perf_counter() - start:.0f} s: "
            f"{args.calls}"
        )
    calls = np.load(args.calls)
    runs = [replay(calls) for _ in range(args.repeat)]
    solves, jacobians = int(np.sum(calls[:, 0] == 0)), int(np.sum(calls[:, 0] == 1))
    print(
        f"{solves} film solves: {statistics.median(r[0] for r in runs):.3f} ms each "
        f"({runs[0][2]:.2f} VI iterations); {jacobians} Jacobians: "
        f"{statistics.median(r[1] for r in runs):.3f} ms each "
        f"(medians of {args.repeat} replays)"
    )
    print("checksum (h_min, p_max, torques, Jacobians): " + " ".join(f"{v:.10e}" for v in runs[0][3]))


if __name__ == "__main__":
    main()
