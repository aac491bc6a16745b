"""``python3 -m solver engine CASE``: one 720 deg cycle of the engine with ideal joints.

Prints a short summary (or one JSON object with ``--json``) on rank 0; with ``--output DIR`` rank 0
also writes ``engine_ideal.csv`` (every output variable, SI, DESIGN 4 names) and ``engine_ideal.png``
(forces and crank torque against crank angle). Bad input raises ``InputError``; solver.cli turns it
into one line ``error: ...`` and exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import os
from pathlib import Path

import numpy as np

from solver.case import DEG, RPM, load_case
from solver.dynamics.engine import EngineCycle, engine_from_case, simulate_ideal
from solver.errors import InputError, out_of_range
from solver.study import io

logger = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``engine`` command."""
    parser.add_argument("case", metavar="CASE", help="case directory (with case.toml) or a case TOML file")
    parser.add_argument(
        "--rpm",
        type=float,
        default=None,
        help="constant crank speed in rpm (replaces engine.speed_rpm and engine.speed_file)",
    )
    parser.add_argument(
        "--step-deg",
        type=float,
        default=None,
        help="crank-angle step of the outputs in degrees (default: solver.step_deg)",
    )
    parser.add_argument(
        "--integrator",
        choices=("kinematic", "explicit", "implicit"),
        default="kinematic",
        help="kinematic: exact constraint solution per crank angle (default); "
        "explicit/implicit: error-controlled time integration (RK45 / ESDIRK32)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the summary")
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        metavar="DIR",
        help="write engine_ideal.csv and engine_ideal.png into DIR",
    )


def summary(cycle: EngineCycle, name: str, speed_rpm: float, step_deg: float) -> dict:
    """Cycle extremes and means (SI; angles in deg)."""
    small = np.hypot(cycle.small_end_force[:, 0], cycle.small_end_force[:, 1])
    k_small = int(np.argmax(small))
    k_gas = int(np.argmax(cycle.gas_force))
    k_side = int(np.argmax(np.abs(cycle.side_thrust)))
    angle_rad = np.radians(cycle.crank_angle)
    span = angle_rad[-1] - angle_rad[0]
    return {
        "case": name,
        "speed_rpm": round(speed_rpm, 9),
        "step_deg": step_deg,
        "integrator": cycle.integrator,
        "peak_small_end_force_N": float(small[k_small]),
        "peak_small_end_force_crank_angle_deg": float(cycle.crank_angle[k_small]),
        "peak_gas_force_N": float(cycle.gas_force[k_gas]),
        "peak_gas_force_crank_angle_deg": float(cycle.crank_angle[k_gas]),
        "peak_cylinder_pressure_bar": float(np.max(cycle.cylinder_pressure) / 1e5),
        "peak_side_thrust_N": float(cycle.side_thrust[k_side]),
        "peak_side_thrust_crank_angle_deg": float(cycle.crank_angle[k_side]),
        "mean_crank_torque_N_m": float(np.trapz(cycle.crank_torque, angle_rad) / span),
        "n_steps": cycle.n_steps,
        "n_force_evaluations": cycle.n_force_evaluations,
        "run_time_s": cycle.wall_time,
    }


