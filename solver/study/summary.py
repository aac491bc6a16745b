"""The summary of a batch: one row per case as an xarray Dataset (``summary.nc``) and a PNG.

``summary.nc`` has the dimension ``case`` (the case directory names, in batch order) and

- coordinates: every case parameter that differs between the cases (and every key varied by a sweep
  file, first and in its order), named ``section.key`` in the units of the case file (e.g.
  ``engine.speed_rpm``), with ``units`` and ``long_name``. Parameters are read from each case's
  ``case.toml`` with the defaults of solver.case.FIELDS filled in, so failed cases have them too.
  The parameters that are the same in every case are global attributes ``section.key``.
- variables (NaN for cases without a finished run): ``h_min_min`` [m] cycle minimum of the minimum film
  thickness, ``p_max_max`` [Pa] cycle maximum of the peak film pressure, ``F_asperity_max`` [N] cycle
  maximum of the asperity contact force, ``friction_power_mean`` [W] cycle mean of the friction power,
  ``big_end_h_min_min``, ``big_end_p_max_max``, ``big_end_F_asperity_max``, ``big_end_friction_power_mean``
  the same of the big end (NaN where it is ideal), ``pin_boss_h_min_min`` [m], ``pin_boss_p_max_max`` [Pa],
  ``pin_boss_friction_power_mean`` [W] (the bosses' smooth films have no asperity contact) and
  ``pin_speed_mean`` [rad/s] of a floating pin (NaN for a fixed one), ``run_time`` [s] wall time of the run
  (over every invocation that worked on it: a resumed run's earlier part included),
  ``run_time_last_invocation`` [s] the part of the invocation that finished it; the integers ``cycles``
  (int32; 0 without a finished run) and ``periodic`` (int8, 1 periodic, 0 not, or no finished run; CF
  ``flag_values``/``flag_meanings``), ``ran_this_invocation`` (int8, 1 when the case ran in the batch
  invocation that wrote the summary, 0 when it had finished before or did not run); and the strings
  ``status`` (complete = finished, in this or an earlier invocation; failed, invalid, missing) and
  ``error``. The metrics come from ``results/results.nc``: its ``summary.*`` attributes when present, else
  computed from its variables with the same definitions (trapezoidal cycle mean).
- attributes: besides the constant parameters, ``n_cases`` and the counts ``n_complete`` (every
  finished case), ``n_skipped`` (of them, those finished before this invocation), ``n_failed``,
  ``n_invalid``, ``n_missing``.

For a full-factorial sweep ``ds.set_index(case=[...varied keys...]).unstack("case")`` turns the rows
into an array over the parameters. ``summary_<metric>.png`` plots one metric against each varied
parameter (one panel each, the first six; cases that agree in every other varied parameter are joined
by a line; cases without a value are left out).
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from solver import __version__
from solver.case import FIELDS, INHERITED
from solver.errors import InputError, read_toml_file
from solver.study import io
from solver.study.results import pin_speed_mean

#: metric -> (units, long_name, plot scale, plot unit)
METRICS: dict[str, tuple[str, str, float, str]] = {
    "h_min_min": ("m", "cycle minimum of the minimum film thickness", 1e6, "um"),
    "p_max_max": ("Pa", "cycle maximum of the peak film pressure", 1e-6, "MPa"),
    "F_asperity_max": ("N", "cycle maximum of the asperity contact force", 1.0, "N"),
    "friction_power_mean": ("W", "cycle mean of the friction power loss", 1.0, "W"),
    "run_time": ("s", "wall time of the run", 1.0, "s"),
    "big_end_h_min_min": (
        "m",
        "big end (when lubricated): cycle minimum of its minimum film thickness",
        1e6,
        "um",
    ),
    "big_end_p_max_max": (
        "Pa",
        "big end (when lubricated): cycle maximum of its peak film pressure",
        1e-6,
        "MPa",
    ),
    "big_end_F_asperity_max": (
        "N",
        "big end (when lubricated): cycle maximum of its asperity contact force",
        1.0,
        "N",
    ),
    "big_end_friction_power_mean": (
        "W",
        "big end (when lubricated): cycle mean of its friction power",
        1.0,
        "W",
    ),
    "pin_boss_h_min_min": (
        "m",
        "floating pin: cycle minimum of the bosses' minimum film thickness",
        1e6,
        "um",
    ),
    "pin_boss_p_max_max": (
        "Pa",
        "floating pin: cycle maximum of the bosses' peak film pressure",
        1e-6,
        "MPa",
    ),
    "pin_boss_friction_power_mean": (
        "W",
        "floating pin: cycle mean of the bosses' friction power",
        1.0,
        "W",
    ),
    "pin_speed_mean": (
        "rad s-1",
        "floating pin: mean angular speed over the cycle (its turn over the cycle's duration)",
        60 / (2 * math.pi),
        "rpm",
    ),
}
MAX_PANELS = 6  # the plot shows the first six varied parameters
_RESULTS_VARIABLE = {
    "h_min_min": ("h_min", np.nanmin),
    "p_max_max": ("p_max", np.nanmax),
    "F_asperity_max": ("F_asperity", np.nanmax),
    "friction_power_mean": ("friction_power", None),
    "big_end_h_min_min": ("big_end_h_min", np.nanmin),
    "big_end_p_max_max": ("big_end_p_max", np.nanmax),
    "big_end_F_asperity_max": ("big_end_F_asperity", np.nanmax),
    "big_end_friction_power_mean": ("big_end_friction_power", None),
    "pin_boss_h_min_min": ("pin_boss_h_min", np.nanmin),
    "pin_boss_p_max_max": ("pin_boss_p_max", np.nanmax),
    "pin_boss_friction_power_mean": ("pin_boss_friction_power", None),
}  # None: trapezoidal cycle mean


def case_parameters(case_dir: Path) -> dict[str, Any] | None:
    """Every case key ``section.key`` -> value in TOML units (defaults filled in); None if unreadable.

    ``name`` and ``description`` are left out; absent optional keys are left out.
    """
    try:
        data = read_toml_file(Path(case_dir) / "case.toml", "case file")
    except InputError:
        return None
    values: dict[str, Any] = {}
    for spec in FIELDS:
        if not spec.section:
            continue
        table = data.get(spec.section, {})
        if spec.section in INHERITED and isinstance(table, dict):  # the keys not given: [surface]'s
            inherited = data.get(INHERITED[spec.section], {})
            table = {**(inherited if isinstance(inherited, dict) else {}), **table}
        value = table.get(spec.key, spec.default) if isinstance(table, dict) else spec.default
        if value is None:
            continue
        if isinstance(value, list):
            value = tuple(value)
        values[spec.name] = value
    return values


def case_metrics(results: Path) -> dict[str, float]:
    """The summary metrics of one results file (NaN where unavailable; ``cycles`` and ``periodic``
    NaN too, the summary's integers make them 0)."""
    out = {name: math.nan for name in (*METRICS, "run_time_last_invocation", "cycles", "periodic")}
    try:
        ds = xr.open_dataset(results)
    except Exception:  # noqa: BLE001 - no results: NaN
        return out
    with ds:
        attrs = ds.attrs
        for name, (variable, reduce) in _RESULTS_VARIABLE.items():
            if f"summary.{name}" in attrs:
                out[name] = float(attrs[f"summary.{name}"])
            elif variable in ds:
                values = np.asarray(ds[variable].values, dtype=float)
                if not np.any(np.isfinite(values)):
                    continue
                if reduce is not None:
                    out[name] = float(reduce(values))
                elif np.all(np.isfinite(values)):
                    angle = np.asarray(ds["crank_angle"].values, dtype=float)
                    out[name] = float(np.trapz(values, angle) / (angle[-1] - angle[0]))
        if "summary.pin_speed_mean" in attrs:
            out["pin_speed_mean"] = float(attrs["summary.pin_speed_mean"])
        elif "pin_angle" in ds:
            out["pin_speed_mean"] = pin_speed_mean(ds["pin_angle"].values, ds["time"].values)
        out["run_time"] = float(attrs.get("wall_time_s", math.nan))
        # results of a solver before it: one invocation
        out["run_time_last_invocation"] = float(attrs.get("wall_time_last_invocation_s", out["run_time"]))
        out["cycles"] = float(attrs.get("cycles", math.nan))
        periodic = attrs.get("periodic")
        if periodic is not None:
            out["periodic"] = 1.0 if str(periodic).lower() in ("true", "1") else 0.0
    return out


def _coordinate(values: list[Any]) -> np.ndarray:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return np.array([math.nan if v is None else float(v) for v in values])
    return np.array(["" if v is None else _text(v) for v in values], dtype=object)


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    return str(value)


def _sort_key(text: str) -> tuple:
    try:
        return (0, float(text), "")
    except ValueError:
        return (1, 0.0, text)


def _label(text: str) -> str:
    try:
        return f"{float(text):g}"
    except ValueError:
        return text


def _attribute(value: Any) -> Any:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple):
        return np.array(value, dtype=float)
    return value


