"""Benchmark of the small-end eye compliance (not a test): set-up time, dofs, mode truncation.

    .venv/bin/python3 bench/bench_compliance.py [--element-size H] [--n-theta N] [--n-z N]

Reference small end (DESIGN 7): pin radius R = 10 mm, width 20 mm, bronze bushing 1.5 mm
(115 GPa, 0.33), steel eye of outer radius 17 mm (210 GPa, 0.3), clamped on the shank arc at
180 deg +- 30 deg. Printed:

- set-up: mesh + stiffness + Cholesky factorisation, then the hat loads and the n_theta n_z
  back-substitutions (what ``eye_compliance`` does when nothing is cached), dofs;
- the truncation error of the displacement (max norm, relative) against the number of modes m for
  the reference loads (uniform; 30 deg cos^2 bumps opposite the shank and 90 deg from it), in the eigen
  basis (modes of G) and in the layer basis (the bushing's local part plus modes of the remainder), and
  the modes the layer basis chooses for the default tolerance;
- the order-of-magnitude check of DESIGN 7: the compression of the bushing alone (on an eye made
  1000 times stiffer) under 240 MPa, bore minus interface at the mid-plane opposite the shank,
  against the Winkler layer (~2 um); then the bore displacement of the reference eye under the
  240 MPa bump opposite the shank (bushing and eye ovalisation together).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

from mpi4py import MPI

import numpy as np

from solver.film.bushings import FEEye, winkler_coefficient
from solver.film.compliance import (
    DEFAULT_ELEMENT_SIZE,
    DEFAULT_MODES,
    DEFAULT_TOLERANCE,
    ElasticEye,
    EyeGeometry,
    reference_loads,
)

REFERENCE = EyeGeometry(bore_radius=0.01, width=0.02, bushing_thickness=1.5e-3, eye_outer_radius=0.017)
PRESSURE = 240e6  # Pa, DESIGN 7


def bushing_compression(geometry: EyeGeometry, element_size: float) -> float:
    """Compression of the bushing [m] (bore minus interface u_r) under a uniform PRESSURE, at z = 0
    opposite the shank."""
    with ElasticEye(geometry, MPI.COMM_SELF, element_size=element_size) as eye:
        u = eye.displacement(lambda theta, z: PRESSURE)
        x = eye.V.tabulate_dof_coordinates() * geometry.bore_radius
        U = u.x.array.reshape(-1, 3)
    r, theta = np.hypot(x[:, 0], x[:, 1]), np.arctan2(x[:, 1], x[:, 0])
    u_r = (U[:, 0] * x[:, 0] + U[:, 1] * x[:, 1]) / r
    opposite = math.radians(geometry.shank_angle_deg) + math.pi
    near = (x[:, 2] < 1e-12) & (np.abs(np.angle(np.exp(1j * (theta - opposite)))) < 0.05)
    bore = u_r[near & (np.abs(r - geometry.bore_radius) < 1e-9)]
    interface = u_r[near & (np.abs(r - geometry.eye_inner_radius) < 1e-9)]
    return bore.mean() - interface.mean()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--element-size", type=float, default=DEFAULT_ELEMENT_SIZE, help="element edge / R")
    parser.add_argument("--n-theta", type=int, default=72)
    parser.add_argument("--n-z", type=int, default=5)
    args = parser.parse_args()
    R = REFERENCE.bore_radius

    start = time.perf_counter()
    with ElasticEye(REFERENCE, MPI.COMM_SELF, element_size=args.element_size * R) as eye:
        factorised = time.perf_counter()
        compliance = eye.compliance(args.n_theta, args.n_z)
        built = time.perf_counter()
        bore = eye.bore_element_size / R
        print(f"element size {args.element_size:g} R (bore {bore:g} R), {eye.num_dofs} dofs")
    print(
        f"set-up {built - start:.1f} s = mesh + stiffness + Cholesky {factorised - start:.1f} s "
        f"+ {compliance.size} hat loads and back-substitutions {built - factorised:.1f} s"
    )

    loads = reference_loads(compliance)
    F = np.column_stack(list(loads.values()))
    local = FEEye(REFERENCE, basis="layer").layer.coefficient
    eigen, layer = compliance.truncation_errors(F), compliance.truncation_errors(F, local)
    print(f"\ntruncation error (max norm, %) against the modes m (eigen: the old default {DEFAULT_MODES}):")
    print(
        f"{'m':>5}"
        + "".join(f"{'eigen ' + name:>16}" for name in loads)
        + "".join(f"{'layer ' + name:>16}" for name in loads)
    )
    for m in (0, 8, 16, 24, 32, 40, 48, 64, 72, 96, 128):
        print(f"{m:5d}" + "".join(f"{100 * e:16.2f}" for e in (*eigen[m], *layer[m])))
    start = time.perf_counter()
    m = compliance.modes_for(DEFAULT_TOLERANCE, F, local)
    print(
        f"layer basis (k = {local:.4g} m/Pa): {m} modes for {DEFAULT_TOLERANCE:.0%} "
        f"(chosen in {time.perf_counter() - start:.2f} s)"
    )

    g = REFERENCE
    winkler = winkler_coefficient(g.bushing_thickness, g.E_bushing, g.nu_bushing) * PRESSURE
    compression = bushing_compression(dataclasses.replace(g, E_eye=1000 * g.E_bushing), args.element_size * R)
    print(
        f"\nbushing alone (eye 1000 x stiffer), uniform {PRESSURE / 1e6:g} MPa: "
        f"compression {compression * 1e6:.2f} um; Winkler layer {winkler * 1e6:.2f} um (DESIGN 7: ~2 um)"
    )
    w = compliance.matrix @ (PRESSURE * loads["opposite"])
    total = 2 * PRESSURE * loads["opposite"].sum()  # int p dA over the whole width
    print(
        f"reference eye, {PRESSURE / 1e6:g} MPa bump opposite the shank (int p dA = {total / 1e3:.1f} kN): "
        f"bore displacement {w.max() * 1e6:.1f} um under the peak"
    )


if __name__ == "__main__":
    main()
