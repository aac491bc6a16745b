"""Benchmark (not a test): cost of the averaged (rough, mixed) film solve against the smooth one.

    .venv/bin/python3 bench/bench_mixed.py [--repeat N]

Same mesh (default size), the reference small end (R = 10 mm, B = 20 mm, c = 10 um, sigma = 0.32 um),
eccentricity 0.9 (h_min/sigma = 3.2, contact factor and flow factors active, some asperity
contact), warm solves after a 1e-3 change of eccentricity, and the Jacobian after a solve.
"""

from __future__ import annotations

import argparse
import statistics
import time

from mpi4py import MPI

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.surface import Surface


def measure(rough: bool, repeat: int) -> dict:
    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    kwargs = dict(roughness=surface.roughness(), contact=surface.contact()) if rough else {}
    bearing = Bearing(radius=0.01, width=0.02, clearance=10e-6, viscosity=0.01)
    omega = 200.0
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=omega, **kwargs) as model:
        kin = lambda eps: Kinematics((0.0, -eps * 10e-6), (0.0, -0.3 * 10e-6 * omega), omega, 0.3 * omega)  # noqa: E731
        model.solve(kin(0.9))
        times, jac = [], []
        for i in range(repeat):
            start = time.perf_counter()
            model.solve(kin(0.9 + 1e-3 * (i % 2)))
            times.append(time.perf_counter() - start)
            start = time.perf_counter()
            model.jacobian()
            jac.append(time.perf_counter() - start)
        return dict(
            dofs=model.dofs, solve_ms=statistics.median(times) * 1e3, jacobian_ms=statistics.median(jac) * 1e3
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args()
    smooth, rough = measure(False, args.repeat), measure(True, args.repeat)
    print("| film model | dofs | warm solve [ms] | Jacobian [ms] |")
    print("|---|---|---|---|")
    print(f"| smooth Reynolds | {smooth['dofs']} | {smooth['solve_ms']:.1f} | {smooth['jacobian_ms']:.1f} |")
    print(
        f"| averaged Reynolds + Greenwood-Tripp | {rough['dofs']} | {rough['solve_ms']:.1f} | "
        f"{rough['jacobian_ms']:.1f} |"
    )
    print(
        f"ratio rough/smooth: solve {rough['solve_ms'] / smooth['solve_ms']:.2f}, "
        f"Jacobian {rough['jacobian_ms'] / smooth['jacobian_ms']:.2f}"
    )


if __name__ == "__main__":
    main()