def build_summary(records: Sequence[dict], parameters: Sequence[str] = ()):
    """The summary Dataset of the batch records (``case``, ``directory``, ``status``, ``error``)."""
    specs = {spec.name: spec for spec in FIELDS}
    names = [r["case"] for r in records]
    readable = [case_parameters(Path(r["directory"])) for r in records]
    params = [p or {} for p in readable]
    known = [p for p in readable if p is not None]  # an unreadable case.toml does not make keys vary
    keys = [spec.name for spec in FIELDS if any(spec.name in p for p in known)]
    varied = [k for k in parameters if k in keys]
    for key in keys:
        if key not in varied and len({_text(p.get(key)) for p in known}) > 1:
            varied.append(key)
    metrics = [
        case_metrics(Path(r["directory"]) / "results" / "results.nc")
        if r["status"] in ("complete", "skipped")
        else {}
        for r in records
    ]

    def integers(name: str, dtype) -> np.ndarray:  # NaN (no finished run) -> 0
        values = [m.get(name, math.nan) for m in metrics]
        return np.array([int(v) if math.isfinite(v) else 0 for v in values], dtype=dtype)

    coords: dict[str, Any] = {"case": ("case", np.array(names, dtype=object), {"long_name": "case name"})}
    for key in varied:
        spec = specs[key]
        coords[key] = (
            "case",
            _coordinate([p.get(key) for p in params]),
            {"units": spec.unit or "1", "long_name": spec.doc},
        )
    variables: dict[str, Any] = {}
    for name, (units, long_name, _, _) in METRICS.items():
        variables[name] = (
            "case",
            np.array([m.get(name, math.nan) for m in metrics], dtype=float),
            {"units": units, "long_name": long_name},
        )
    variables["run_time_last_invocation"] = (
        "case",
        np.array([m.get("run_time_last_invocation", math.nan) for m in metrics], dtype=float),
        {
            "units": "s",
            "long_name": "wall time of the invocation that finished the run (less than run_time when it "
            "resumed an interrupted run)",
        },
    )
    variables["cycles"] = (
        "case",
        integers("cycles", np.int32),
        {"units": "1", "long_name": "720 deg cycles computed (0: no finished run)"},
    )
    variables["periodic"] = (
        "case",
        integers("periodic", np.int8),
        {
            "units": "1",
            "long_name": "1 if the run reached the periodicity tolerance, 0 if not or without a finished run",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "not_periodic periodic",
        },
    )
    variables["ran_this_invocation"] = (
        "case",
        np.array(
            [1 if r.get("ran_this_invocation", r["status"] != "skipped") else 0 for r in records], np.int8
        ),
        {
            "units": "1",
            "long_name": "1 if the case ran in the batch invocation that wrote this summary, 0 if it had "
            "finished before (or did not run)",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "not_run_now run_now",
        },
    )
    variables["status"] = (
        "case",
        np.array(["complete" if r["status"] == "skipped" else r["status"] for r in records], dtype=object),
        {
            "long_name": "complete (finished, in this or an earlier invocation: see ran_this_invocation), "
            "failed, invalid or missing"
        },
    )
    variables["error"] = (
        "case",
        np.array([r.get("error", "") or "" for r in records], dtype=object),
        {"long_name": "error message of a failed case"},
    )
    constant = {key: _attribute(known[0][key]) for key in keys if key not in varied and key in known[0]}
    counts = {
        state: sum(r["status"] == state for r in records)
        for state in ("complete", "skipped", "failed", "invalid", "missing")
    }
    counts["complete"] += counts["skipped"]  # n_complete: every finished case; n_skipped: not run now
    attrs = {
        "title": "batch summary: one row per case",
        "solver_version": __version__,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "varied_parameters": ", ".join(varied),
        "n_cases": len(records),
        **{f"n_{state}": n for state, n in counts.items()},
        **constant,
    }
    return xr.Dataset(variables, coords=coords, attrs=attrs)


