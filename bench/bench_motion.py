"""Benchmark (not a test): the film under a prescribed motion against the engine's film, per row and per step.

    taskset -c 1 .venv/bin/python3 bench/bench_motion.py cases/reference-2000rpm-jfo [--mesh-size 0.1]

Runs the case's engine for one cycle from its ideal-joint start (``python3 -m solver run``, with the
``--mesh-size`` override in a copy of the case), takes that cycle's small-end motion from its results
(the pin's eccentricity and its rate in the bushing frame, the relative speed, every output row), and
drives the same film (the engine's own, built from the case: solver.dynamics.joint.joint_from_case)
through it with ``bearing --motion``'s driver (solver.study.motion.drive, from a full film). Prints the
engine's film cost per accepted integrator step and per film solve (results ``timing.*``) and the
motion's per row, and their ratios. Issue 34's target: the cost per row no more than the engine's per
step at the same mesh. The machine's speed drifts: pin to one core, compare runs of one sitting.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from solver.case import load_case  # noqa: E402
from solver.dynamics.engine import engine_from_case  # noqa: E402
from solver.dynamics.joint import joint_from_case  # noqa: E402
from solver.study.motion import Motion, drive  # noqa: E402


def engine_cycle(case_dir: Path, work: Path, mesh_size: float | None) -> Path:
    """One engine cycle of a copy of the case (max_cycles = 1; mesh_size if given): its results.nc."""
    copy = work / case_dir.name
    shutil.copytree(case_dir, copy, ignore=shutil.ignore_patterns("results"))
    text = (copy / "case.toml").read_text()
    for key, value in (("max_cycles", "1"), ("mesh_size", None if mesh_size is None else f"{mesh_size}")):
        if value is None:
            continue
        text = re.sub(rf"^{key}\s*=.*$", "", text, flags=re.MULTILINE)
        text = (
            text.replace("[solver]", f"[solver]\n{key} = {value}", 1)
            if "[solver]" in text
            else (text + f"\n[solver]\n{key} = {value}\n")
        )
    (copy / "case.toml").write_text(text)
    done = subprocess.run(
        [sys.executable, "-m", "solver", "run", str(copy), "--json", "--quiet", "--restart"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"{copy}: exit {done.returncode}: {done.stderr.strip().splitlines()[-1:]}")
    return Path(json.loads(done.stdout)["results"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", type=Path)
    parser.add_argument(
        "--mesh-size", type=float, default=None, help="film element size / R (default: the case's)"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        results = engine_cycle(args.case.resolve(), Path(tmp), args.mesh_size)
        with xr.open_dataset(results) as ds:
            attrs = ds.attrs.copy()
            motion = Motion(
                time=ds["time"].values - float(ds["time"].values[0]),
                ecc=np.column_stack([ds["ecc_x"].values, ds["ecc_y"].values]),
                ecc_rate=np.column_stack([ds["ecc_rate_x"].values, ds["ecc_rate_y"].values]),
                # the engine's film sees the relative speed on the journal, the bushing still
                # (solver.dynamics.joint.FilmJoint.forces)
                omega_journal=ds["omega_rel"].values,
                omega_bushing=np.zeros(ds.sizes["crank_angle"]),
            )
        case = load_case(Path(tmp) / args.case.resolve().name)
        _, model = joint_from_case(case, engine_from_case(case), MPI.COMM_SELF, "mixed-fem")
        begin = time.perf_counter()
        run = drive(model, motion, start="full")
        wall = time.perf_counter() - begin
        model.close()
    last = {
        k: float(np.atleast_1d(attrs[f"timing.{k}"])[-1])
        for k in ("film_solves", "steps", "film_solve_s", "film_jacobian_s")
    }
    solves, steps = last["film_solves"], last["steps"]
    film_s = last["film_solve_s"] + last["film_jacobian_s"]
    rows = len(motion)
    per_step, per_solve, per_row = film_s / steps, film_s / solves, wall / rows
    print(f"case {args.case} (film {attrs['mesh_size']} R, {attrs['film_dofs']} dofs)")
    print(
        f"engine, one cycle: {steps:.0f} accepted steps, {solves:.0f} film solves, {film_s:.2f} s in the "
        f"film (solves and Jacobians): {1e3 * per_step:.2f} ms per step, {1e3 * per_solve:.2f} ms per solve"
    )
    print(
        f"motion, the same cycle's {rows} rows: {wall:.2f} s, {1e3 * per_row:.2f} ms per row "
        f"({run.substeps} internal steps added, {np.mean(run.iterations):.2f} Newton iterations per row)"
    )
    print(f"per row / engine per step: {per_row / per_step:.3f}", end="; ")
    print(f"per row / engine per solve: {per_row / per_solve:.3f}")


if __name__ == "__main__":
    main()