def _write_outputs(cycle: EngineCycle, directory: Path, title: str) -> None:

    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        message = f"--output = {str(directory)!r}: cannot create the directory ({err.strerror})"
        raise InputError(message) from None
    columns = cycle.columns()
    header = ",".join(f"{name} [{unit}]" for name, (_, unit, _) in columns.items())
    table = np.column_stack([values for values, _, _ in columns.values()])
    csv_path = directory / "engine_ideal.csv"
    part = csv_path.with_name(csv_path.name + ".part")  # never leave a half-written file
    np.savetxt(part, table, delimiter=",", header=header, comments="", fmt="%.10g")
    os.replace(part, csv_path)

    angle = cycle.crank_angle
    figure, axes = io.subplots(3, 1, figsize=(8, 9), sharex=True)
    axes[0].plot(angle, cycle.gas_force / 1e3, label="gas force")
    axes[0].plot(angle, cycle.pin_force_x / 1e3, label="pin on rod, x")
    axes[0].plot(angle, cycle.pin_force_y / 1e3, label="pin on rod, y")
    axes[0].plot(angle, cycle.big_end_force[:, 0] / 1e3, "--", label="crankpin on rod, x")
    axes[0].set_ylabel("force (kN)")
    axes[1].plot(angle, cycle.side_thrust / 1e3, label="wall on piston, y")
    axes[1].plot(angle, cycle.main_bearing_force[:, 0] / 1e3, label="crank on main bearing, x")
    axes[1].plot(angle, cycle.main_bearing_force[:, 1] / 1e3, label="crank on main bearing, y")
    axes[1].set_ylabel("force (kN)")
    axes[2].plot(angle, cycle.crank_torque, label="driving torque on crank")
    axes[2].set_ylabel("torque (N m)")
    axes[2].set_xlabel("crank angle (deg; 360 = firing TDC)")
    for axis in axes:
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize="small")
    axes[-1].set_xticks(np.arange(0.0, 721.0, 90.0))
    figure.suptitle(title)
    figure.tight_layout()
    png_path = directory / "engine_ideal.png"
    part = png_path.with_name(png_path.name + ".part")
    figure.savefig(part, dpi=120, format="png")
    os.replace(part, png_path)


def run(args: argparse.Namespace, comm) -> int:
    """Run the ideal-joint cycle; every rank computes, rank 0 prints and writes."""
    case = load_case(args.case)
    if args.rpm is not None:
        if not (math.isfinite(args.rpm) and args.rpm > 0.0):
            raise out_of_range("--rpm", f"{args.rpm:g}", "> 0")
        case = dataclasses.replace(
            case, engine=dataclasses.replace(case.engine, speed=args.rpm * RPM, speed_file=None)
        )
    step_deg = case.solver.step / DEG if args.step_deg is None else args.step_deg
    count = 720.0 / step_deg if step_deg else math.inf
    if not (math.isfinite(step_deg) and 0.0 < step_deg < 10.0 and abs(count - round(count)) < 1e-9 * count):
        raise out_of_range("--step-deg", f"{step_deg:g}", "(0, 10) with 720 / step an integer")
    engine = engine_from_case(case)
    cycle = simulate_ideal(engine, step_deg=step_deg, integrator=args.integrator)
    speed_rpm = engine.crank_motion.speed / RPM
    result = summary(cycle, case.name, speed_rpm, step_deg)
    if comm.rank == 0:
        if args.output is not None:
            _write_outputs(cycle, args.output, f"{case.name}: ideal joints, {speed_rpm:g} rpm")
            result["output"] = str(args.output)
        if args.json:
            print(json.dumps(result))
        else:
            print(
                f"case {case.name}: {speed_rpm:g} rpm, {cycle.crank_angle.size} points "
                f"every {step_deg:g} deg, "
                f"{cycle.integrator}\n"
                f"  peak small-end force  {result['peak_small_end_force_N']:10.1f} N   at "
                f"{result['peak_small_end_force_crank_angle_deg']:6.1f} deg\n"
                f"  peak gas force        {result['peak_gas_force_N']:10.1f} N   at "
                f"{result['peak_gas_force_crank_angle_deg']:6.1f} deg "
                f"(p_max {result['peak_cylinder_pressure_bar']:.2f} bar)\n"
                f"  peak side thrust      {result['peak_side_thrust_N']:10.1f} N   at "
                f"{result['peak_side_thrust_crank_angle_deg']:6.1f} deg\n"
                f"  mean crank torque     {result['mean_crank_torque_N_m']:10.3f} N m (driver on crank)\n"
                f"  run time              {result['run_time_s']:10.3f} s"
                + (f"\n  wrote {args.output / 'engine_ideal.csv'} and .png" if args.output else "")
            )
    return 0
