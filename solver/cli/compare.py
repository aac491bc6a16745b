"""``python3 -m solver compare RUN RUN ...``: finished runs side by side, in one table and one plot.

Each RUN is a case directory (its ``results/results.nc``), a results directory (``run --output DIR``,
holding ``results.nc``) or a results file. A run is labelled by its directory's name, a file by the case
name stored in it (so that a copied ``results.nc`` keeps its case's name). Prints one row per run (or
one JSON object with ``--json``): the joint, the cycle minimum of h_min, the maxima of p_max, of the
asperity force and of the bushing's deformation, the cycle means of the friction power and of the ruptured
film's share of the bearing area (cavitation model beside it); for a lubricated big end one more line
(JSON keys ``big_end_*``: its joint, min h_min, max p_max, max asperity force, mean friction power), for a
floating pin one
more (JSON keys ``pin``, ``pin_speed_mean_rpm`` and ``pin_boss_*``: the bosses' film's min h_min, max p_max,
mean friction power). With ``--output PNG``
rank 0 also writes the plot: h_min, p_max, asperity force, friction power and (where the runs have it) the
cavitated area over the crank angle, one line per run (e.g. the rigid and the elastic small end of the
same engine, or the Reynolds condition and the mass-conserving film).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import xarray as xr

from solver.errors import InputError
from solver.study import io
from solver.study.results import is_complete, nan_reduce, pin_speed_mean
from solver.study.thermal import cycle_mean

# (variable, label, scale to the plotted unit)
PANELS = (
    ("h_min", "h_min [um]", 1e6),
    ("p_max", "p_max [MPa]", 1e-6),
    ("F_asperity", "asperity force [N]", 1.0),
    ("friction_power", "friction power [W]", 1.0),
    ("cavitated_area_ratio", "cavitated area ratio", 1.0),
)
#: more panels when some run has a lubricated big end (the force on the rod also for an ideal one) or a
#: floating pin
BIG_END_PANELS = (
    ("big_end_force", "big end: force on the rod [kN]", 1e-3),
    ("big_end_h_min", "big end: h_min [um]", 1e6),
    ("big_end_p_max", "big end: p_max [MPa]", 1e-6),
    ("big_end_friction_power", "big end: friction power [W]", 1.0),
)
PIN_PANELS = (("pin_speed", "floating pin: speed [rpm]", 60 / (2 * np.pi)),)


def _panel_values(ds: xr.Dataset, name: str) -> np.ndarray | None:
    """A panel's values of one run (None: the run has none)."""
    if name == "big_end_force":
        if "big_end_force_x" not in ds:
            return None
        return np.hypot(ds.big_end_force_x.values, ds.big_end_force_y.values)
    return ds[name].values if name in ds else None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``compare`` command."""
    parser.add_argument(
        "runs",
        nargs="+",
        metavar="RUN",
        help="case directory (with results/results.nc), results directory (with results.nc) or a "
        "results.nc file; at least one",
    )
    parser.add_argument(
        "--output", type=Path, default=None, metavar="PNG", help="write the comparison plot here"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")


def results_path(run: str) -> Path:
    """The results file of a RUN argument; InputError unless it is a finished run's."""
    path = Path(run)
    if path.is_dir():
        path = path / "results.nc" if (path / "results.nc").is_file() else path / "results" / "results.nc"
    if not is_complete(path):
        raise InputError(
            f"RUN = {run!r} is out of range (allowed: a case directory with a finished run's "
            "results/results.nc, a directory with such a results.nc, or such a file)"
        )
    return path


def run_label(run: str, path: Path) -> str:
    """A run's label: a directory's name, or (a file, perhaps copied elsewhere) the case name stored in it."""
    if Path(run).is_dir():
        return Path(run).resolve().name
    with xr.open_dataset(path) as ds:
        return str(ds.attrs.get("name", "")) or path.stem


