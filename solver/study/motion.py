"""The film under a prescribed motion: a motion file read and checked, and the film driven through it.

A motion is the journal's eccentricity in the bushing frame over time (journal centre minus bushing
centre, the bushing's axes; solver.film.types.Kinematics), its rate (d/dt of those components, given or
differentiated to second order) and the journal's and the bushing's speeds. ``read_motion`` reads it
from a CSV file with a header (``COLUMNS``) and refuses a bad file with one line naming the column and
the row. ``drive`` solves the film (solver.film.model.Film, as built by solver.film.factory.make_film:
the engine's film) at every row and commits the film's history there, as the engine commits an
accepted step (solver.study.cycles): the film fraction of the mass-conserving film and the elastic
bushing's deformation go on from row to row with their BDF2 rates (solver.film.history). A row whose
solve fails is reached through smaller steps (the motion interpolated by cubic Hermite between the
rows), each committed in turn.

Start (``START``): "full", the film full (film fraction 1) one row interval before the first row, the
bushing deformed as in the steady film at the first row; "steady", the steady (quasi-static) film at
the first row, the start of an engine run. A film without history (rigid, Reynolds) has no start.

Numpy here; the film is passed in (the command builds it).
"""

from __future__ import annotations

import csv
import dataclasses
import logging
import math
import time
from pathlib import Path

import numpy as np

from solver import film_rules
from solver.errors import FilmNotConverged, InputError

log = logging.getLogger(__name__)

#: column -> (required, unit, meaning)
COLUMNS = {
    "time_s": (True, "s", "time, strictly increasing"),
    "ecc_x_m": (True, "m", "eccentricity x (journal centre - bushing centre, bushing frame)"),
    "ecc_y_m": (True, "m", "eccentricity y (bushing frame)"),
    "ecc_rate_x_m_s": (False, "m/s", "d ecc_x / dt (else differentiated, second order)"),
    "ecc_rate_y_m_s": (False, "m/s", "d ecc_y / dt (with ecc_rate_x_m_s)"),
    "journal_speed_rpm": (False, "rpm", "journal speed (else --speed)"),
    "bushing_speed_rpm": (False, "rpm", "bushing speed (else --bushing-speed, default 0)"),
}
START = ("full", "steady")
RPM = 2 * math.pi / 60
#: a row that fails is reached through at most 2^MAX_HALVINGS internal steps
MAX_HALVINGS = 6


@dataclasses.dataclass(frozen=True)
class Motion:
    """A prescribed motion (SI): per row the time, the eccentricity and its rate (bushing frame) and the
    journal's and bushing's angular speeds."""

    time: np.ndarray  # s, (n,)
    ecc: np.ndarray  # m, (n, 2)
    ecc_rate: np.ndarray  # m/s, (n, 2)
    omega_journal: np.ndarray  # rad/s, (n,)
    omega_bushing: np.ndarray  # rad/s, (n,)
    rates_given: bool = True

    def __len__(self) -> int:
        return len(self.time)

    def kinematics(self, i: int):
        """The Kinematics of row ``i``."""
        from solver.film.types import Kinematics

        return Kinematics(
            tuple(map(float, self.ecc[i])),
            tuple(map(float, self.ecc_rate[i])),
            float(self.omega_journal[i]),
            float(self.omega_bushing[i]),
        )

    def between(self, i: int, s: float):
        """The Kinematics at the fraction ``s`` in [0, 1] of the interval from row i - 1 to row i: cubic
        Hermite through the positions and rates of both rows (rate its derivative), speeds linear."""
        from solver.film.types import Kinematics

        h = self.time[i] - self.time[i - 1]
        e0, e1, r0, r1 = self.ecc[i - 1], self.ecc[i], self.ecc_rate[i - 1] * h, self.ecc_rate[i] * h
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        ecc = h00 * e0 + h10 * r0 + h01 * e1 + h11 * r1
        rate = (d00 * e0 + d10 * r0 + d01 * e1 + d11 * r1) / h
        omega_j = (1 - s) * self.omega_journal[i - 1] + s * self.omega_journal[i]
        omega_b = (1 - s) * self.omega_bushing[i - 1] + s * self.omega_bushing[i]
        return Kinematics(tuple(map(float, ecc)), tuple(map(float, rate)), float(omega_j), float(omega_b))


def _bad(path: Path, text: str) -> InputError:
    return InputError(f"--motion {path}: {text}")


