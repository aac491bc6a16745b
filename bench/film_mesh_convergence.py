"""Mesh convergence of the mixed film at the hardest state of the reference engine (not a test).

    .venv/bin/python3 bench/film_mesh_convergence.py

The state is the one of minimum film thickness of a reference run (cases/reference-2000rpm, crank
angle 605 deg: eps = 0.971, squeeze and slow rotation, asperity contact). The film is solved on
uniform meshes from 0.15 R to 0.025 R and the hydrodynamic load, asperity load and pin friction torque
are printed with their deviation from the finest mesh. This is what the choice of the default
``solver.mesh_size`` rests on (README, Verification).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from mpi4py import MPI

from solver.case import load_case
from solver.dynamics.engine import engine_from_case
from solver.dynamics.joint import joint_from_case
from solver.film.bearing import Kinematics

ROOT = Path(__file__).resolve().parents[1]
STATE = Kinematics(
    ecc=(-9.4719e-06, 2.1293e-06),
    ecc_rate=(2.6648e-05, 1.00379e-04),
    omega_journal=-27.2526,
    omega_bushing=0.0,
)  # bushing (rod) frame, SI
SIZES = (0.15, 0.1, 0.07, 0.05, 0.035, 0.025)


def main() -> None:
    case = load_case(ROOT / "cases" / "reference-2000rpm")
    engine = engine_from_case(case)
    rows = []
    for size in SIZES:
        refined = dataclasses.replace(case, solver=dataclasses.replace(case.solver, mesh_size=size))
        _, model = joint_from_case(refined, engine, MPI.COMM_SELF, "mixed-fem")
        with model:
            r = model.solve(STATE)
            rows.append((size, model.dofs, r.hydro_load, r.asperity_load, r.torque_journal, r.p_max))
    ref = rows[-1]
    print(
        "| mesh size / R | dofs | hydrodynamic load [N] | deviation | asperity load [N] | deviation | "
        "pin friction torque [N m] | deviation | p_max [MPa] |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for size, dofs, hydro, asperity, torque, p_max in rows:
        print(
            f"| {size:g} | {dofs} | {hydro:.1f} | {100 * (hydro / ref[2] - 1):+.2f} % | {asperity:.2f} | "
            f"{100 * (asperity / ref[3] - 1):+.3f} % | {torque:.5f} | {100 * (torque / ref[4] - 1):+.3f} % | "
            f"{p_max / 1e6:.2f} |"
        )


if __name__ == "__main__":
    main()
