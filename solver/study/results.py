"""Results of a coupled run: the netCDF data contract (DESIGN 4), PNG plots and the log.

``results.nc`` has the dimension ``crank_angle`` (deg, 0-720, the last computed cycle) and the
DESIGN 4 variables (names are an interface: add, do not rename), each with ``units`` and
``long_name``; its scalar variables (``FILM_VARIABLES``) the film's temperature and viscosity in the
last cycle and its heat balance (solver.study.thermal); its attributes hold every case parameter as
``"section.key"`` in the case file's units, the solver version, the numerical settings, the wall time
and ``status = "complete"`` (a results file without it is not a finished run). Files are written by
rank 0 of the case communicator, under a temporary name and renamed into place.
"""

from __future__ import annotations

import dataclasses
import datetime
import logging
import math
from pathlib import Path

from mpi4py import MPI

import numpy as np
import xarray as xr

from solver import __version__
from solver.case import case_attributes
from solver.study import io
from solver.study.thermal import cycle_mean

log = logging.getLogger(__name__)

#: name -> (units, long_name). The first block is the DESIGN 4 contract; the rest are additions.
VARIABLES: dict[str, tuple[str, str]] = {
    "F_gas": ("N", "gas force on the piston, towards the crank"),
    "x_piston": ("m", "piston pin position along the cylinder axis"),
    "a_piston": ("m s-2", "piston acceleration along the cylinder axis"),
    "pin_force_x": ("N", "force of the pin on the rod small end, x (film + asperity + friction)"),
    "pin_force_y": ("N", "force of the pin on the rod small end, y (film + asperity + friction)"),
    "ideal_pin_force_x": ("N", "force of the pin on the rod small end with an ideal joint, x"),
    "ideal_pin_force_y": ("N", "force of the pin on the rod small end with an ideal joint, y"),
    "ecc_x": ("m", "eccentricity of the pin in the bushing (rod) frame, x (along the rod)"),
    "ecc_y": ("m", "eccentricity of the pin in the bushing (rod) frame, y"),
    "eps": ("1", "eccentricity ratio |e|/c"),
    "h_min": ("m", "minimum film thickness"),
    "p_max": ("Pa", "peak film pressure"),
    "F_hydro": ("N", "film (hydrodynamic) force magnitude"),
    "F_asperity": ("N", "asperity contact force magnitude"),
    "friction_torque": ("N m", "friction torque on the pin about its centre (viscous + asperity)"),
    "friction_power": ("W", "friction power loss, -friction_torque x (omega_pin - omega_rod)"),
    "crank_torque": ("N m", "driving torque on the crank (counter-clockwise +)"),
    # additions
    "time": ("s", "time"),
    "v_piston": ("m s-1", "piston velocity along the cylinder axis"),
    "rod_angle": ("rad", "connecting rod angle from the cylinder axis"),
    "p_cyl": ("Pa", "cylinder pressure (absolute)"),
    "ecc_rate_x": ("m s-1", "rate of ecc_x in the rotating rod frame"),
    "ecc_rate_y": ("m s-1", "rate of ecc_y in the rotating rod frame"),
    "omega_rel": ("rad s-1", "angular speed of the pin relative to the rod"),
    "h_min_over_sigma": ("1", "minimum film thickness over composite roughness"),
    "contact_area_ratio": ("1", "real asperity contact area over nominal bearing area"),
    "deformation_max": (
        "m",
        "largest radial deformation of the bushing surface, signed (+ opens the gap; 0: rigid)",
    ),
    "deformation_max_angle": ("rad", "bushing (rod frame) angle of deformation_max"),
    "deformation_max_angle_deg": (
        "degree",
        "deformation_max_angle in degrees, [0, 360) from the rod frame's +x axis towards +y (as h_min_angle)",
    ),
    "h_min_angle": (
        "degree",
        "bushing (rod frame) angle where the film is thinnest, [0, 360) from the rod frame's +x axis "
        "(along the rod, as ecc_x) towards +y (as ecc_y): along the eccentricity for a rigid bushing, "
        "the deformed film's thinnest point for an elastic one; NaN for the ideal joint",
    ),
    "squeeze_power": ("W", "power of the joint force on the relative pin motion, -F . de/dt"),
    "side_flow": ("m3 s-1", "oil volume flow out of both bushing edges (film joints; NaN otherwise)"),
    "supply_flow": (
        "m3 s-1",
        "oil volume flow from the supply hole or groove into the film (finite-element film; "
        "0 without a supply, NaN for other joints)",
    ),
    "cavitated_area_ratio": (
        "1",
        "ruptured film area over bearing area: film fraction < 1 (oil.cavitation = jfo) "
        "or pressure at the cavitation pressure (reynolds); finite-element film, NaN otherwise",
    ),
    "oil_volume": (
        "m3",
        "oil held in the film, integral of film fraction x mean gap (oil.cavitation = jfo; NaN otherwise)",
    ),
    "dissipated_power": ("W", "power dissipated in the joint (friction + squeeze)"),
    "input_power": ("W", "power of the crank driver and the gas on the mechanism"),
    "kinetic_energy": ("J", "kinetic energy of the mechanism"),
    "potential_energy": ("J", "gravitational potential energy of the mechanism"),
    "input_work": (
        "J",
        "work of the crank driver (from the crank's generalized momentum) and of the gas since "
        "the cycle's start",
    ),
    "dissipated_energy": (
        "J",
        "energy dissipated in the clearance joints (small end, and big end when lubricated, and a floating "
        "pin's bosses) since the cycle's start, integrated along the integrator's stages",
    ),
    "drift_work": (
        "J",
        "work of the constraints' reactions on the integrator's velocity-constraint residual "
        "since the cycle's start, with the kinetic energy of the velocities' projection at the "
        "outputs: a numerical term (0 for an exact solution)",
    ),
    # the big end (crankpin in the rod's big eye; big_end.joint): its force on the rod with any joint,
    # the clearance joint's variables (NaN for the ideal big end) as the small end's, in the rod frame
    "big_end_force_x": ("N", "force of the crankpin on the rod big end, x (film force when lubricated)"),
    "big_end_force_y": ("N", "force of the crankpin on the rod big end, y (film force when lubricated)"),
    "big_end_ecc_x": ("m", "eccentricity of the crankpin in the big eye (rod frame), x (along the rod)"),
    "big_end_ecc_y": ("m", "eccentricity of the crankpin in the big eye (rod frame), y"),
    "big_end_ecc_rate_x": ("m s-1", "rate of big_end_ecc_x in the rotating rod frame"),
    "big_end_ecc_rate_y": ("m s-1", "rate of big_end_ecc_y in the rotating rod frame"),
    "big_end_omega_rel": ("rad s-1", "angular speed of the crank relative to the rod"),
    "big_end_h_min": ("m", "big end: minimum film thickness"),
    "big_end_h_min_angle": ("degree", "big end: rod-frame angle of the thinnest film, as h_min_angle"),
    "big_end_p_max": ("Pa", "big end: peak film pressure"),
    "big_end_F_hydro": ("N", "big end: film (hydrodynamic) force magnitude"),
    "big_end_F_asperity": (
        "N",
        "big end: asperity contact force magnitude (mixed-fem; dry: all of the force; short-bearing: 0)",
    ),
    "big_end_contact_area_ratio": ("1", "big end: real asperity contact area over nominal bearing area"),
    "big_end_supply_flow": ("m3 s-1", "big end: oil volume flow from a supply into the film (mixed-fem)"),
    "big_end_cavitated_area_ratio": (
        "1",
        "big end: ruptured film area over bearing area, as cavitated_area_ratio (mixed-fem)",
    ),
    "big_end_friction_torque": ("N m", "big end: friction torque on the crankpin about its centre"),
    "big_end_friction_power": (
        "W",
        "big end: friction power loss, -big_end_friction_torque x (omega_crank - omega_rod)",
    ),
    "big_end_squeeze_power": ("W", "big end: power of the joint force on the relative motion, -F . de/dt"),
    "big_end_side_flow": ("m3 s-1", "big end: oil volume flow out of both edges"),
    "big_end_dissipated_power": ("W", "big end: power dissipated in the joint (friction + squeeze)"),
    "big_end_oil_volume": (
        "m3",
        "big end: oil held in the film, as oil_volume (mixed-fem with oil.cavitation = jfo; NaN otherwise)",
    ),
    "big_end_deformation_max": (
        "m",
        "big end: largest radial deformation of the shell's surface (with the FE eye: of the eye and the "
        "shell), as deformation_max (mixed-fem; 0: rigid, big_end.elastic)",
    ),
    "big_end_deformation_max_angle": (
        "rad",
        "big end: rod-frame angle of big_end_deformation_max, as deformation_max_angle",
    ),
    # the full-floating pin (small_end.pin = "floating"; NaN for a fixed pin): its rotation, the torques of
    # both films on it, and its film in the piston bosses ([pin_boss]) as the small end's, in the piston
    # frame (= the global frame: the piston does not turn)
    "pin_angle": (
        "rad",
        "floating pin: angle of the pin about its axis (counter-clockwise +), from 0 at the run's start",
    ),
    "pin_speed": ("rad s-1", "floating pin: angular speed of the pin (counter-clockwise +)"),
    "pin_torque_small_end": (
        "N m",
        "floating pin: the small end's friction torque on the pin about its centre",
    ),
    "pin_torque_boss": ("N m", "floating pin: the bosses' friction torque on the pin about its centre"),
    "pin_torque_net": (
        "N m",
        "floating pin: pin_torque_small_end + pin_torque_boss, = pin inertia x angular acceleration",
    ),
    "pin_boss_force_x": ("N", "floating pin: force of the pin on the piston bosses, x (film force)"),
    "pin_boss_force_y": ("N", "floating pin: force of the pin on the piston bosses, y (film force)"),
    "pin_boss_ecc_x": (
        "m",
        "eccentricity of the pin in the bosses (piston frame), x (along the cylinder axis)",
    ),
    "pin_boss_ecc_y": ("m", "eccentricity of the pin in the bosses (piston frame), y"),
    "pin_boss_ecc_rate_x": ("m s-1", "rate of pin_boss_ecc_x"),
    "pin_boss_ecc_rate_y": ("m s-1", "rate of pin_boss_ecc_y"),
    "pin_boss_omega_rel": ("rad s-1", "angular speed of the pin relative to the piston (= pin_speed)"),
    "pin_boss_h_min": ("m", "pin bosses: minimum film thickness"),
    "pin_boss_h_min_angle": ("degree", "pin bosses: piston-frame angle of the thinnest film, as h_min_angle"),
    "pin_boss_p_max": ("Pa", "pin bosses: peak film pressure"),
    "pin_boss_F_hydro": ("N", "pin bosses: film (hydrodynamic) force magnitude"),
    "pin_boss_F_asperity": (
        "N",
        "pin bosses: asperity contact force magnitude (pin_boss.joint = mixed-fem; 0: the smooth short "
        "bearing)",
    ),
    "pin_boss_friction_torque": ("N m", "pin bosses: friction torque on the pin about its centre"),
    "pin_boss_friction_power": (
        "W",
        "pin bosses: friction power loss, -pin_boss_friction_torque x pin_speed",
    ),
    "pin_boss_squeeze_power": (
        "W",
        "pin bosses: power of the joint force on the relative motion, -F . de/dt",
    ),
    "pin_boss_side_flow": ("m3 s-1", "pin bosses: oil volume flow out of both edges"),
    "pin_boss_dissipated_power": ("W", "pin bosses: power dissipated in the joint (friction + squeeze)"),
}


