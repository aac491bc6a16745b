"""Benchmark (not a test): the cost of one engine cycle with the small end's finite-element film alone and
with the big end's as well (``big_end.joint = "mixed-fem"``), side by side (issue 33's target: at most 2.2 x).

    .venv/bin/python3 bench/bench_two_films.py [--mesh-size 0.07] [--step-deg 1] [--cycles 2] [--supply none]

Both runs are the reference case (cases/reference-2000rpm) with the same film mesh (``solver.mesh_size``
relative to each joint's radius), output step and tolerances; the one has the ideal big end, the other
the FE big end (its default geometry; ``--supply hole`` adds the crankpin's hole at 3 bar). Each
integrates ``--cycles`` cycles from the centred start and times the last one (the first carries the
start's transient). Printed per run: the last cycle's wall time, the films' solves and Jacobians and
their seconds, the integrator's steps and rejections, the films' degrees of freedom; then the ratio of
the wall times.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from solver.case import load_case
from solver.study import simulation

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "reference-2000rpm"


def case_with(directory: Path, big_end: str, mesh_size: float, step_deg: float, supply: str) -> Path:
    """The reference case with the big end's model, the film mesh and the output step."""
    text = (CASE / "case.toml").read_text()
    big = f'joint = "{big_end}"\nsupply = "{supply}"'
    text = re.sub(r'^joint = "ideal".*$', big, text, count=1, flags=re.M)
    text = re.sub(r"^mesh_size = .*$", f"mesh_size = {mesh_size}", text, count=1, flags=re.M)
    text = re.sub(r"^step_deg = .*$", f"step_deg = {step_deg}", text, count=1, flags=re.M)
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "case.toml").write_text(text)
    return directory


def one_run(directory: Path, cycles: int) -> dict[str, float]:
    """Integrate the cycles of the case; the TIMING of the last one, and the films' sizes."""
    run = simulation.Run(load_case(directory), MPI.COMM_SELF, "mixed-fem")
    try:
        state = run.em.initial_state(0.0)
        begin = time.perf_counter()
        for cycle in range(cycles):
            output, state = run.integrate_cycle(cycle, *state)
        timing = dict(output.timing)
        timing["total_s"] = time.perf_counter() - begin
        timing["small_end_dofs"] = run.model.dofs
        timing["big_end_dofs"] = run.big_model.dofs if run.big_model is not None else 0
        return timing
    finally:
        for model in run.film_models:
            model.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mesh-size", type=float, default=0.07, help="solver.mesh_size of both films")
    parser.add_argument("--step-deg", type=float, default=1.0, help="solver.step_deg")
    parser.add_argument("--cycles", type=int, default=2, help="cycles per run (the last one is timed)")
    parser.add_argument("--supply", choices=("none", "hole"), default="none", help="big_end.supply")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-two-films-") as work:
        rows = {}
        for name, big_end in (("small end FE alone", "ideal"), ("small end + big end FE", "mixed-fem")):
            supply = args.supply if big_end == "mixed-fem" else "none"
            directory = case_with(Path(work) / big_end, big_end, args.mesh_size, args.step_deg, supply)
            rows[name] = one_run(directory, args.cycles)
    print(
        f"mesh_size {args.mesh_size:g} R, step {args.step_deg:g} deg, cycle {args.cycles} of {args.cycles} "
        f"timed (big end supply: {args.supply})"
    )
    print(
        f"{'run':<24} {'cycle s':>8} {'solves':>7} {'solve s':>8} {'jacobians':>9} {'jac s':>6} "
        f"{'steps':>6} {'rejected':>8} {'dofs (small, big)':>18}"
    )
    for name, t in rows.items():
        print(
            f"{name:<24} {t['wall_s']:8.1f} {t['film_solves']:7.0f} {t['film_solve_s']:8.1f} "
            f"{t['film_jacobians']:9.0f} {t['film_jacobian_s']:6.1f} {t['steps']:6.0f} "
            f"{t['rejected_steps']:8.0f} "
            f"{t['small_end_dofs']:>8.0f}, {t['big_end_dofs']:<8.0f}"
        )
    alone, both = rows.values()
    print(f"ratio (both / alone): {both['wall_s'] / alone['wall_s']:.2f} x (issue 33's target: <= 2.2 x)")


if __name__ == "__main__":
    main()
