"""Files: ParaView fields (XDMF), PNG plots, netCDF results. The only module that writes files.

Every file is written under a temporary name (or in a temporary directory) and renamed into place,
so an interrupted run never leaves a half-written file behind. Collective functions take the
communicator from the mesh; only rank 0 writes plots.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import math
import os
import shutil
import tempfile
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

with warnings.catch_warnings():
    # Debian 12's netCDF4 is built against another numpy patch level, and its import warns
    # "numpy.ndarray size changed, may indicate binary incompatibility": harmless (the struct only
    # grew), and nothing a user can act on. Imported here, once, so that xarray finds it loaded.
    warnings.filterwarnings("ignore", "numpy.ndarray size changed", RuntimeWarning)
    import netCDF4  # noqa: F401

log = logging.getLogger(__name__)


def subplots(*args, figsize, constrained_layout: bool = False, **kwargs):
    """(figure, axes) of a new Agg figure: no pyplot, so no global state and no display needed."""
    figure = Figure(figsize=figsize, constrained_layout=constrained_layout)
    return figure, figure.subplots(*args, **kwargs)


@contextlib.contextmanager
def atomic_path(path: Path):
    """Yield a temporary path beside ``path``; rename it to ``path`` if the block succeeds."""
    path = Path(path)
    part = path.with_name(f".{path.name}.part")
    try:
        yield part
        os.replace(part, path)
    finally:
        if part.exists():
            part.unlink()


def _rotation_z(x: np.ndarray, angle: float) -> None:
    c, s = math.cos(angle), math.sin(angle)
    x0 = x[:, 0].copy()
    x[:, 0] = c * x0 - s * x[:, 1]
    x[:, 1] = s * x0 + c * x[:, 1]


def write_film_fields(directory: Path, name: str, model) -> Path:
    """Write the film's current fields (FilmSeries.write) as one snapshot ``directory/name.xdmf``.

    The mesh is in metres in the bushing frame (the solution frame turned back, see
    solver.film.bearing). Collective on the model's communicator.
    """
    series = FilmSeries(directory, name, model, frame_angle=model.frame_angle)
    try:
        series.write(0.0)
        return series.close()
    except BaseException:
        series.abort()
        raise


class FilmSeries:
    """The film fields over the cycle as one ParaView time series: ``directory/name.xdmf`` (+ ``.h5``).

    The mesh is written once, in metres, turned by ``frame_angle`` (the solution frame's angle, to
    put a snapshot in the bushing frame); every ``write(angle)`` adds the fields of the model's
    current solution (pressure, film thickness, asperity pressure) at time = crank angle [deg], so
    that ParaView plays the cycle. With the max-gap inlet the solution frame turns with the
    eccentricity: a series is then in the solution frame (maximum gap at theta = 0).
    Written in a temporary directory and renamed into place by ``close()``; ``abort()`` leaves
    nothing. Collective on the model's communicator.
    """

    def __init__(self, directory: Path, name: str, model, frame_angle: float = 0.0):
        from dolfinx.io import XDMFFile  # dolfinx only for the fields: the plots and netCDF do not need it

        self.directory, self.name, self.model, self.comm = Path(directory), name, model, model.comm
        self.tmp = Path(
            self.comm.bcast(
                tempfile.mkdtemp(prefix=".series-", dir=self.directory) if self.comm.rank == 0 else None,
                root=0,
            )
        )
        self.xdmf = XDMFFile(self.comm, str(self.tmp / f"{name}.xdmf"), "w")
        x = model.mesh.geometry.x
        original = x.copy()
        try:
            _rotation_z(x, frame_angle)
            x *= model.bearing.radius
            self.xdmf.write_mesh(model.mesh)
        finally:
            x[:] = original

    def write(self, angle_deg: float) -> None:
        for field in self.model.fields_si().values():
            self.xdmf.write_function(field, float(angle_deg))

    def close(self) -> Path:
        self.xdmf.close()
        self.comm.Barrier()
        if self.comm.rank == 0:
            merge_xdmf_time_series(self.tmp / f"{self.name}.xdmf", self.name)
            for suffix in (".xdmf", ".h5"):
                os.replace(self.tmp / f"{self.name}{suffix}", self.directory / f"{self.name}{suffix}")
            shutil.rmtree(self.tmp, ignore_errors=True)
        self.comm.Barrier()
        return self.directory / f"{self.name}.xdmf"

    def abort(self) -> None:
        """Leave nothing behind (after an error: no collective call, it could wait forever)."""
        try:
            self.xdmf.close()
        except Exception:  # noqa: BLE001 - already closed, or the error that brought us here
            pass
        if self.comm.rank == 0:
            shutil.rmtree(self.tmp, ignore_errors=True)


def merge_xdmf_time_series(path: Path, name: str) -> None:
    """Rewrite a dolfinx XDMF file so that each time step is one grid carrying every field.

    dolfinx 0.5 writes each function as its own temporal collection: ParaView then reads a multiblock
    with one copy of the mesh per field, each with one array, and a Calculator combining two fields
    gives nothing (dolfinx issue #3026). Here the collections become one, whose grid at each time
    references the mesh's topology and geometry once and holds all the attributes written at that
    time; the HDF5 file is not touched. Rank 0 only, after the XDMFFile is closed.
    """
    xinclude = "http://www.w3.org/2001/XInclude"
    ET.register_namespace("xi", xinclude)
    tree = ET.parse(path)
    domain = tree.getroot().find("Domain")
    grids = domain.findall("Grid")
    mesh = next(g for g in grids if g.get("GridType") == "Uniform")
    collections = [g for g in grids if g.get("CollectionType") == "Temporal"]
    steps: dict[str, list] = {}
    for collection in collections:
        for grid in collection.findall("Grid"):
            steps.setdefault(grid.find("Time").get("Value"), []).extend(grid.findall("Attribute"))
    merged = ET.Element("Grid", Name=name, GridType="Collection", CollectionType="Temporal")
    for time_value in sorted(steps, key=float):
        grid = ET.SubElement(merged, "Grid", Name=name, GridType="Uniform")
        grid.append(mesh.find("Topology"))  # the same HDF5 datasets: no data duplicated
        grid.append(mesh.find("Geometry"))
        ET.SubElement(grid, "Time", Value=time_value)
        grid.extend(steps[time_value])
    for grid in collections + [mesh]:
        domain.remove(grid)
    domain.append(merged)
    ET.indent(tree, space="  ")
    tree.write(path, xml_declaration=True, encoding="utf-8")


def gather_pressure(model) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(theta [deg, bushing frame], z [mm], p [MPa]) of all dofs on rank 0 (a half mesh mirrored to
    the whole width); None elsewhere."""
    n = model.V.dofmap.index_map.size_local
    coords = model.V.tabulate_dof_coordinates()[:n]
    theta = (np.degrees(np.arctan2(coords[:, 1], coords[:, 0]) + model.frame_angle)) % 360.0
    z = coords[:, 2] * model.bearing.radius * 1e3
    p = model.P.x.array[:n] * model.scales.pressure * 1e-6
    if model.mesh_spec.half:  # the solved half z >= 0 and its mirror image
        mirror = z > 0
        theta, z, p = (
            np.concatenate([theta, theta[mirror]]),
            np.concatenate([z, -z[mirror]]),
            np.concatenate([p, p[mirror]]),
        )
    parts = model.comm.gather((theta, z, p), root=0)
    if model.comm.rank != 0:
        return None
    return tuple(np.concatenate([part[i] for part in parts]) for i in range(3))


def plot_pressure_map(path: Path, model, title: str = "") -> None:
    """PNG of the film pressure over the unrolled bearing surface (theta, z). Collective."""
    data = gather_pressure(model)
    if data is None:
        return
    theta, z, p = data
    # repeat a strip across the seam so that the contours reach 0 and 360 deg
    low, high = theta < 20, theta > 340
    theta = np.concatenate([theta, theta[low] + 360, theta[high] - 360])
    z, p = np.concatenate([z, z[low], z[high]]), np.concatenate([p, p[low], p[high]])
    fig, ax = subplots(figsize=(9, 3.6), constrained_layout=True)
    levels = np.linspace(0.0, max(float(p.max()), 1e-12), 21)
    cs = ax.tricontourf(theta, z, p, levels=levels, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="film pressure [MPa]")
    ax.set_xlabel("bushing angle theta [deg]")
    ax.set_ylabel("axial position z [mm]")
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_title(title or "film pressure (cavitated where 0)")
    with atomic_path(Path(path)) as part:
        fig.savefig(part, dpi=120, format="png")


def write_json(path: Path, data: dict) -> None:
    with atomic_path(Path(path)) as part:
        part.write_text(json.dumps(data, indent=2) + "\n")


__all__ = [
    "atomic_path",
    "write_film_fields",
    "plot_pressure_map",
    "gather_pressure",
    "write_json",
    "Checkpoint",
    "write_checkpoint",
    "read_checkpoint",
    "checkpoint_cycles",
]


def write_netcdf(ds, path: Path) -> None:
    """Write an xarray Dataset to netCDF atomically (compressed variables)."""
    encoding = {name: {"zlib": True, "complevel": 4} for name in ds.data_vars}
    with atomic_path(Path(path)) as part:
        ds.to_netcdf(part, encoding=encoding, format="NETCDF4")


STRIBECK_VARIABLES = {  # name -> (units, long_name)
    "eccentricity": ("1", "eccentricity ratio e/c"),
    "h_min": ("m", "minimum film thickness"),
    "h_min_over_sigma": ("1", "minimum film thickness over composite roughness"),
    "friction_coefficient": ("1", "friction coefficient |M_journal| / (R W)"),
    "hydro_load": ("N", "load carried by the film pressure"),
    "asperity_load": ("N", "load carried by asperity contact"),
    "friction_torque": ("N m", "friction torque on the journal"),
    "asperity_friction_torque": ("N m", "asperity part of the friction torque on the journal"),
    "power_loss": ("W", "friction power loss"),
    "p_max": ("Pa", "peak film pressure"),
    "contact_area_ratio": ("1", "real contact area over nominal area"),
}


def stribeck_dataset(speeds_rpm, hersey, petroff, data: dict, attrs: dict):
    variables = {
        name: ("speed", data[name], {"units": u, "long_name": ln})
        for name, (u, ln) in STRIBECK_VARIABLES.items()
    }
    variables["hersey_number"] = (
        "speed",
        hersey,
        {"units": "1", "long_name": "Hersey number eta N / P (N in rev/s)"},
    )
    variables["petroff_friction_coefficient"] = (
        "speed",
        petroff,
        {"units": "1", "long_name": "Petroff's law"},
    )
    return xr.Dataset(
        variables,
        coords={"speed": ("speed", speeds_rpm, {"units": "rpm", "long_name": "journal speed"})},
        attrs=attrs,
    )


def plot_stribeck(ds, path: Path) -> None:
    fig, ax = subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.loglog(ds.hersey_number, ds.friction_coefficient, "o-", label="finite-element mixed lubrication")
    ax.loglog(ds.hersey_number, ds.petroff_friction_coefficient, "--", color="gray", label="Petroff")
    mu_f = ds.attrs.get("asperity_friction")
    if mu_f:
        ax.axhline(mu_f, color="tab:red", ls=":", label="asperity friction coefficient")
    f = ds.friction_coefficient.values
    ax.set_ylim(0.3 * np.nanmin(f), 3 * max(np.nanmax(f), mu_f or 0))
    ax.set_xlabel("Hersey number eta N / P")
    ax.set_ylabel("friction coefficient")
    ax.set_title(f"Stribeck curve, load {ds.attrs['load_N']:g} N")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    with atomic_path(Path(path)) as part:
        fig.savefig(part, dpi=120, format="png")


@dataclasses.dataclass(frozen=True)
class Checkpoint:
    """A run's state at a cycle end (``results/checkpoint.npz``): what a resumed run goes on from.

    Attributes:
        fingerprint: the case settings, joint and solver version it belongs to.
        cycles: cycles done.
        t: s, the time at the cycle end.
        q: coordinates there.
        qd: velocities there (the consistent ones the next cycle starts from).
        h_min_history: m, the min h_min of each cycle done (the periodic test's).
        friction_history: W, the mean friction power of each cycle done (the periodic test's).
        timings: the TIMING of each cycle done (solver.study.results.TIMING).
        thermal: the thermal iteration's state (solver.study.thermal.EffectiveTemperature.state);
            None when isothermal.
        film: the film's committed history states, (time, state) in the order they were committed
            (the film's ``committed_history``; [] for a film without history).
        elapsed_s: s, the wall time of the run up to this checkpoint, over every invocation that
            worked on it (a resumed run's wall time goes on from it).
        joint_histories: m, the min h_min of each cycle done of the other lubricated joints, by name
            (``big_end``, ``pin_boss``; the periodic test follows them too).
        big_end_film: the big end's film's committed history states as ``film`` ([] for a big end
            without history; read as [] from an older checkpoint).
    """

    fingerprint: str
    cycles: int
    t: float
    q: np.ndarray
    qd: np.ndarray
    h_min_history: list[float]
    friction_history: list[float]
    timings: list[dict[str, float]]
    thermal: list[dict] | None = None
    film: list[tuple[float, np.ndarray]] = dataclasses.field(default_factory=list)
    elapsed_s: float = 0.0
    joint_histories: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    big_end_film: list[tuple[float, np.ndarray]] = dataclasses.field(default_factory=list)


def _history_arrays(film: list[tuple[float, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """(times, states) of a film's committed history, for the checkpoint."""
    times = np.array([time for time, _ in film], dtype=float)
    states = np.array([state for _, state in film], dtype=float) if film else np.zeros((0, 0))
    return times, states


def write_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """Write a checkpoint (atomic)."""
    film_times, film_states = _history_arrays(checkpoint.film or [])
    big_times, big_states = _history_arrays(checkpoint.big_end_film or [])
    with atomic_path(path) as part:
        with open(part, "wb") as stream:
            np.savez(
                stream,
                fingerprint=checkpoint.fingerprint,
                cycles=checkpoint.cycles,
                t=checkpoint.t,
                q=checkpoint.q,
                qd=checkpoint.qd,
                history=np.asarray(checkpoint.h_min_history),
                timings=json.dumps(list(checkpoint.timings)),
                thermal=json.dumps(checkpoint.thermal),
                film_times=film_times,
                film_states=film_states,
                friction=np.asarray(checkpoint.friction_history, dtype=float),
                elapsed=float(checkpoint.elapsed_s),
                joint_histories=json.dumps(
                    {k: list(map(float, v)) for k, v in checkpoint.joint_histories.items()}
                ),
                big_end_film_times=big_times,
                big_end_film_states=big_states,
            )


def checkpoint_cycles(path: Path) -> int | None:
    """The number of cycles a checkpoint file holds (whatever case it belongs to); None without a
    readable one. For messages (e.g. after an interruption: where a rerun resumes)."""
    try:
        with np.load(path) as data:
            return int(data["cycles"])
    except (OSError, KeyError, ValueError):
        return None


def read_checkpoint(path: Path, fingerprint: str) -> Checkpoint | None:
    """The checkpoint at ``path`` if it belongs to the same case (``fingerprint``), else None."""
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            if str(data["fingerprint"]) != fingerprint:
                log.info("checkpoint %s belongs to other case settings: starting afresh", path)
                return None
            timings = json.loads(str(data["timings"])) if "timings" in data else []
            return Checkpoint(
                fingerprint=fingerprint,
                cycles=int(data["cycles"]),
                t=float(data["t"]),
                q=data["q"].copy(),
                qd=data["qd"].copy(),
                h_min_history=list(data["history"]),
                friction_history=list(data["friction"]) if "friction" in data else [],
                timings=timings,
                thermal=json.loads(str(data["thermal"])) if "thermal" in data else None,
                film=(
                    list(zip(data["film_times"].tolist(), data["film_states"].copy()))
                    if "film_times" in data
                    else []
                ),
                # an older checkpoint without it: the cycles' own wall times (without the set-up)
                elapsed_s=(
                    float(data["elapsed"])
                    if "elapsed" in data
                    else float(sum(t.get("wall_s", 0.0) for t in timings))
                ),
                joint_histories=json.loads(str(data["joint_histories"])) if "joint_histories" in data else {},
                big_end_film=(
                    list(zip(data["big_end_film_times"].tolist(), data["big_end_film_states"].copy()))
                    if "big_end_film_times" in data
                    else []
                ),
            )
    except (OSError, KeyError, ValueError) as err:
        log.warning("unreadable checkpoint %s (%s): starting afresh", path, err)
        return None
