"""``python3 -m solver bearing``: one journal bearing, at a given eccentricity or under a load.

The bushing is fixed and the journal turns at ``--speed`` rpm (counter-clockwise for positive
speed). The load acts on the journal along the bushing's -y axis ("downwards"); ``--attitude`` places
the journal centre that many degrees from the load line in the direction of rotation. With
``--eccentricity-rate`` the journal also moves along the line of centres (pure squeeze if the speed
is 0). All inputs and outputs are SI except the speed (rpm) and angles (degrees).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from solver.errors import InputError


def _number(name: str, low: float | None = None, high: float | None = None, low_open: bool = True,
            high_open: bool = True, allowed: str = ""):
    """An argparse type: a finite float inside the given range, else a one-line error naming it."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r} is not a number (allowed: {allowed})") from None
        ok = math.isfinite(value)
        if ok and low is not None:
            ok = value > low if low_open else value >= low
        if ok and high is not None:
            ok = value < high if high_open else value <= high
        if not ok:
            raise argparse.ArgumentTypeError(f"{name} = {text} is out of range (allowed: {allowed})")
        return value

    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The bearing command's arguments."""
    g = parser.add_argument_group("bearing")
    g.add_argument("--radius", required=True, type=_number("--radius", 0, allowed="> 0 m"), help="journal radius R [m]")
    g.add_argument("--width", required=True, type=_number("--width", 0, allowed="> 0 m"), help="bearing width B [m]")
    g.add_argument("--clearance", required=True, type=_number("--clearance", 0, allowed="> 0 m"),
                   help="radial clearance c [m]")
    g.add_argument("--viscosity", required=True, type=_number("--viscosity", 0, allowed="> 0 Pa s"),
                   help="dynamic viscosity [Pa s]")
    g.add_argument("--speed", type=_number("--speed", allowed="a finite number of rpm"), default=0.0,
                   help="journal speed [rpm] (bushing fixed; default 0)")
    g.add_argument("--cavitation-pressure", type=_number("--cavitation-pressure", high=0, high_open=False,
                                                         allowed="<= 0 Pa gauge"),
                   default=0.0, help="cavitation pressure [Pa gauge] (default 0)")
    g.add_argument("--inlet", choices=("max-gap", "none"), default="max-gap",
                   help="max-gap: ambient pressure along the line of maximum film thickness (the tables' "
                        "assumption, default); none: cavitation alone decides")
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--eccentricity", type=_number("--eccentricity", 0, 1, low_open=False, allowed="[0, 1)"),
                      help="eccentricity ratio e/c")
    mode.add_argument("--load", type=_number("--load", 0, allowed="> 0 N"), help="load on the journal [N]")
    parser.add_argument("--attitude", type=_number("--attitude", -360, 360, allowed="(-360, 360) deg"),
                        default=None, help="with --eccentricity: angle of the line of centres from the load line [deg]")
    parser.add_argument("--eccentricity-rate", type=_number("--eccentricity-rate", allowed="a finite number of 1/s"),
                        default=0.0, help="d(eps)/dt along the line of centres [1/s] (squeeze)")
    n = parser.add_argument_group("numerics and output")
    n.add_argument("--mesh-size", type=_number("--mesh-size", 0, 1, high_open=False, allowed="(0, 1] (element size / R)"),
                   default=None, help="element size / radius (default 0.05)")
    n.add_argument("--degree", type=int, choices=(1, 2), default=1, help="pressure element degree (default 1)")
    n.add_argument("--json", action="store_true", help="print one JSON object")
    n.add_argument("--output", type=Path, default=None, help="directory for the XDMF field and the PNG pressure map")


def _check(args) -> None:
    if args.clearance >= 0.1 * args.radius:
        raise InputError(f"--clearance = {args.clearance:g} is out of range (allowed: (0, 0.1 radius) m)")
    if args.speed == 0 and args.eccentricity_rate == 0:
        raise InputError("--speed = 0 and --eccentricity-rate = 0: nothing moves (allowed: either non-zero)")
    if args.load is not None and args.speed == 0:
        raise InputError("--speed = 0 with --load: a static load needs rotation (allowed: --speed != 0)")
    if args.attitude is not None and args.eccentricity is None:
        raise InputError("--attitude goes with --eccentricity (allowed: omit it with --load)")
    if args.eccentricity is not None and args.eccentricity == 0 and args.eccentricity_rate == 0:
        pass  # concentric rotation: zero load, still a valid question (friction, flow)