#: The variables build_dataset derives from the others (and the ideal cycle) rather than from each state
DERIVED_VARIABLES = (
    "ideal_pin_force_x",
    "ideal_pin_force_y",
    "eps",
    "h_min_over_sigma",
    "deformation_max_angle_deg",
)
#: The variables of each output state (solver.study.outputs); NaN where a state has no value for one
#: (the film variables of an ideal joint, a joint that does not report it, a film that failed to solve)
STATE_VARIABLES = tuple(name for name in VARIABLES if name not in DERIVED_VARIABLES)

#: Scalars of the last cycle: name -> (units, long_name). Film temperature and viscosity are the case's with
#: oil.thermal = "isothermal" (temperature NaN when the case gives viscosity_Pa_s), the effective ones
#: with "effective"; the heat balance terms other than heat_generated are NaN when isothermal.
FILM_VARIABLES: dict[str, tuple[str, str]] = {
    "film_temperature": ("degC", "film (oil) temperature of the last cycle"),
    "film_viscosity": ("Pa s", "dynamic viscosity of the oil at film_temperature, used in the last cycle"),
    "film_density": ("kg m-3", "density of the oil at film_temperature"),
    "heat_generated": ("W", "cycle mean of dissipated_power"),
    "side_flow_mean": ("m3 s-1", "cycle mean of side_flow"),
    "heat_to_oil": ("W", "heat into the oil, (1 - oil.heat_to_solids) x heat_generated"),
    "heat_carried": (
        "W",
        (
            "heat carried out by the side flow, film_density c_p side_flow_mean "
            "(film_temperature - oil.temperature_C)"
        ),
    ),
    "thermal_closure": ("1", "|heat_to_oil - heat_carried| / heat_to_oil"),
}


