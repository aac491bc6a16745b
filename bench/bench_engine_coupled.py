"""Benchmark (not a test): wall time per 720 deg cycle of the reference case with the mixed FE film.

    .venv/bin/python3 bench/bench_engine_coupled.py [--cycles N] [--mesh-size H] [--step-deg D]

Runs the reference engine (cases/reference-2000rpm) on one rank, from the centred pin, for the given
number of cycles (default 2) at the default resolution, and breaks the time down as the run
records it itself (results attributes ``timing.*``, run.log): film solves (operator assembly + VI +
functionals), film Jacobians (sensitivities), the rest of the integration (multibody, Newton linear
algebra, Python), I/O (checkpoints, ParaView fields) and set-up. Counts of film solves, VI iterations,
Jacobians and integrator steps are printed too.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import xarray as xr

from solver.study import simulation
from solver.study.results import TIMING

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

    start = time.perf_counter()
    summary = simulation.run_case(case, MPI.COMM_SELF, progress=False)
    total = time.perf_counter() - start
    # the run's own record of where the time went (results attributes timing.*, one value per cycle)
    with xr.open_dataset(summary.results) as ds:
        timing = {name: np.atleast_1d(ds.attrs[f"timing.{name}"]) for name in TIMING}
        fields_io = float(ds.attrs["timing.fields_io_s"])
    cycles = summary.cycles
    io_total = float(timing["io_s"].sum()) + fields_io
    other_setup = total - float(timing["wall_s"].sum()) - fields_io  # case, mesh, forms, ideal cycle, results
    print(
        f"reference case, mixed-fem, {cycles} cycles, total {total:.1f} s, "
        f"h_min min {summary.h_min_min * 1e6:.4f} um, "
        f"friction power mean {summary.friction_power_mean:.4f} W, "
        f"p_max max {summary.p_max_max / 1e6:.2f} MPa, "
        f"F_asperity max {summary.F_asperity_max:.2f} N"
    )
    print("| per cycle | wall [s] | share |")
    print("|---|---|---|")
    rows = {
        "film solves": timing["film_solve_s"].sum(),
        "film Jacobians": timing["film_jacobian_s"].sum(),
        "multibody, integrator, Python": timing["multibody_s"].sum(),
        "I/O (checkpoints, fields)": io_total,
        "set-up and results": other_setup,
    }
    for name, value in rows.items():
        print(f"| {name} | {value / cycles:.1f} | {100 * value / total:.0f} % |")
    print(f"| **total** | **{total / cycles:.1f}** | |")
    solves, jacobians = timing["film_solves"].sum(), timing["film_jacobians"].sum()
    print(
        f"film solves {solves / cycles:.0f} per cycle "
        f"({1e3 * timing['film_solve_s'].sum() / max(1, solves):.2f} ms each, "
        f"{timing['vi_iterations'].sum() / max(1, solves):.2f} VI iterations each), "
        f"Jacobians {jacobians / cycles:.0f} per cycle "
        f"({1e3 * timing['film_jacobian_s'].sum() / max(1, jacobians):.2f} ms each), "
        f"integrator steps {timing['steps'].sum() / cycles:.0f} per cycle "
        f"({timing['rejected_steps'].sum() / cycles:.0f} rejected)"
    )
    print(
        "wall time of each cycle [s]: "
        + ", ".join(f"{w:.1f}" for w in timing["wall_s"])
        + " (the first starts from the centred pin)"
    )
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