def summary(ds: xr.Dataset, label: str) -> dict:
    """The row of one run (SI)."""
    angle = ds.crank_angle.values
    deformation = ds["deformation_max"].values if "deformation_max" in ds else np.full(angle.size, np.nan)
    return {
        "run": label,
        "joint": str(ds.attrs.get("joint", "")),
        "elastic": str(ds.attrs.get("small_end.elastic", "none")),
        "piezoviscosity": str(ds.attrs.get("oil.piezoviscosity", "none")),
        "h_min_min_m": nan_reduce(np.nanmin, ds.h_min.values),
        "p_max_max_Pa": nan_reduce(np.nanmax, ds.p_max.values),
        "F_asperity_max_N": nan_reduce(np.nanmax, ds.F_asperity.values),
        "friction_power_mean_W": cycle_mean(ds.friction_power.values, angle),
        "deformation_max_m": nan_reduce(np.nanmax, deformation),
        "cavitation": str(ds.attrs.get("oil.cavitation", "reynolds")),
        "cavitated_area_mean": (
            cycle_mean(ds.cavitated_area_ratio.values, angle)
            if "cavitated_area_ratio" in ds
            else float("nan")
        ),
        **_big_end(ds, angle),
        **_pin(ds, angle),
    }


def _values(ds: xr.Dataset, angle: np.ndarray, name: str) -> np.ndarray:
    """A variable's values over the crank angle; NaN where the file does not have it."""
    return ds[name].values if name in ds else np.full(angle.size, np.nan)


def _big_end(ds: xr.Dataset, angle: np.ndarray) -> dict:
    """The big end's joint and, when lubricated, its metrics (NaN when ideal or not in the file)."""

    return {
        "big_end_joint": str(ds.attrs.get("big_end.joint", "ideal")),
        "big_end_h_min_min_m": nan_reduce(np.nanmin, _values(ds, angle, "big_end_h_min")),
        "big_end_p_max_max_Pa": nan_reduce(np.nanmax, _values(ds, angle, "big_end_p_max")),
        "big_end_F_asperity_max_N": nan_reduce(np.nanmax, _values(ds, angle, "big_end_F_asperity")),
        "big_end_friction_power_mean_W": cycle_mean(_values(ds, angle, "big_end_friction_power"), angle),
    }


def _pin(ds: xr.Dataset, angle: np.ndarray) -> dict:
    """The piston pin (fixed or floating) and, when floating, its mean speed and the bosses' film's
    metrics (NaN for a fixed pin or a file without them)."""

    return {
        "pin": str(ds.attrs.get("small_end.pin", "fixed")),
        "pin_speed_mean_rpm": pin_speed_mean(_values(ds, angle, "pin_angle"), _values(ds, angle, "time"))
        * 60
        / (2 * np.pi),
        "pin_boss_h_min_min_m": nan_reduce(np.nanmin, _values(ds, angle, "pin_boss_h_min")),
        "pin_boss_p_max_max_Pa": nan_reduce(np.nanmax, _values(ds, angle, "pin_boss_p_max")),
        "pin_boss_friction_power_mean_W": cycle_mean(_values(ds, angle, "pin_boss_friction_power"), angle),
    }


