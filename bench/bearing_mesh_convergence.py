"""Study (not a test): how far the film load at a mesh size is from its mesh-converged value, over
bearing width and eccentricity, for journal rotation and for pure squeeze.

    .venv/bin/python3 bench/bearing_mesh_convergence.py [--mesh-size H] [--ratios 0.125,0.25,0.5,1,2]
                                                        [--eccentricities 0.2,0.6,0.95]

For each B/D, eccentricity and motion the load is computed at the element size given (``--mesh-size``,
relative to the pin radius; default: the film's default for that width, default_mesh_size) and at two
refinements (1/2 and 1/4 of it);
the mesh-converged value is the Richardson extrapolation of the two finest with the observed order
(P1 with the midpoint rule converges as h^2). Prints the error of the given size, the observed
order and the unknowns, as a markdown table. The inlet is the max-gap line (the bearing command's
default and the classic tables' assumption).
"""

from __future__ import annotations

import argparse
import math
import time

from mpi4py import MPI

from solver.film.bearing import Bearing, FilmModel, Kinematics, default_mesh_size

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 100.0


def load(ratio: float, eps: float, motion: str, mesh_size: float) -> tuple[float, int]:
    bearing = Bearing(radius=R, width=2 * R * ratio, clearance=C, viscosity=MU)
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=mesh_size) as model:
        direction = (0.0, -1.0)
        if motion == "rotation":
            kin = Kinematics((eps * C * direction[0], eps * C * direction[1]), (0.0, 0.0), OMEGA, 0.0)
        else:  # squeeze along the line of centres, towards the minimum gap
            rate = C * OMEGA
            kin = Kinematics(
                (eps * C * direction[0], eps * C * direction[1]),
                (rate * direction[0], rate * direction[1]),
                0.0,
                0.0,
            )
        return model.solve(kin).load, model.dofs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--mesh-size", type=float, default=None, help="element size / R (default: the film's default)"
    )
    parser.add_argument("--ratios", default="0.125,0.25,0.5,1,2", help="B/D values")
    parser.add_argument("--eccentricities", default="0.2,0.6,0.95")
    args = parser.parse_args()
    print(
        "element size: "
        + (f"{args.mesh_size:g} R" if args.mesh_size else "the film's default for each B/D")
        + " (refined twice by halving for the reference)"
    )
    print("| B/D | eps | motion | element size / R | dofs | error of the load [%] | observed order |")
    print("|---|---|---|---|---|---|---|")
    worst = 0.0
    start = time.perf_counter()
    for ratio in (float(x) for x in args.ratios.split(",")):
        h = args.mesh_size or default_mesh_size(2 * R * ratio, R)
        for eps in (float(x) for x in args.eccentricities.split(",")):
            for motion in ("rotation", "squeeze"):
                (w0, dofs), (w1, _), (w2, _) = (load(ratio, eps, motion, h / k) for k in (1, 2, 4))
                order = math.log2(abs((w1 - w0) / (w2 - w1))) if w2 != w1 else math.nan
                p = order if 1.0 <= order <= 3.0 else 2.0  # a clean order, else the theoretical one
                converged = w2 + (w2 - w1) / (2**p - 1)
                error = 100 * (w0 / converged - 1)
                worst = max(worst, abs(error))
                print(
                    f"| {ratio:g} | {eps:g} | {motion} | {h:.4g} | {dofs} | {error:+.2f} | {order:.2f} |",
                    flush=True,
                )
    print(f"largest error {worst:.2f} %; {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
