"""Benchmark of the elastic film (not a test): cost of a coupled solve against the rigid one.

    .venv/bin/python3 bench/bench_elastic_film.py [--steps N]

The reference small end (R = 10 mm, B = 20 mm, c = 10 um, 0.01 Pa s, rough surfaces with asperity
contact, default film mesh), the pin turning at 200 rad/s relative to the bushing and moving along a
path of N states from eps = 0.90 to 0.97 toward the shank (as between time steps of a firing stroke);
each model solves the path warm, then gives its Jacobian at each state. Printed per model: set-up
time, cold first solve, median warm solve, median Jacobian, mean Newton iterations, and at the last
state load, p_max, h_min and the largest deformation.

Models: rigid; Winkler bushing (1.5 mm bronze); finite-element eye (outer radius 17 mm, steel;
72 modes; the compliance's set-up is reported apart and comes from the disk cache on a second run).
"""

from __future__ import annotations

import argparse
import statistics
import time

from mpi4py import MPI

import numpy as np

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.bushings import WinklerLayer, bushing_model
from solver.film.surface import Surface

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0


def path(steps: int) -> list[Kinematics]:
    eps = np.linspace(0.90, 0.97, steps)
    rate = (eps[1] - eps[0]) * C * OMEGA / 0.02  # as if 0.02 rad of crank per state
    return [Kinematics((-e * C, 0.0), (-rate, 0.0), OMEGA, 0.0) for e in eps]


def run(name: str, elastic, states: list[Kinematics]) -> dict:
    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    start = time.perf_counter()
    model = FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        roughness=surface.roughness(),
        contact=surface.contact(),
        elastic=elastic,
    )
    setup = time.perf_counter() - start
    start = time.perf_counter()
    model.solve(states[0])
    cold = time.perf_counter() - start
    warm, jac, iterations = [], [], []
    for kin in states[1:]:
        start = time.perf_counter()
        result = model.solve(kin)
        warm.append(time.perf_counter() - start)
        iterations.append(result.iterations)
        start = time.perf_counter()
        model.jacobian()
        jac.append(time.perf_counter() - start)
    model.close()
    return {
        "model": name,
        "setup_s": setup,
        "cold_ms": 1e3 * cold,
        "warm_ms": 1e3 * statistics.median(warm),
        "jacobian_ms": 1e3 * statistics.median(jac),
        "iterations": statistics.mean(iterations),
        "load_N": result.load,
        "p_max_MPa": result.p_max / 1e6,
        "h_min_um": result.h_min * 1e6,
        "deformation_um": result.max_deformation * 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=30)
    args = parser.parse_args()
    states = path(args.steps)
    start = time.perf_counter()
    eye = bushing_model(
        "fe",
        radius=R,
        width=2 * R,
        bushing_thickness=1.5e-3,
        eye_outer_radius=0.017,
        E_eye=210e9,
        nu_eye=0.3,
        E_bushing=115e9,
        nu_bushing=0.33,
        shank_half_angle_deg=30.0,
        modes=72,
        comm=MPI.COMM_SELF,
    )
    print(f"FE compliance of the eye: {time.perf_counter() - start:.1f} s (build, or read from the cache)")
    rows = [
        run("rigid", None, states),
        run("winkler", WinklerLayer(1.5e-3, 115e9, 0.33), states),
        run("fe (72 modes)", eye, states),
    ]
    keys = list(rows[0])
    print(" | ".join(keys))
    for row in rows:
        print(" | ".join(f"{row[k]:.4g}" if isinstance(row[k], float) else str(row[k]) for k in keys))


if __name__ == "__main__":
    main()