def read_motion(path: Path, speed_rpm: float = 0.0, bushing_speed_rpm: float = 0.0) -> Motion:
    """The Motion of a CSV file (module docstring); InputError naming the column and the row (the
    file's line number) for a bad file."""
    path = Path(path)
    allowed = ", ".join(COLUMNS)
    try:
        with path.open(newline="") as stream:
            lines = [row for row in csv.reader(stream) if row and not row[0].lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as err:
        raise _bad(path, f"cannot be read ({err.__class__.__name__}) (allowed: a CSV file)") from None
    if not lines:
        raise _bad(path, f"empty (allowed: a header with {allowed}, then rows)")
    header = [name.strip() for name in lines[0]]
    for name in header:
        if name not in COLUMNS:
            raise _bad(path, f"unknown column {name!r} (allowed: {allowed})")
    if len(set(header)) != len(header):
        raise _bad(path, "a column named twice (allowed: each column once)")
    missing = [name for name, (required, _, _) in COLUMNS.items() if required and name not in header]
    if missing:
        raise _bad(path, f"missing column {', '.join(missing)} (allowed: {allowed}; the first three needed)")
    if ("ecc_rate_x_m_s" in header) != ("ecc_rate_y_m_s" in header):
        raise _bad(path, "ecc_rate_x_m_s and ecc_rate_y_m_s go together (allowed: both or neither)")
    values = np.empty((len(lines) - 1, len(header)))
    for k, row in enumerate(lines[1:]):
        line = k + 2  # the header is line 1 (comment lines aside)
        if len(row) != len(header):
            raise _bad(path, f"row {line} has {len(row)} values (allowed: {len(header)}, one per column)")
        for j, text in enumerate(row):
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise _bad(
                    path, f"row {line}, column {header[j]} = {text.strip()!r} (allowed: a finite number)"
                )
            values[k, j] = value
    rates_given = "ecc_rate_x_m_s" in header
    minimum = 2 if rates_given else 3
    if len(values) < minimum:
        raise _bad(
            path,
            f"{len(values)} row(s) (allowed: at least {minimum}"
            + ("" if rates_given else ", to differentiate the eccentricity to second order")
            + ")",
        )
    column = {name: values[:, j] for j, name in enumerate(header)}
    t = column["time_s"]
    steps = np.diff(t)
    if not np.all(steps > 0):
        k = int(np.argmin(steps > 0)) + 1
        raise _bad(
            path, f"row {k + 2}, column time_s = {t[k]:g} after {t[k - 1]:g} (allowed: strictly increasing)"
        )
    ecc = np.column_stack([column["ecc_x_m"], column["ecc_y_m"]])
    if rates_given:
        rate = np.column_stack([column["ecc_rate_x_m_s"], column["ecc_rate_y_m_s"]])
    else:  # second order inside and at both ends (non-uniform rows too)
        rate = np.gradient(ecc, t, axis=0, edge_order=2)
    journal = column.get("journal_speed_rpm", np.full(len(t), speed_rpm))
    bushing = column.get("bushing_speed_rpm", np.full(len(t), bushing_speed_rpm))
    return Motion(t.copy(), ecc, rate, journal * RPM, bushing * RPM, rates_given)


def check_reach(motion: Motion, clearance: float, limit: float, path: Path | str = "") -> None:
    """Every row's |e| / c below ``limit`` (the film's max_eccentricity_ratio), else one line naming the
    first row beyond it."""
    eps = np.hypot(motion.ecc[:, 0], motion.ecc[:, 1]) / clearance
    beyond = np.flatnonzero(~(eps < limit))
    if beyond.size:
        k = int(beyond[0])
        raise _bad(
            Path(path),
            f"row {k + 2}, columns ecc_x_m, ecc_y_m: |e| / c = {eps[k]:.6g} (allowed: [0, {limit:g}) for "
            "this film)",
        )


def reference_speed(motion: Motion, clearance: float) -> float:
    """The film scaling's reference angular speed [rad/s], by the bearing command's rule
    (solver.film_rules.reference_speed) over the rows' largest speeds; 1 if nothing moves."""
    speed = film_rules.reference_speed(
        float(np.max(np.abs(motion.omega_journal + motion.omega_bushing))),
        float(np.max(np.abs(motion.omega_journal - motion.omega_bushing))),
        float(np.max(np.hypot(motion.ecc_rate[:, 0], motion.ecc_rate[:, 1]))) / clearance,
    )
    return speed if speed > 0 else 1.0


#: the film's outputs per row: name -> (units, long_name, FilmResult -> value)
OUTPUTS = {
    "force_x_N": (
        "N",
        "force on the journal, x (film + asperity contact, bushing frame)",
        lambda r: r.force[0],
    ),
    "force_y_N": (
        "N",
        "force on the journal, y (film + asperity contact, bushing frame)",
        lambda r: r.force[1],
    ),
    "p_max_Pa": ("Pa", "peak film pressure (gauge)", lambda r: r.p_max),
    "h_min_m": ("m", "minimum film thickness", lambda r: r.h_min),
    "friction_torque_Nm": (
        "N m",
        "friction torque on the journal (counter-clockwise +)",
        lambda r: r.torque_journal,
    ),
    "friction_torque_bushing_Nm": (
        "N m",
        "friction torque on the bushing (counter-clockwise +)",
        lambda r: r.torque_bushing,
    ),
    "cavitated_area_ratio": ("1", "ruptured film area / bearing area", lambda r: r.cavitated_area_ratio),
    "oil_volume_m3": (
        "m3",
        "oil held in the film (NaN: the Reynolds cavitation law does not conserve mass; --cavitation jfo)",
        lambda r: r.oil_volume,
    ),
    "side_flow_m3_per_s": ("m3 s-1", "oil flow out of both edges", lambda r: r.side_flow),
    "supply_flow_m3_per_s": ("m3 s-1", "oil flow from the supply into the film", lambda r: r.supply_flow),
    "max_deformation_m": (
        "m",
        "largest radial deformation of the bushing (0: rigid bushing)",
        lambda r: r.max_deformation,
    ),
}


#: the oil's volumes since the first row, beside OUTPUTS: name -> (units, long_name)
VOLUMES = {
    "supply_volume_m3": (
        "m3",
        "oil supplied since the first row (the supply flow of every internal step, trapezoids)",
    ),
    "side_volume_m3": (
        "m3",
        "oil lost through both edges since the first row (the side flow of every internal step, trapezoids)",
    ),
}


#: the motion as used, beside OUTPUTS in bearing_motion.nc: name -> (units, long_name, Motion -> values)
MOTION_VARIABLES = {
    "ecc_x_m": ("m", "eccentricity x (journal centre - bushing centre, bushing axes)", lambda m: m.ecc[:, 0]),
    "ecc_y_m": ("m", "eccentricity y (bushing frame)", lambda m: m.ecc[:, 1]),
    "ecc_rate_x_m_s": (
        "m s-1",
        "d ecc_x / dt (bushing-frame components; the file's, or its second-order differences)",
        lambda m: m.ecc_rate[:, 0],
    ),
    "ecc_rate_y_m_s": ("m s-1", "d ecc_y / dt (as ecc_rate_x_m_s)", lambda m: m.ecc_rate[:, 1]),
    "journal_speed_rpm": ("rpm", "journal speed", lambda m: m.omega_journal / RPM),
    "bushing_speed_rpm": ("rpm", "bushing speed", lambda m: m.omega_bushing / RPM),
}


@dataclasses.dataclass
class MotionRun:
    """The film's outputs at the rows (``values``: name of OUTPUTS -> array), the solver's effort."""

    values: dict[str, np.ndarray]
    iterations: np.ndarray
    substeps: int = 0  # internal steps added where a row's solve failed
    solve_time_s: float = 0.0
    #: the oil supplied and lost through the edges since the first row [m^3]: the flows of every
    #: internal step integrated by trapezoids (VOLUMES)
    volumes: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    _last_flow: tuple | None = None  # (time, supply flow, side flow, both volumes) at the last commit

    def accumulate(self, time_s: float, result) -> tuple[float, float]:
        """The supplied and side volumes up to ``time_s`` with ``result``'s flows (trapezoids from the
        last committed solve; 0 at the first)."""
        supply, side = float(result.supply_flow), float(result.side_flow)
        if self._last_flow is None:
            volumes = (0.0, 0.0)
        else:
            t0, supply0, side0, v_supply, v_side = self._last_flow
            dt = time_s - t0
            volumes = (v_supply + dt * (supply + supply0) / 2, v_side + dt * (side + side0) / 2)
        self._last_flow = (time_s, supply, side, *volumes)
        return volumes


def _full(model, state: np.ndarray) -> np.ndarray:
    """The history state with the film fraction 1 everywhere (the mass-conserving film's u >= 0:
    solver.film.jfo), the rest (an elastic bushing's deformation) as it is."""
    if model.spec.cavitation != "jfo":
        return state
    full = state.copy()
    n = model.space.n
    full[:n] = np.maximum(full[:n], 0.0)
    return full


def drive(
    model,
    motion: Motion,
    start: str = "full",
    progress_every: int = 0,
    after_row=None,
    substeps: int = 1,
) -> MotionRun:
    """Solve ``model`` (solver.film.model.Film) at every row of ``motion``, committing its history at
    each row and at ``substeps - 1`` equal internal steps between rows (the motion interpolated by
    cubic Hermite: ``Motion.between``); ``after_row(i)``, if given, is called after row i's solve (the
    film then holds its solution: e.g. to write its fields). The supplied and side volumes integrate the
    flows of every committed solve (``MotionRun.volumes``). A row that fails after MAX_HALVINGS halvings
    of its internal step raises FilmNotConverged naming its time."""
    if start not in START:
        raise InputError(f"--start {start} is out of range (allowed: {', '.join(START)})")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise InputError(f"--substeps {substeps} is out of range (allowed: an integer >= 1)")
    n = len(motion)
    values = {name: np.full(n, np.nan) for name in OUTPUTS}
    iterations = np.zeros(n, dtype=int)
    history = model.has_history
    clock = time.perf_counter()
    run = MotionRun(values, iterations, volumes={name: np.full(n, np.nan) for name in VOLUMES})
    t = motion.time
    if history:
        first = model.solve(motion.kinematics(0))  # quasi-static: the steady film at the first row
        if start == "full":
            model.commit_history(_full(model, model.history_state()), float(t[0] - (t[1] - t[0])))
    for i in range(n):
        if i == 0 and history and start == "steady":
            result = first
            model.commit_history(model.history_state(), float(t[0]))
            run.accumulate(float(t[0]), result)
        elif history:
            result = solve_row(model, motion, i, run, substeps)
        else:  # no history: the internal steps only integrate the flows between the rows
            for k in range(1, substeps if i > 0 else 1):
                s = k / substeps
                run.accumulate(float(t[i - 1] + s * (t[i] - t[i - 1])), model.solve(motion.between(i, s)))
            result = model.solve(motion.kinematics(i))
            run.accumulate(float(t[i]), result)
        for name, (_, _, get) in OUTPUTS.items():
            values[name][i] = get(result)
        for name, volume in zip(VOLUMES, run._last_flow[3:]):
            run.volumes[name][i] = volume
        iterations[i] = result.iterations
        if after_row is not None:
            after_row(i)
        if progress_every and (i + 1) % progress_every == 0 and i + 1 < n:
            log.info(
                "motion: row %d of %d (t = %.6g s), %.1f s so far",
                i + 1,
                n,
                t[i],
                time.perf_counter() - clock,
            )
    run.solve_time_s = time.perf_counter() - clock
    return run


def solve_row(model, motion: Motion, i: int, run: MotionRun, substeps: int = 1):
    """Row ``i`` reached in ``substeps`` equal internal steps from the last commit (row 0: one step at
    its time), each solved with the history's rate and committed; where a solve fails, the step is
    halved (intermediate states committed) until it succeeds."""
    t = motion.time
    regular = 1.0 / substeps
    done = 0.0  # the fraction of the interval to row i already committed
    step = regular
    while True:
        target = done + step
        if target > 1.0 - 1e-9 * step:  # (the last internal step ends on the row exactly)
            target = 1.0
        kin = motion.kinematics(i) if target == 1.0 or i == 0 else motion.between(i, target)
        time_s = float(t[i]) if target == 1.0 or i == 0 else float(t[i - 1] + target * (t[i] - t[i - 1]))
        try:
            result = model.solve(kin, time_s)
        except FilmNotConverged:
            if i == 0 or step <= regular * 0.5**MAX_HALVINGS:
                raise FilmNotConverged(
                    f"the film at row time_s = {t[i]:g} s did not converge, also in "
                    f"{substeps * 2**MAX_HALVINGS} internal steps",
                    0,
                    0,
                ) from None
            step /= 2
            continue
        model.commit_history(model.history_state(), time_s)
        run.accumulate(time_s, result)
        if target == 1.0:
            return result
        if step < regular:
            run.substeps += 1
        done = target