#: Where the time of a cycle goes: name -> meaning (names ending in _s are seconds, the others counts).
#: Logged per cycle and stored in the results' attributes as ``timing.<name>`` (one value per computed
#: cycle, the first cycle first).
TIMING: dict[str, str] = {
    "wall_s": "wall time of the cycle (integration, outputs, the film alone and checkpoint)",
    "film_solves": "film solves (each an SNES VI solve, its assembly and functionals; the small end's and "
    "a finite-element big end's together, as the other film counts and seconds)",
    "vi_iterations": "SNES VI (Newton) iterations of all film solves",
    "film_jacobians": "film Jacobians (sensitivities with the converged active set)",
    "steps": "accepted integrator steps",
    "rejected_steps": "rejected integrator step attempts (error test or Newton failure)",
    "transport_fallbacks": "JFO film with the limited transport: committed states whose step fell back to "
    "upwinding (its limited solve did not converge)",
    "euler_rate_steps": "film with history: committed steps more than BDF2_MAX_RATIO (2.4) times the one "
    "before (the integrator grows its step up to 5 times, after a rejection or a step cut short at an "
    "output), over which the film's rate was implicit Euler, not BDF2 (solver.film.history)",
    "film_solve_s": "seconds in film solves",
    "film_jacobian_s": "seconds in film Jacobians",
    "multibody_s": "seconds in the multibody system, integrator and Python (the rest of the cycle)",
    "io_s": "seconds writing the checkpoint",
    "film_alone_solves": "film solves of the small end's film run alone under the cycle's motion after it "
    '(solver.periodic_acceleration = "film"; 0 otherwise)',
    "film_alone_s": "seconds of those solves",
}


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """What a finished run returns (and the batch layer tabulates)."""

    case: str
    results: Path  # results.nc
    h_min_min: float  # m, cycle minimum of the minimum film thickness
    p_max_max: float  # Pa, cycle maximum of the peak film pressure
    F_asperity_max: float  # N, cycle maximum of the asperity contact force
    friction_power_mean: float  # W, cycle mean of the friction power
    cycles: int
    periodic: bool  # periodic (and, with oil.thermal = "effective", thermally consistent)
    wall_time: float  # s, over every invocation that worked on the run (a resumed run's included)
    film_temperature: float = math.nan  # C, in the last cycle (FILM_VARIABLES)
    film_viscosity: float = math.nan  # Pa s, at film_temperature
    thermal_closure: float = math.nan  # |heat_to_oil - heat_carried| / heat_to_oil (NaN: isothermal)
    heat_generated: float = math.nan  # W, cycle mean of the dissipated power
    heat_to_oil: float = math.nan  # W
    heat_carried: float = math.nan  # W, by the side flow
    wall_time_last_invocation: float = math.nan  # s, of the invocation that finished the run
    big_end_h_min_min: float = math.nan  # m, cycle minimum of the big end's film thickness (NaN: ideal)
    big_end_friction_power_mean: float = math.nan  # W, cycle mean of the big end's friction power
    big_end_p_max_max: float = math.nan  # Pa, cycle maximum of the big end's peak pressure
    big_end_F_asperity_max: float = math.nan  # N, cycle maximum of the big end's asperity force
    pin_boss_h_min_min: float = math.nan  # m, cycle minimum of the floating pin's boss film (NaN: fixed pin)
    pin_boss_p_max_max: float = math.nan  # Pa, cycle maximum of the bosses' peak pressure
    pin_boss_friction_power_mean: float = math.nan  # W, cycle mean of the bosses' friction power
    pin_speed_mean: float = math.nan  # rad/s, the floating pin's mean angular speed over the cycle