def plot(datasets: dict[str, xr.Dataset], path: Path) -> None:
    """One panel per PANELS variable (that some run has) over the crank angle, one line per run; the big
    end's panels when some run has a lubricated big end, the pin's speed when some run's pin floats."""
    big_end = any(ds.attrs.get("big_end.joint", "ideal") != "ideal" for ds in datasets.values())
    floating = any(ds.attrs.get("small_end.pin", "fixed") == "floating" for ds in datasets.values())
    candidates = PANELS + (BIG_END_PANELS if big_end else ()) + (PIN_PANELS if floating else ())
    panels = [p for p in candidates if any(_panel_values(ds, p[0]) is not None for ds in datasets.values())]
    fig, axes = io.subplots(
        len(panels), 1, figsize=(8, 2.2 * len(panels)), sharex=True, constrained_layout=True
    )
    for ax, (name, label, scale) in zip(axes, panels):
        for run, ds in datasets.items():
            values = _panel_values(ds, name)
            if values is not None:
                ax.plot(ds.crank_angle.values, values * scale, lw=1.2, label=run)
        ax.set_ylabel(label)
        for x in (0, 180, 360, 540, 720):
            ax.axvline(x, color="0.85", lw=0.8, zorder=0)
    axes[0].legend(fontsize=8)
    title = "small end" + (", big end" if big_end else "") + (", floating pin" if floating else "")
    axes[0].set_title(f"{title} over the cycle, run by run", fontsize=9)
    axes[-1].set_xlim(0, 720)
    axes[-1].set_xticks(range(0, 721, 90))
    axes[-1].set_xlabel("crank angle [deg] (360 = firing TDC)")
    with io.atomic_path(path) as part:
        fig.savefig(part, dpi=110, format="png")


def run(args: argparse.Namespace, comm) -> int:
    """Read the runs, print the table (or JSON), write the plot; exit status 0."""
    paths = [results_path(r) for r in args.runs]
    if args.output is not None and args.output.suffix.lower() != ".png":
        raise InputError(f"--output = {str(args.output)!r} is out of range (allowed: a .png file)")
    labels: list[str] = []
    for r, path in zip(args.runs, paths):
        name = run_label(r, path)
        labels.append(name if name not in labels else f"{name} ({len(labels) + 1})")
    datasets = {}
    try:
        for label, path in zip(labels, paths):
            with xr.open_dataset(path) as ds:
                datasets[label] = ds.load()
        rows = [summary(ds, label) for label, ds in datasets.items()]
        if comm.rank == 0:
            if args.output is not None:
                plot(datasets, args.output)
            if args.json:
                print(json.dumps({"runs": rows, "plot": str(args.output) if args.output else None}))
            else:
                print(
                    f"{'run':<28} {'joint':>13} {'elastic':>8} {'piezo':>8} {'min h_min':>11} "
                    f"{'max p_max':>10} {'max F_asp':>10} "
                    f"{'friction':>9} {'max w':>8} {'cavitation':>10} {'cav. area':>9}"
                )
                for row in rows:
                    print(
                        f"{row['run']:<28} {row['joint']:>13} {row['elastic']:>8} {row['piezoviscosity']:>8} "
                        f"{row['h_min_min_m'] * 1e6:>8.3f} um {row['p_max_max_Pa'] / 1e6:>6.1f} MPa "
                        f"{row['F_asperity_max_N']:>8.1f} N {row['friction_power_mean_W']:>7.3f} W "
                        f"{row['deformation_max_m'] * 1e6:>5.2f} um {row['cavitation']:>10} "
                        f"{row['cavitated_area_mean']:>9.3f}"
                    )
                for row in rows:
                    if row["big_end_joint"] != "ideal":
                        print(
                            f"{row['run']:<28} big end {row['big_end_joint']}: min h_min "
                            f"{row['big_end_h_min_min_m'] * 1e6:.3f} um, max p_max "
                            f"{row['big_end_p_max_max_Pa'] / 1e6:.1f} MPa, max asperity force "
                            f"{row['big_end_F_asperity_max_N']:.1f} N, friction "
                            f"{row['big_end_friction_power_mean_W']:.3f} W"
                        )
                for row in rows:
                    if row["pin"] == "floating":
                        print(
                            f"{row['run']:<28} floating pin: mean speed {row['pin_speed_mean_rpm']:.2f} rpm; "
                            f"bosses min h_min {row['pin_boss_h_min_min_m'] * 1e6:.3f} um, max p_max "
                            f"{row['pin_boss_p_max_max_Pa'] / 1e6:.1f} MPa, friction "
                            f"{row['pin_boss_friction_power_mean_W']:.4f} W"
                        )
                if args.output is not None:
                    print(f"plot: {args.output}")
    finally:
        for ds in datasets.values():
            ds.close()
    return 0
