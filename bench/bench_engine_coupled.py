"""Benchmark (not a test): wall time per 720 deg cycle of the reference case with the mixed FE film.

    .venv/bin/python3 bench/bench_engine_coupled.py [--cycles N] [--mesh-size H] [--step-deg D]

Runs the reference engine (cases/reference-2000rpm) on one rank, from the centred pin, for the given
number of cycles (default 2) at the default resolution, and breaks the time down into: film solves
(operator assembly + VI), film Jacobians (sensitivities), the rest of the integration (multibody,
Newton linear algebra, Python), and I/O (results file, plots, ParaView fields). Counts of film
solves, Jacobians and integrator steps are printed too.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from solver.film import bearing
from solver.study import results, simulation

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2)
    parser.add_argument("--mesh-size", type=float, default=None)
    parser.add_argument("--step-deg", type=float, default=None)
    parser.add_argument("--rtol", type=float, default=None)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-engine-"))
    case = work / "reference"
    case.mkdir()
    text = (ROOT / "cases" / "reference-2000rpm" / "case.toml").read_text()
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        if key == "max_cycles":
            line = f"max_cycles = {args.cycles}"
        elif key == "periodic_tolerance":
            line = "periodic_tolerance = 1e-12"  # run exactly --cycles cycles
        elif key == "mesh_size" and args.mesh_size:
            line = f"mesh_size = {args.mesh_size}"
        elif key == "step_deg" and args.step_deg:
            line = f"step_deg = {args.step_deg}"
        elif key == "rtol" and args.rtol:
            line = f"rtol = {args.rtol}"
        lines.append(line)
    (case / "case.toml").write_text("\n".join(lines) + "\n")

    timers = {"film solve": 0.0, "film Jacobian": 0.0, "I/O": 0.0}
    counts = {"film solve": 0, "film Jacobian": 0}

    def timed(name, function):
        def wrapper(*a, **k):
            start = time.perf_counter()
            try:
                return function(*a, **k)
            finally:
                timers[name] += time.perf_counter() - start
                if name in counts:
                    counts[name] += 1
        return wrapper

    bearing.FilmModel.solve = timed("film solve", bearing.FilmModel.solve)
    bearing.FilmModel.jacobian = timed("film Jacobian", bearing.FilmModel.jacobian)
    results.write_results = timed("I/O", results.write_results)
    simulation._Run.write_fields = timed("I/O", simulation._Run.write_fields)
    steps = {}
    original = simulation._Run.integrate_cycle

    cycle_walls = []

    def count_steps(self, *a, **k):
        begin = time.perf_counter()
        out = original(self, *a, **k)
        cycle_walls.append(time.perf_counter() - begin)
        steps["n"] = self.steps
        return out

    simulation._Run.integrate_cycle = count_steps
    start = time.perf_counter()
    summary = simulation.run_case(case, MPI.COMM_SELF, progress=False)
    total = time.perf_counter() - start
    cycles = summary.cycles
    other = total - sum(timers.values())
    print(f"reference case, mixed-fem, {cycles} cycles, total {total:.1f} s, h_min min {summary.h_min_min * 1e6:.3f} um")
    print("| per cycle | wall [s] | share |")
    print("|---|---|---|")
    for name, value in {**timers, "multibody, integrator, Python": other}.items():
        print(f"| {name} | {value / cycles:.1f} | {100 * value / total:.0f} % |")
    print(f"| **total** | **{total / cycles:.1f}** | |")
    print(f"film solves {counts['film solve'] / cycles:.0f} per cycle ({1e3 * timers['film solve'] / max(1, counts['film solve']):.1f} ms each), "
          f"Jacobians {counts['film Jacobian'] / cycles:.0f} per cycle ({1e3 * timers['film Jacobian'] / max(1, counts['film Jacobian']):.1f} ms each), "
          f"integrator steps {steps.get('n', 0) / cycles:.0f} per cycle")
    print("integration wall time of each cycle [s]: " + ", ".join(f"{w:.1f}" for w in cycle_walls)
          + " (the first starts from the centred pin)")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
