"""``python3 -m solver bearing ... --motion FILE``: the film of one bearing under a prescribed motion.

The bearing, oil, surfaces, supply, cavitation law, bushing and numerics come from the bearing
command's options (solver.cli.bearing, which builds the film and drives it: ``run_motion``); the
motion from FILE (solver.study.motion: the columns, the checks, the driver). The film is the engine's
(solver.film.factory.make_film, a film in time: ``quasi_static=False``; without --inlet a film with
history has the inlet 'none'), solved at every row with its history committed there. This module
checks the options that go without --motion and the file, and reports: ``DIR/bearing_motion.nc``
(dimension ``time``), a PNG of the forces, the peak pressure and the minimum film thickness over time,
and a summary (``--json``: one JSON object with the maxima, the means and the file's path).
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np

from solver.errors import InputError
from solver.study import io
from solver.study.motion import (
    MOTION_VARIABLES,
    OUTPUTS,
    VOLUMES,
    Motion,
    MotionRun,
    check_reach,
    read_motion,
)

#: log a progress line every this many rows (files longer than this)
PROGRESS_ROWS = 50


def check(args) -> None:
    """What goes without --motion (one line naming the flag)."""
    for flag, given in (
        ("--attitude", args.attitude is not None),
        ("--eccentricity-rate", args.eccentricity_rate != 0),
    ):
        if given:
            raise InputError(f"{flag} with --motion (allowed: the motion file's columns instead)")
    if args.fields and args.output is None:
        raise InputError("--fields without --output (allowed: --fields with --output DIR)")


def field_series(args, comm, model):
    """``--fields``: the ParaView series ``DIR/bearing_motion.xdmf`` (solver.study.io.FilmSeries: the
    bushing frame, or with the max-gap inlet the solution frame, maximum gap at theta = 0), or None."""
    if not args.fields:
        return None
    if comm.rank == 0:
        args.output.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    return io.FilmSeries(args.output, "bearing_motion", model)


def motion_of(args) -> Motion:
    """The checked Motion of ``--motion FILE`` (the clearance within the film's reach)."""
    from solver.film.types import ELASTIC_MAX_ECCENTRICITY

    motion = read_motion(args.motion, args.speed, args.bushing_speed)
    limit = 1.0 if args.elastic == "none" else ELASTIC_MAX_ECCENTRICITY
    check_reach(motion, args.clearance, limit, args.motion)
    return motion


def report(args, comm, motion: Motion, result: MotionRun, dofs: int, setup_time: float, start: str) -> int:
    """Write ``DIR/bearing_motion.nc``, its PNG and JSON (``--output``), print the summary; the exit
    status."""
    summary = _summary(args, motion, result, dofs, setup_time, start)
    if args.output is not None:
        out = args.output
        if comm.rank == 0:
            out.mkdir(parents=True, exist_ok=True)
            nc = out / "bearing_motion.nc"
            io.write_netcdf(_dataset(args, motion, result, start), nc)
            png = out / "bearing_motion.png"
            _plot(motion, result, png)
            summary["netcdf"], summary["plot"] = str(nc), str(png)
            io.write_json(out / "bearing_motion.json", summary)
        comm.Barrier()
    if comm.rank == 0:
        if args.json:
            print(json.dumps(summary))
        else:
            _print_table(summary, sys.stdout)
    return 0


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _summary(args, motion, result, dofs: int, setup_time: float, start: str) -> dict:
    values = result.values
    force = np.hypot(values["force_x_N"], values["force_y_N"])
    maxima = {name: _finite(np.max(v)) if np.all(np.isfinite(v)) else None for name, v in values.items()}
    means = {name: _finite(np.mean(v)) if np.all(np.isfinite(v)) else None for name, v in values.items()}
    minima = {name: _finite(np.min(v)) if np.all(np.isfinite(v)) else None for name, v in values.items()}
    return {
        "rows": len(motion),
        "time_start_s": float(motion.time[0]),
        "time_end_s": float(motion.time[-1]),
        "start": start,
        "cavitation": args.cavitation,
        "elastic": args.elastic,
        "inlet": args.inlet,
        "rates": "given" if motion.rates_given else "differentiated",
        "max_load_N": float(np.max(force)),
        "mean_load_N": float(np.mean(force)),
        "max_p_max_Pa": maxima["p_max_Pa"],
        "min_h_min_m": minima["h_min_m"],
        "maxima": maxima,
        "minima": minima,
        "means": means,
        "dofs": dofs,
        "iterations": int(np.sum(result.iterations)),
        "internal_substeps": result.substeps,
        "substeps_per_row": args.substeps,
        "transport": args.transport if args.cavitation == "jfo" else None,
        "supply_volume_m3": _finite(result.volumes["supply_volume_m3"][-1]),
        "side_volume_m3": _finite(result.volumes["side_volume_m3"][-1]),
        "oil_balance_defect_m3": _finite(_oil_balance_defect(values, result.volumes)),
        "setup_time_s": setup_time,
        "solve_time_s": result.solve_time_s,
        "netcdf": None,
        "plot": None,
    }


def _oil_balance_defect(values, volumes) -> float:
    """The oil held at the end minus at the start minus (supplied - lost through the edges) [m^3]: zero
    for an exactly conservative film; NaN for the Reynolds film (no oil held)."""
    held = values["oil_volume_m3"]
    net = volumes["supply_volume_m3"][-1] - volumes["side_volume_m3"][-1]
    return float(held[-1] - held[0] - net)


def _dataset(args, motion, result, start: str):
    import xarray as xr

    from solver import __version__

    variables = {
        name: ("time", result.values[name], {"units": units, "long_name": long_name})
        for name, (units, long_name, _) in OUTPUTS.items()
    }
    for name, (units, long_name) in VOLUMES.items():
        variables[name] = ("time", result.volumes[name], {"units": units, "long_name": long_name})
    for name, (units, long_name, get) in MOTION_VARIABLES.items():
        variables[name] = ("time", get(motion), {"units": units, "long_name": long_name})
    variables["iterations"] = (
        "time",
        result.iterations,
        {"units": "1", "long_name": "film solver iterations"},
    )
    return xr.Dataset(
        variables,
        coords={"time": ("time", motion.time, {"units": "s", "long_name": "time"})},
        attrs={
            "title": "the film of one bearing under a prescribed motion (python3 -m solver bearing --motion)",
            "motion_file": str(args.motion),
            "start": start,
            "substeps_per_row": args.substeps,
            "transport": args.transport if args.cavitation == "jfo" else "none",
            "cavitation": args.cavitation,
            "elastic": args.elastic,
            "inlet": args.inlet,
            "radius_m": args.radius,
            "width_m": args.width,
            "clearance_m": args.clearance,
            "viscosity_Pa_s": args.viscosity,
            "solver_version": __version__,
        },
    )


def _plot(motion, result, path) -> None:
    values, t = result.values, motion.time
    fig, axes = io.subplots(3, 1, figsize=(7, 7.5), constrained_layout=True, sharex=True)
    axes[0].plot(t, values["force_x_N"], label="F_x")
    axes[0].plot(t, values["force_y_N"], label="F_y")
    axes[0].plot(t, np.hypot(values["force_x_N"], values["force_y_N"]), "k--", label="|F|")
    axes[0].set_ylabel("force on journal [N]")
    axes[0].legend(loc="best")
    axes[1].plot(t, values["p_max_Pa"] / 1e6)
    axes[1].set_ylabel("peak pressure [MPa]")
    axes[2].plot(t, values["h_min_m"] * 1e6)
    axes[2].set_ylabel("min film thickness [um]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.ticklabel_format(axis="y", useOffset=False)  # (a constant h_min: no 1e-12 + 2 axis)
        low, high = ax.get_ylim()
        middle, spread = (low + high) / 2, high - low
        if spread < 1e-3 * max(abs(middle), 1e-30):  # a constant curve: +-5 % around it, not round-off
            pad = 0.05 * abs(middle) if middle else 1.0
            ax.set_ylim(middle - pad, middle + pad)
    with io.atomic_path(path) as part:
        fig.savefig(part, format="png", dpi=120)


def _print_table(summary: dict, stream) -> None:
    rows = [
        ("rows", summary["rows"], ""),
        ("max load", summary["max_load_N"], "N"),
        ("mean load", summary["mean_load_N"], "N"),
        ("max peak pressure", summary["max_p_max_Pa"] / 1e6, "MPa"),
        ("min film thickness", summary["min_h_min_m"] * 1e6, "um"),
        ("mean friction torque", summary["means"]["friction_torque_Nm"], "N m"),
        ("mean side flow", summary["means"]["side_flow_m3_per_s"] * 6e4, "l/min"),
        ("internal substeps", summary["internal_substeps"], ""),
        ("solve time", summary["solve_time_s"], "s"),
    ]
    for label, value, unit in rows:
        text = "n/a" if value is None else f"{value:14.6g}"
        print(f"{label:28s} {text:>14s} {unit}", file=stream)
    if summary["netcdf"]:
        print(f"results: {summary['netcdf']}", file=stream)