def attach_log(path: Path, comm: MPI.Comm) -> logging.Handler | None:
    """Log the run to ``path`` (rank 0 of the case communicator)."""
    if comm.rank != 0:
        return None
    handler = logging.FileHandler(path, mode="a")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger("solver")
    root.addHandler(handler)
    if root.level == logging.NOTSET or root.level > logging.INFO:
        root.setLevel(logging.INFO)
    return handler


def detach_log(handler: logging.Handler | None) -> None:
    if handler is not None:
        logging.getLogger("solver").removeHandler(handler)
        handler.close()


def build_dataset(
    case, columns: dict[str, np.ndarray], ideal, *, attrs: dict, film: dict[str, float] | None = None
):
    """The xarray Dataset of the data contract; ``film``: the FILM_VARIABLES (scalars), if given."""
    angles = columns["crank_angle"]
    data = dict(columns)
    data["ideal_pin_force_x"] = np.interp(angles, ideal.crank_angle, ideal.pin_force_x)
    data["ideal_pin_force_y"] = np.interp(angles, ideal.crank_angle, ideal.pin_force_y)
    data["eps"] = np.hypot(data["ecc_x"], data["ecc_y"]) / case.small_end.clearance
    data["h_min_over_sigma"] = data["h_min"] / case.surface.sigma
    data["deformation_max_angle_deg"] = np.degrees(np.asarray(data["deformation_max_angle"], dtype=float))
    variables = {
        name: ("crank_angle", np.asarray(data[name], dtype=float), {"units": u, "long_name": ln})
        for name, (u, ln) in VARIABLES.items()
    }
    if film is not None:
        variables.update(
            {
                name: ((), float(film[name]), {"units": u, "long_name": ln})
                for name, (u, ln) in FILM_VARIABLES.items()
            }
        )
    coords = {
        "crank_angle": (
            "crank_angle",
            angles,
            {"units": "degree", "long_name": "crank angle (0 = TDC at the start of intake)"},
        )
    }
    return xr.Dataset(variables, coords=coords, attrs=attrs)