def run(args, comm) -> int:
    """Solve and report; returns the exit status."""
    _check(args)
    from solver import io
    from solver.bearing import DEFAULT_MESH_SIZE, Bearing, FilmModel, Kinematics, equilibrium

    bearing = Bearing(radius=args.radius, width=args.width, clearance=args.clearance, viscosity=args.viscosity,
                      cavitation_pressure=args.cavitation_pressure, inlet=args.inlet)
    omega = args.speed * 2 * math.pi / 60
    rate = args.eccentricity_rate
    omega_ref = abs(omega) if omega != 0 else abs(rate)
    start = time.perf_counter()
    model = FilmModel(bearing, comm, omega_ref=omega_ref, mesh_size=args.mesh_size or DEFAULT_MESH_SIZE,
                      degree=args.degree)
    setup_time = time.perf_counter() - start
    c = args.clearance
    load_angle = -math.pi / 2  # the load acts along -y
    residual = None
    if args.load is not None:
        W = (args.load * math.cos(load_angle), args.load * math.sin(load_angle))
        eq = equilibrium(model, W, omega_journal=omega)
        kin, result, newton_iterations, residual = eq.kinematics, eq.result, eq.newton_iterations, eq.force_residual
    else:
        sense = 1.0 if omega >= 0 else -1.0
        angle = load_angle + sense * math.radians(args.attitude or 0.0)
        direction = (math.cos(angle), math.sin(angle))
        kin = Kinematics((args.eccentricity * c * direction[0], args.eccentricity * c * direction[1]),
                         (rate * c * direction[0], rate * c * direction[1]), omega, 0.0)
        result = model.solve(kin)
        newton_iterations = result.iterations
    eps = math.hypot(*kin.ecc) / c
    load = result.load
    # Attitude: angle between the load line (opposite the film force) and the line of centres.
    attitude = float("nan")
    if eps > 0 and load > 0:
        load_dir = math.atan2(-result.force[1], -result.force[0])
        attitude = abs((math.degrees(math.atan2(kin.ecc[1], kin.ecc[0]) - load_dir) + 180.0) % 360.0 - 180.0)
    psi = c / args.radius
    speed_for_So = abs(omega) if omega != 0 else abs(rate)
    So = load * psi**2 / (args.width * 2 * args.radius * args.viscosity * speed_for_So)
    report = {
        "load_N": load, "attitude_deg": attitude, "eccentricity": eps, "sommerfeld_So": So,
        "p_max_Pa": result.p_max, "h_min_m": result.h_min, "friction_torque_Nm": result.torque_journal,
        "side_flow_m3_per_s": result.side_flow, "dofs": model.dofs, "newton_iterations": newton_iterations,
        "solve_time_s": time.perf_counter() - start - setup_time,
        # additions (keys above are the interface)
        "force_x_N": result.force[0], "force_y_N": result.force[1],
        "friction_torque_bushing_Nm": result.torque_bushing, "p_max_angle_deg": math.degrees(result.p_max_theta),
        "p_max_z_m": result.p_max_z, "ecc_x_m": kin.ecc[0], "ecc_y_m": kin.ecc[1],
        "vi_iterations": result.iterations, "setup_time_s": setup_time,
    }
    if residual is not None:
        report["force_residual_N"] = residual
    if args.output is not None:
        out = args.output
        if comm.rank == 0:
            out.mkdir(parents=True, exist_ok=True)
        comm.Barrier()
        io.write_film_fields(out, "bearing_pressure", model)
        io.plot_pressure_map(out / "bearing_pressure.png", model,
                             title=f"eps = {eps:.3f}, load = {load:.4g} N, p_max = {result.p_max / 1e6:.3g} MPa")
        if comm.rank == 0:
            io.write_json(out / "bearing.json", report)
    model.close()
    if comm.rank == 0:
        if args.json:
            print(json.dumps(report))
        else:
            _print_table(report, sys.stdout)
    return 0


def _print_table(report: dict, stream) -> None:
    rows = [
        ("eccentricity ratio", report["eccentricity"], ""), ("load", report["load_N"], "N"),
        ("attitude angle", report["attitude_deg"], "deg"), ("Sommerfeld number So", report["sommerfeld_So"], ""),
        ("peak pressure", report["p_max_Pa"] / 1e6, "MPa"), ("minimum film thickness", report["h_min_m"] * 1e6, "um"),
        ("friction torque on journal", report["friction_torque_Nm"], "N m"),
        ("side flow", report["side_flow_m3_per_s"] * 6e4, "l/min"), ("dofs", report["dofs"], ""),
        ("Newton iterations", report["newton_iterations"], ""), ("solve time", report["solve_time_s"], "s"),
    ]
    if "force_residual_N" in report:
        rows.append(("force residual", report["force_residual_N"], "N"))
    for label, value, unit in rows:
        print(f"{label:28s} {value:14.6g} {unit}", file=stream)
