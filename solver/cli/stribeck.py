"""``python3 -m solver stribeck``: friction coefficient against speed at a fixed load (a Stribeck curve).

At each journal speed the static equilibrium under the load is found (film + asperity contact,
solver.film.bearing.equilibrium), from the highest speed down so that each equilibrium starts from the
previous one. The result is a netCDF file (xarray; dimension ``speed``) and a PNG of the friction
coefficient against the Hersey number ``eta N / P`` (N in rev/s, P = W/(2 R B)), which shows the
boundary (asperity friction), mixed and hydrodynamic regimes. Petroff's law
``f = 2 pi^2 (eta N / P)(R / c)`` is drawn for reference.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from solver.cli.bearing import (
    _number,
    add_geometry_arguments,
    add_surface_arguments,
    bearing_from_args,
    check_plausible,
    resolve_supply,
    resolve_viscosity,
    surface_from_args,
)
from solver.errors import InputError
from solver.study import io


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The stribeck command's arguments."""
    add_geometry_arguments(parser)
    add_surface_arguments(parser)
    parser.add_argument("--load", required=True, type=_number("--load", 0, allowed="> 0 N"), help="load [N]")
    parser.add_argument(
        "--speed-min",
        type=_number("--speed-min", 0, allowed="> 0 rpm"),
        default=1.0,
        help="lowest journal speed [rpm] (default 1)",
    )
    parser.add_argument(
        "--speed-max",
        type=_number("--speed-max", 0, allowed="> 0 rpm"),
        default=10000.0,
        help="highest journal speed [rpm] (default 10000)",
    )
    parser.add_argument("--points", type=int, default=25, help="number of speeds, log-spaced (default 25)")
    parser.add_argument(
        "--mesh-size",
        type=_number("--mesh-size", 0, 1, high_open=False, allowed="(0, 1]"),
        default=None,
        help="element size / radius (default: 0.07, and at least 10 elements across the half width)",
    )
    parser.add_argument(
        "--output", type=Path, default=Path("stribeck"), help="output directory (default ./stribeck)"
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")


def sweep(model, load: float, speeds_rpm: np.ndarray, radius: float, progress=None) -> dict[str, np.ndarray]:
    """Equilibria at the given speeds (any order; solved from fast to slow). SI arrays, same order."""
    from solver.film.equilibrium import equilibrium

    order = np.argsort(speeds_rpm)[::-1]
    keys = (
        "eccentricity",
        "h_min",
        "h_min_over_sigma",
        "friction_coefficient",
        "hydro_load",
        "asperity_load",
        "friction_torque",
        "asperity_friction_torque",
        "power_loss",
        "p_max",
        "contact_area_ratio",
    )
    out = {k: np.full(len(speeds_rpm), np.nan) for k in keys}
    W = (0.0, -load)
    guess = None
    for i in order:
        omega = speeds_rpm[i] * 2 * math.pi / 60
        eq = equilibrium(model, W, omega_journal=omega, guess=guess)
        guess = eq.kinematics.ecc
        r = eq.result
        out["eccentricity"][i] = math.hypot(*eq.kinematics.ecc) / model.bearing.clearance
        out["h_min"][i] = r.h_min
        out["h_min_over_sigma"][i] = r.h_min_over_sigma
        out["friction_coefficient"][i] = abs(r.torque_journal) / (radius * r.load)
        out["hydro_load"][i], out["asperity_load"][i] = r.hydro_load, r.asperity_load
        out["friction_torque"][i], out["asperity_friction_torque"][i] = (
            r.torque_journal,
            r.asperity_torque_journal,
        )
        out["power_loss"][i] = abs(r.torque_journal * omega)
        out["p_max"][i], out["contact_area_ratio"][i] = r.p_max, r.contact_area_ratio
        if progress is not None:
            progress(speeds_rpm[i], out["friction_coefficient"][i])
    return out


def run(args, comm) -> int:
    """Sweep the speeds, write netCDF and PNG; returns the exit status."""
    resolve_viscosity(args)
    resolve_supply(args)
    check_plausible(args)
    if args.points < 2:
        raise InputError(f"--points = {args.points} is out of range (allowed: >= 2)")
    if not args.speed_min < args.speed_max:
        raise InputError(
            f"--speed-min = {args.speed_min:g} is out of range (allowed: < --speed-max = {args.speed_max:g})"
        )
    from solver.film.spec import FilmSpec

    bearing = bearing_from_args(args)
    surface = surface_from_args(args)
    speeds = np.geomspace(args.speed_min, args.speed_max, args.points)
    start = time.perf_counter()
    pressure = args.load / (2 * args.radius * args.width)  # N/m^2, projected-area pressure
    # Asperity friction is smoothed below 1e-3 of the slowest sliding speed, so that it is fully
    # developed (f -> mu_f) at every speed of the sweep.
    slowest_sliding = args.radius * args.speed_min * 2 * math.pi / 60
    spec = FilmSpec(  # the film's rules, before any mesh (solver.film_rules)
        bearing=bearing,
        omega_ref=args.speed_max * 2 * math.pi / 60,
        roughness=surface.roughness(),
        contact=surface.contact(),
        mesh_size=args.mesh_size,
        slip_regularisation=1e-3 * slowest_sliding,
        cavitation=args.cavitation,
        quasi_static=True,
    )
    spec.check(ranks=comm.size)
    from solver.film.factory import make_film  # dolfinx: after the checks

    with make_film(spec, comm) as model:
        bar = None
        if comm.rank == 0 and not args.json:
            bar = tqdm(total=len(speeds), desc="stribeck", unit="speed", file=sys.stderr)

        def progress(rpm, f):
            if bar is not None:
                bar.set_postfix_str(f"{rpm:.3g} rpm, f = {f:.3g}")
                bar.update()

        data = sweep(model, args.load, speeds, args.radius, progress)
        if bar is not None:
            bar.close()
    hersey = args.viscosity * (speeds / 60) / pressure
    petroff = 2 * math.pi**2 * hersey * args.radius / args.clearance
    ds = io.stribeck_dataset(
        speeds,
        hersey,
        petroff,
        data,
        attrs={
            "load_N": args.load,
            "radius_m": args.radius,
            "width_m": args.width,
            "clearance_m": args.clearance,
            "viscosity_Pa_s": args.viscosity,
            "temperature_C": "" if args.temperature is None else args.temperature,
            "sigma_m": surface.sigma,
            "asperity_friction": surface.asperity_friction,
            "cavitation": args.cavitation,
            "wall_time_s": time.perf_counter() - start,
        },
    )
    if comm.rank == 0:
        args.output.mkdir(parents=True, exist_ok=True)
        io.write_netcdf(ds, args.output / "stribeck.nc")
        io.plot_stribeck(ds, args.output / "stribeck.png")
        summary = {
            "points": len(speeds),
            "friction_coefficient_min": float(np.nanmin(data["friction_coefficient"])),
            "hersey_at_min": float(hersey[np.nanargmin(data["friction_coefficient"])]),
            "friction_coefficient_lowest_speed": float(data["friction_coefficient"][0]),
            "friction_coefficient_highest_speed": float(data["friction_coefficient"][-1]),
            "netcdf": str(args.output / "stribeck.nc"),
            "png": str(args.output / "stribeck.png"),
            "viscosity_Pa_s": args.viscosity,
            "temperature_C": args.temperature,
            "cavitation": args.cavitation,
        }
        print(json.dumps(summary) if args.json else "\n".join(f"{k:36s} {v}" for k, v in summary.items()))
    return 0