def write_results(
    out_dir: Path,
    case,
    run,
    cycle,
    ideal,
    *,
    joint: str,
    cycles: int,
    periodic: bool,
    wall_time: float,
    fields: list[Path],
    comm: MPI.Comm,
):
    """Write results.nc and the plots (rank 0); return the RunSummary on every rank. ``wall_time`` is
    this invocation's; the results hold it as ``wall_time_last_invocation_s`` and, with the earlier
    invocations' (``run.earlier_wall_time``, from the checkpoint a resumed run started from), as
    ``wall_time_s``."""
    cols = cycle.columns
    invocation, wall_time = wall_time, wall_time + getattr(run, "earlier_wall_time", 0.0)
    summary_values = {
        "h_min_min": nan_reduce(np.nanmin, cols["h_min"]),
        "p_max_max": nan_reduce(np.nanmax, cols["p_max"]),
        "F_asperity_max": nan_reduce(np.nanmax, cols["F_asperity"]),
        "friction_power_mean": cycle_mean(cols["friction_power"], cols["crank_angle"]),
    }
    big_end = {
        "big_end_h_min_min": nan_reduce(np.nanmin, cols["big_end_h_min"]),
        "big_end_p_max_max": nan_reduce(np.nanmax, cols["big_end_p_max"]),
        "big_end_F_asperity_max": nan_reduce(np.nanmax, cols["big_end_F_asperity"]),
        "big_end_friction_power_mean": cycle_mean(cols["big_end_friction_power"], cols["crank_angle"]),
    }
    pin = {
        "pin_boss_h_min_min": nan_reduce(np.nanmin, cols["pin_boss_h_min"]),
        "pin_boss_p_max_max": nan_reduce(np.nanmax, cols["pin_boss_p_max"]),
        "pin_boss_friction_power_mean": cycle_mean(cols["pin_boss_friction_power"], cols["crank_angle"]),
        "pin_speed_mean": pin_speed_mean(cols["pin_angle"], cols["time"]),
    }
    film = run.oil.record(cols)
    attrs = {**case_attributes(case)}
    attrs.update(
        {
            "status": "complete",
            "solver_version": __version__,
            "joint": joint,
            "cycles": cycles,
            "periodic": "true" if periodic else "false",
            "wall_time_s": wall_time,
            "wall_time_last_invocation_s": invocation,
            "mesh_size": run.model.mesh_spec.element_size if run.model is not None else "none",
            "film_dofs": run.model.dofs if run.model is not None else 0,
            **(
                {"big_end_film_dofs": run.big_model.dofs}
                if getattr(run, "big_model", None) is not None
                else {}
            ),
            "rtol": case.solver.rtol,
            "atol": "1e-4 clearance on positions, x crank speed on velocities",
            "periodic_tolerance": case.solver.periodic_tolerance,
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "fields": ", ".join(p.name for p in fields),
            **{f"summary.{k}": v for k, v in summary_values.items()},
            **{f"summary.{k}": v for k, v in big_end.items() if math.isfinite(v)},
            **{f"summary.{k}": v for k, v in pin.items() if math.isfinite(v)},
            **{
                f"timing.{name}": np.array(
                    [cycle_timing.get(name, np.nan) for cycle_timing in run.timings], dtype=float
                )
                for name in TIMING
            },
            "timing.fields_io_s": run.fields_seconds,
            **{
                f"history.{name}": np.array(values, dtype=float) for name, values in run.cycle_history.items()
            },
            "history.description": "per computed cycle, the first cycle first: h_min_min, the cycle minimum "
            "of h_min [m]; friction_power_mean, the cycle mean of friction_power [W] (the periodic test's "
            "quantities, with big_end_h_min_min and pin_boss_h_min_min of the other lubricated joints); "
            "the change of each part of the state over the cycle, NaN where the state has no "
            "such part or the cycle was resumed: state_change_position [clearance] and "
            "state_change_velocity [clearance x crank speed] (the pin's eccentricity in the bushing and "
            "its rate), state_change_film_fraction (largest at a node), state_change_deformation "
            "[clearance, rms over the film's nodes] (the small end's film), state_change_temperature [K] "
            "(the heat balance's fixed point less the cycle's temperature), "
            "state_change_big_end_film_fraction and state_change_big_end_deformation (the big end's "
            "film alike); extrapolated_start: 1 if the cycle started from "
            "an extrapolated state (solver.study.periodic); film_alone_cycles: the film cycles the small "
            "end's film ran alone under the cycle's motion after it (solver.study.relaxation; 0: none)",
            "timing.description": "; ".join(f"{name}: {text}" for name, text in TIMING.items())
            + "; one value per computed cycle, the first cycle first",
            "Conventions": "CF-1.8 (partially)",
            "title": f"engine small-end tribo-dynamics: {case.name}",
        }
    )
    thermal = run.oil.thermal
    if thermal is not None:
        attrs["thermal.temperatures_C"] = np.array([b.temperature for b in thermal.history], dtype=float)
        attrs["thermal.closures"] = np.array([b.closure for b in thermal.history], dtype=float)
        attrs["thermal.description"] = (
            "film temperature and heat balance closure of every computed cycle, "
            "the first cycle first (solver.study.thermal)"
        )
    ds = build_dataset(case, cols, ideal, attrs=attrs, film=film)
    results = out_dir / "results.nc"
    if comm.rank == 0:
        io.write_netcdf(ds, results)
        plot_cycle(ds, out_dir, title=f"{case.name} ({joint})")
    comm.Barrier()
    return RunSummary(
        case=case.name,
        results=results,
        cycles=cycles,
        periodic=periodic,
        wall_time=wall_time,
        wall_time_last_invocation=invocation,
        **summary_values,
        **big_end,
        **pin,
        **{
            name: film[name]
            for name in (
                "film_temperature",
                "film_viscosity",
                "thermal_closure",
                "heat_generated",
                "heat_to_oil",
                "heat_carried",
            )
        },
    )


