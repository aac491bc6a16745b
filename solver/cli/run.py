"""``python3 -m solver run CASE``: one engine operating point with the lubricated small end.

Writes ``CASE/results/`` (or ``--output DIR``): ``results.nc`` (the data contract of DESIGN 4),
``orbit.png``, ``film.png``, ``forces.png``, ``friction_power.png``, ParaView fields
``film_XXX.Xdeg.xdmf`` (mixed-fem) and ``run.log``. Finished results of another case or another joint
in that directory are not overwritten without ``--force`` (bad input, exit 2). A progress bar shows the
cycle, the crank angle and h_min. An interrupted run (Ctrl-C, SIGTERM) prints one line (where it
stopped, the checkpoint kept) and exits with 130; it resumes from the last finished cycle
(``checkpoint.npz`` in the results directory) when run again, unless ``--restart`` is given.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from solver.cli.interrupts import interrupted, sigterm_interrupts
from solver.errors import InputError
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
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        metavar="DIR",
        help="results directory (default: results/ beside the case file)",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="overwrite finished results of another case or joint in the results directory",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def check_output(out_dir: Path, name: str, joint: str, force: bool) -> None:
    """InputError if ``out_dir`` holds the finished results of another case or joint (unless ``force``)."""
    from solver.study.results import results_owner

    owner = results_owner(out_dir / "results.nc")
    if force or owner is None or owner == (name, joint):
        return
    raise InputError(
        f"--output = {str(out_dir)!r} holds the results of case {owner[0]} with joint {owner[1]}, which this "
        f"run (case {name}, joint {joint}) would overwrite (allowed: another --output DIR, or --force)"
    )


def run(args, comm) -> int:
    """Run the case; 0 on success, 1 when the simulation fails (bad input: InputError -> 2), 130 when
    interrupted."""
    from solver.case import load_case
    from solver.study.batch import interruption_text

    case = load_case(args.case)
    out_dir = args.output if args.output is not None else case.directory / "results"
    joint = args.joint or case.solver.joint
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"--output = {str(out_dir)!r} is out of range (allowed: a directory)")
    check_output(out_dir, case.name, joint, args.force)
    try:
        with sigterm_interrupts():
            summary = run_case(
                args.case,
                comm,
                joint=args.joint,
                progress=not (args.quiet or args.json),
                resume=not args.restart,
                output=out_dir,
            )
    except SimulationError as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as err:
        text = interruption_text(err, case.name, out_dir / "checkpoint.npz")
        return interrupted(comm, text + (" (--restart starts afresh)" if "resumes" in text else ""))
    if comm.rank == 0:
        report = {
            "case": summary.case,
            "results": str(summary.results),
            "h_min_min_m": summary.h_min_min,
            "p_max_max_Pa": summary.p_max_max,
            "F_asperity_max_N": summary.F_asperity_max,
            "friction_power_mean_W": summary.friction_power_mean,
            "big_end_h_min_min_m": summary.big_end_h_min_min,
            "big_end_friction_power_mean_W": summary.big_end_friction_power_mean,
            "big_end_p_max_max_Pa": summary.big_end_p_max_max,
            "big_end_F_asperity_max_N": summary.big_end_F_asperity_max,
            "pin_boss_h_min_min_m": summary.pin_boss_h_min_min,
            "pin_boss_p_max_max_Pa": summary.pin_boss_p_max_max,
            "pin_boss_friction_power_mean_W": summary.pin_boss_friction_power_mean,
            "pin_speed_mean_rpm": summary.pin_speed_mean / (2 * math.pi / 60),
            "cycles": summary.cycles,
            "periodic": summary.periodic,
            "wall_time_s": summary.wall_time,
            "wall_time_last_invocation_s": summary.wall_time_last_invocation,
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
