"""Benchmark of the film solve (not a test): cold and warm time per solve, VI iterations, dofs and
the So error against Butenschoen's table, at three mesh sizes.

    .venv/bin/python3 bench/bench_film.py [--repeat N] [--cavitation reynolds|jfo]

Case: B/D = 1, eccentricity 0.6, journal rotation (table: So = 1.3146, attitude 50.536 deg).
- setup: mesh generation + forms (JIT compilation is cached; the first-ever run is reported apart);
- cold solve: first solve on a fresh model, starting from P = 0;
- warm solve: a solve after a change of eccentricity of 1e-3 (as between two time steps),
  starting from the previous pressure; median of N.
- numeric LU + solve: the floor of a warm solve, one numeric refactorisation of the same matrix
  (fixed pattern, the converged active set) and one solve with it;
- jacobian: the 4x4 film Jacobian after a solve (back-substitutions with the VI's factorisation).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from mpi4py import MPI

from solver.film.factory import make_film
from solver.film.spec import FilmSpec
from solver.film.types import Bearing, Kinematics

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 2 * math.pi * 50
SO_TABLE, ATTITUDE_TABLE = 1.3146, 50.536


def run(mesh_size: float, repeat: int, cavitation: str = "reynolds") -> dict:
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU)
    start = time.perf_counter()
    spec = FilmSpec(  # steady solves: quasi-static (the max-gap inlet with the JFO film)
        bearing=bearing, omega_ref=OMEGA, mesh_size=mesh_size, cavitation=cavitation, quasi_static=True
    )
    model = make_film(spec, MPI.COMM_SELF)
    setup = time.perf_counter() - start
    direction = -1.0

    def kin(eps: float) -> Kinematics:
        return Kinematics((eps * C * math.cos(direction), eps * C * math.sin(direction)), (0, 0), OMEGA, 0)

    start = time.perf_counter()
    result = model.solve(kin(0.6))
    cold = time.perf_counter() - start
    cold_its = result.iterations
    So = result.load * (C / R) ** 2 / (2 * R * 2 * R * MU * OMEGA)
    warm, its = [], []
    for i in range(repeat):
        start = time.perf_counter()
        r = model.solve(kin(0.6 + 1e-3 * ((i % 2) * 2 - 1)))
        warm.append(time.perf_counter() - start)
        its.append(r.iterations)
    start = time.perf_counter()
    for _ in range(repeat):
        model.jacobian()
    jac = (time.perf_counter() - start) / repeat
    # the floor of a warm solve: one numeric refactorisation of the same matrix and one solve with it
    lu, limit = model.solver.lu, float("nan")
    if lu is not None and cavitation == "reynolds":
        inactive = model.solver.inactive_set()
        b, x = lu.K.createVecs()
        b.set(0.0)
        start = time.perf_counter()
        for _ in range(repeat):
            lu.factor(inactive)
            lu.solve_full(b, x)
        limit = (time.perf_counter() - start) / repeat
    model.close()
    return dict(
        mesh_size=mesh_size,
        dofs=model.dofs,
        setup_s=setup,
        cold_ms=cold * 1e3,
        cold_its=cold_its,
        warm_ms=statistics.median(warm) * 1e3,
        warm_its=statistics.median(its),
        jacobian_ms=jac * 1e3,
        limit_ms=limit * 1e3,
        So_error_pct=100 * (So / SO_TABLE - 1),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument(
        "--cavitation",
        choices=("reynolds", "jfo"),
        default="reynolds",
        help="the film's cavitation model (jfo: the mass-conserving film, steady)",
    )
    args = parser.parse_args()
    start = time.perf_counter()
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU)
    make_film(FilmSpec(bearing=bearing, omega_ref=OMEGA, mesh_size=0.2), MPI.COMM_SELF).close()
    print(f"first model (JIT compilation if not cached): {time.perf_counter() - start:.2f} s")
    header = (
        "| mesh size / R | dofs | setup [s] | cold solve [ms] (VI its) | warm solve [ms] (VI its) | "
        "numeric LU + solve [ms] | Jacobian [ms] | So error vs table |"
    )
    print(header)
    print("|" + "---|" * 8)
    for h in (0.1, 0.07, 0.035):
        r = run(h, args.repeat, args.cavitation)
        print(
            f"| {r['mesh_size']} | {r['dofs']} | {r['setup_s']:.2f} | "
            f"{r['cold_ms']:.1f} ({r['cold_its']}) | "
            f"{r['warm_ms']:.2f} ({r['warm_its']:.0f}) | {r['limit_ms']:.2f} | {r['jacobian_ms']:.1f} | "
            f"{r['So_error_pct']:+.2f} % |"
        )


if __name__ == "__main__":
    main()