def pin_speed_mean(angle: np.ndarray, time: np.ndarray) -> float:
    """rad/s, the floating pin's mean angular speed over the cycle: its turn over the cycle's duration
    (NaN for a fixed pin)."""
    angle, time = np.asarray(angle, dtype=float), np.asarray(time, dtype=float)
    if len(angle) < 2 or not (math.isfinite(angle[0]) and math.isfinite(angle[-1])):
        return math.nan
    return float((angle[-1] - angle[0]) / (time[-1] - time[0]))


def nan_reduce(fn, values: np.ndarray) -> float:
    values = np.asarray(values, dtype=float)
    return float(fn(values)) if np.any(np.isfinite(values)) else math.nan


def is_complete(path: Path) -> bool:
    """True for a results file of a finished run: it opens with xarray and ``status == "complete"``."""
    path = Path(path)
    if not path.is_file():
        return False
    try:
        with xr.open_dataset(path) as ds:
            return ds.attrs.get("status") == "complete"
    except Exception:  # noqa: BLE001 - any unreadable file is an unfinished run
        return False


def results_owner(path: Path) -> tuple[str, str] | None:
    """(case name, joint) of a finished run's results file; None for no file or an unfinished run."""
    if not is_complete(path):
        return None
    try:
        with xr.open_dataset(path) as ds:
            return str(ds.attrs.get("name", "")), str(ds.attrs.get("joint", ""))
    except Exception:  # noqa: BLE001 - gone or unreadable since: nothing to protect
        return None


