"""``python3 -m solver run CASE``: one engine operating point with the lubricated small end.

Writes ``CASE/results/``: ``results.nc`` (the data contract of DESIGN 4), ``orbit.png``, ``film.png``,
``forces.png``, ``friction_power.png``, ParaView fields ``film_XXX.Xdeg.xdmf`` (mixed-fem) and
``run.log``. A progress bar shows the cycle, the crank angle and h_min. An interrupted run resumes
from the last finished cycle (``results/checkpoint.npz``) unless ``--restart`` is given.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from solver.study.simulation import SimulationError, run_case


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The run command's arguments."""
    parser.add_argument("case", type=Path, help="case directory (with case.toml) or a case TOML file")
    parser.add_argument(
        "--joint",
        choices=("mixed-fem", "short-bearing", "dry", "ideal"),
        default=None,
        help="small-end model (default: solver.joint of the case, normally mixed-fem)",
    )
    parser.add_argument("--restart", action="store_true", help="ignore a checkpoint and start from cycle 1")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args, comm) -> int:
    """Run the case; 0 on success, 1 when the simulation fails (bad input: InputError -> 2)."""
    try:
        summary = run_case(
            args.case, comm, joint=args.joint, progress=not (args.quiet or args.json), resume=not args.restart
        )
    except SimulationError as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 1
    if comm.rank == 0:
        report = {
            "case": summary.case,
            "results": str(summary.results),
            "h_min_min_m": summary.h_min_min,
            "p_max_max_Pa": summary.p_max_max,
            "F_asperity_max_N": summary.F_asperity_max,
            "friction_power_mean_W": summary.friction_power_mean,
            "cycles": summary.cycles,
            "periodic": summary.periodic,
            "wall_time_s": summary.wall_time,
            "film_temperature_C": summary.film_temperature,
            "film_viscosity_Pa_s": summary.film_viscosity,
            "thermal_closure": summary.thermal_closure,
            "heat_generated_W": summary.heat_generated,
            "heat_to_oil_W": summary.heat_to_oil,
            "heat_carried_W": summary.heat_carried,
        }
        report = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in report.items()
        }
        if args.json:  # NaN (e.g. no film with --joint ideal) is null: strict JSON
            print(json.dumps(report))
        else:  # the table leaves out what does not apply to this run (e.g. an isothermal run's heat balance)
            for key, value in report.items():
                if value is not None:
                    print(f"{key:24s} {value}")
    return 0