def write_summary(
    records: Sequence[dict], directory: Path, *, metric: str = "h_min_min", parameters: Sequence[str] = ()
) -> list[Path]:
    """Write ``summary.nc`` and ``summary_<metric>.png`` into ``directory``; return their paths."""
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r} (allowed: {', '.join(METRICS)})")
    ds = build_summary(records, parameters)
    directory = Path(directory)
    path = directory / "summary.nc"
    encoding = {
        name: {"zlib": True, "complevel": 4} for name, var in ds.data_vars.items() if var.dtype.kind == "f"
    }  # not the strings
    with io.atomic_path(path) as part:
        ds.to_netcdf(part, encoding=encoding, format="NETCDF4")
    png = directory / f"summary_{metric}.png"
    plot_summary(ds, png, metric)
    return [path, png]


def plot_summary(ds, path: Path, metric: str) -> None:
    """PNG of one metric against each varied parameter."""

    units, long_name, scale, unit = METRICS[metric]
    y = np.asarray(ds[metric].values, dtype=float) * scale
    varied = [k for k in ds.attrs.get("varied_parameters", "").split(", ") if k][:MAX_PANELS]
    ncols = min(max(len(varied), 1), 3)
    nrows = math.ceil(max(len(varied), 1) / ncols)
    fig, axes = io.subplots(
        nrows, ncols, figsize=(5.2 * ncols, 3.8 * nrows), squeeze=False, constrained_layout=True
    )
    if not varied:
        ax = axes[0, 0]
        ax.bar(range(len(y)), np.nan_to_num(y), tick_label=[str(c) for c in ds["case"].values])
        ax.set_ylabel(f"{metric} [{unit}]")
        ax.tick_params(axis="x", rotation=30)
    for number, key in enumerate(varied):
        ax = axes.flat[number]
        values = ds[key].values
        numeric = values.dtype.kind == "f"
        if numeric:
            x = values.astype(float)
        else:
            labels = sorted({str(v) for v in values})
            x = np.array([labels.index(str(v)) for v in values], dtype=float)
            ax.set_xticks(range(len(labels)), labels)
        others = [k for k in varied if k != key]
        groups: dict[tuple, list[int]] = {}
        for i in np.flatnonzero(np.isfinite(y)):  # cases without a value are left out
            groups.setdefault(tuple(str(ds[k].values[i]) for k in others), []).append(i)
        for label, members in sorted(groups.items(), key=lambda item: [_sort_key(v) for v in item[0]]):
            members = sorted(members, key=lambda i: x[i])
            text = ", ".join(f"{k.split('.', 1)[1]}={_label(v)}" for k, v in zip(others, label))
            ax.plot(
                x[members],
                y[members],
                "o-" if len(members) > 1 else "o",
                label=text if len(groups) <= 8 and text else None,
            )
        if not groups:
            ax.text(0.5, 0.5, "no case with a value", ha="center", va="center", transform=ax.transAxes)
        spec_unit = ds[key].attrs.get("units", "")
        ax.set_xlabel(f"{key} [{spec_unit}]" if spec_unit and spec_unit != "1" else key)
        ax.set_ylabel(f"{metric} [{unit}]")
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    for ax in list(axes.flat)[max(len(varied), 1) :]:
        ax.set_visible(False)
    failed = int(np.sum(~np.isfinite(y)))
    fig.suptitle(f"{long_name}" + (f" ({failed} case(s) without a value)" if failed else ""))
    with io.atomic_path(Path(path)) as part:
        fig.savefig(part, dpi=110, format="png")


__all__ = ["METRICS", "build_summary", "write_summary", "plot_summary", "case_parameters", "case_metrics"]