def plot_cycle(ds, out_dir: Path, title: str) -> list[Path]:
    """PNG plots: pin orbit, h_min and p_max, joint forces, friction power (over the crank angle); the
    crankpin's orbit in the big eye (``orbit_big_end.png``) when the big end is a clearance joint, the
    floating pin's orbit in the bosses (``orbit_pin_boss.png``)."""
    angle = ds.crank_angle.values
    c = float(ds.attrs["small_end.clearance_um"]) * 1e-6
    paths = []

    def save(fig, name):
        path = out_dir / name
        with io.atomic_path(path) as part:
            fig.savefig(part, dpi=110, format="png")
        paths.append(path)

    def mark_tdc(ax):
        for x in (0, 180, 360, 540, 720):
            ax.axvline(x, color="0.85", lw=0.8, zorder=0)
        ax.set_xlim(0, 720)
        ax.set_xticks(range(0, 721, 90))
        ax.set_xlabel("crank angle [deg] (360 = firing TDC)")

    # orbit
    fig, ax = io.subplots(figsize=(5.6, 5.2), constrained_layout=True)
    circle = np.linspace(0, 2 * np.pi, 361)
    ax.plot(np.cos(circle), np.sin(circle), color="k", lw=1, label="clearance circle")
    ex, ey = ds.ecc_x.values / c, ds.ecc_y.values / c
    if np.any(np.isfinite(ex)):
        points = ax.scatter(ex, ey, c=angle, cmap="twilight", s=6, vmin=0, vmax=720)
        fig.colorbar(points, ax=ax, label="crank angle [deg]")
        ax.plot(ex, ey, color="0.5", lw=0.5)
    ax.set_aspect("equal")
    ax.set_xlim(-1.1, 1.1)
    ax.set_ylim(-1.1, 1.1)
    ax.set_xlabel("e_x / c (along the rod, towards the small end)")
    ax.set_ylabel("e_y / c")
    ax.set_title(f"pin orbit in the bushing: {title}", fontsize=9)
    save(fig, "orbit.png")
    # the big end's orbit, when it is a clearance joint; the floating pin's in the bosses
    for joint, what, along, file in (
        (
            "big_end",
            "crankpin orbit in the big eye",
            "along the rod, towards the small end",
            "orbit_big_end.png",
        ),
        ("pin_boss", "pin orbit in the piston bosses", "along the cylinder axis", "orbit_pin_boss.png"),
    ):
        c_joint = float(ds.attrs.get(f"{joint}.clearance_um", math.nan)) * 1e-6
        bx, by = (
            ds[n].values / c_joint if n in ds else np.full(len(angle), np.nan)
            for n in (f"{joint}_ecc_x", f"{joint}_ecc_y")
        )
        if not np.any(np.isfinite(bx)):
            continue
        fig, ax = io.subplots(figsize=(5.6, 5.2), constrained_layout=True)
        ax.plot(np.cos(circle), np.sin(circle), color="k", lw=1, label="clearance circle")
        points = ax.scatter(bx, by, c=angle, cmap="twilight", s=6, vmin=0, vmax=720)
        fig.colorbar(points, ax=ax, label="crank angle [deg]")
        ax.plot(bx, by, color="0.5", lw=0.5)
        ax.set_aspect("equal")
        ax.set_xlim(-1.1, 1.1)
        ax.set_ylim(-1.1, 1.1)
        ax.set_xlabel(f"e_x / c ({along})")
        ax.set_ylabel("e_y / c")
        ax.set_title(f"{what}: {title}", fontsize=9)
        save(fig, file)
    # film thickness and pressure
    fig, (a1, a2) = io.subplots(2, 1, figsize=(8, 6), sharex=True, constrained_layout=True)
    a1.plot(angle, ds.h_min.values * 1e6, color="tab:blue")
    sigma = (
        math.hypot(float(ds.attrs["surface.sigma_pin_um"]), float(ds.attrs["surface.sigma_bushing_um"]))
        * 1e-6
    )
    if np.any(np.isfinite(ds.F_asperity.values)):
        a1.axhline(3 * sigma * 1e6, color="tab:red", ls=":", label="3 sigma (asperity contact below)")
        a1.legend(fontsize=8)
    a1.set_ylabel("h_min [um]")
    a1.set_title(f"minimum film thickness and peak pressure: {title}", fontsize=9)
    a2.plot(angle, ds.p_max.values / 1e6, color="tab:orange")
    a2.set_ylabel("p_max [MPa]")
    mark_tdc(a1)
    mark_tdc(a2)
    save(fig, "film.png")
    # forces
    fig, ax = io.subplots(figsize=(8, 4.2), constrained_layout=True)
    ideal = np.hypot(ds.ideal_pin_force_x.values, ds.ideal_pin_force_y.values)
    ax.plot(angle, ideal / 1e3, color="k", lw=1, ls="--", label="ideal joint |F_pin|")
    ax.plot(
        angle,
        np.hypot(ds.pin_force_x.values, ds.pin_force_y.values) / 1e3,
        color="0.4",
        lw=1,
        label="|F_pin|",
    )
    ax.plot(angle, ds.F_hydro.values / 1e3, color="tab:blue", label="film")
    ax.plot(angle, ds.F_asperity.values / 1e3, color="tab:red", label="asperity contact")
    ax.set_ylabel("force [kN]")
    ax.set_title(f"small-end forces: {title}", fontsize=9)
    ax.legend(fontsize=8)
    mark_tdc(ax)
    save(fig, "forces.png")
    # friction power
    fig, ax = io.subplots(figsize=(8, 4.2), constrained_layout=True)
    ax.plot(angle, ds.friction_power.values, color="tab:green", label="friction power")
    ax.plot(angle, ds.squeeze_power.values, color="tab:purple", lw=0.8, label="squeeze power")
    ax.set_ylabel("power [W]")
    ax.set_title(f"small-end friction power: {title}", fontsize=9)
    ax.legend(fontsize=8)
    mark_tdc(ax)
    save(fig, "friction_power.png")
    return paths
