"""One engine operating point with the lubricated small end: cycles until periodic, then results.

The case's engine (solver.dynamics.engine) is built with the small end as a clearance joint whose law is one
of solver.joint (``mixed-fem``: the finite-element mixed-lubrication film; ``short-bearing``; ``dry``) or as
an ideal revolute (``ideal``), the big end as an ideal revolute or a clearance joint (``big_end.joint``:
short bearing, the finite-element film of the crankpin in the rod's big eye, or dry contact), and the
piston pin fixed in the piston or floating (``small_end.pin``: a body of its own, turning in the small
end's film and in the bosses' film, ``[pin_boss]``: short bearing or finite-element film); all the
clearance joints' forces (each finite-element film solved) enter every stage of one integration. The
equations of motion are integrated with the L-stable ESDIRK32 method (solver.dynamics.integrate), whose
Newton iterations use the joint's exact Jacobian, so that the step is set by accuracy and not by the
film's stiffness (DESIGN 3.8).

The run starts from the ideal-joint configuration at 0 deg with the pin centred in its bushing and
integrates whole 720 deg cycles until periodic; the last cycle is reported. The study by concern:

- solver.study.cycles: the cycle loop (time loop, periodicity, checkpoints, progress);
- solver.study.outputs: the variables at each output state (each joint reports its own);
- solver.study.energy: the energy audit;
- solver.study.film_temperature: the film's oil temperature iterated with the cycles
  (``oil.thermal = "effective"``, solver.study.thermal);
- solver.study.fields: the ParaView fields of the last cycle;
- solver.study.results: the results' table (VARIABLES), results.nc and plots.

A failed film solve returns NaN forces and the integrator retries with a shorter step; when the step
size collapses the run stops with a ``SimulationError`` naming the crank angle. Everything runs on the
given communicator: the film mesh is distributed over it and every rank integrates the (small)
multibody system with the same, reduced film forces.
"""

from __future__ import annotations

import hashlib
import logging
import math
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from solver import __version__
from solver.case import Case, case_attributes, defaults_note, load_case
from solver.dynamics.engine import FloatingPin, build_mechanism, engine_from_case, simulate_ideal
from solver.dynamics.joint import (
    JOINTS,
    big_end_joint_from_case,
    joint_from_case,
    pin_boss_joint_from_case,
)
from solver.errors import InputError
from solver.study import cycles, fields
from solver.study import results as results_io
from solver.study.cycles import CycleOutput, SimulationError, describe_timing
from solver.study.film_temperature import FilmOil
from solver.study.outputs import ideal_cycle_columns
from solver.study.results import RunSummary

log = logging.getLogger(__name__)

__all__ = ["CycleOutput", "Run", "SimulationError", "describe_timing", "run_case"]


def case_fingerprint(case: Case, joint: str) -> str:
    """The case settings, joint and solver version a checkpoint belongs to."""
    text = repr(sorted((k, str(v)) for k, v in case_attributes(case).items())) + joint + __version__
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class Run:
    """The state of one coupled run: the engine, its small-end joint (and film model) and mechanism,
    the film's oil, and what the cycles leave for the results (the heavy objects are the mechanism and
    the film; the concerns are the modules of solver.study named in this module's docstring)."""

    def __init__(self, case: Case, comm: MPI.Comm, joint_name: str):
        self.case, self.comm, self.joint_name = case, comm, joint_name
        self.engine = engine_from_case(case)
        self.omega = self.engine.crank_motion.speed
        self.joint, self.model = joint_from_case(case, self.engine, comm, joint_name)
        # None: an ideal big end; a FilmJoint (big_end.joint = "mixed-fem") has its film as ``model``
        self.big_joint = big_end_joint_from_case(case, self.engine, comm)
        self.big_model = getattr(self.big_joint, "model", None)
        # the big end's film carries a history (JFO film fraction, Winkler shell): committed as the small
        # end's (solver.study.cycles), kept in the checkpoint, a part of the cycle map's state
        self.big_has_history = self.big_model is not None and self.big_model.has_history
        # None: the pin fixed in the piston; a finite-element boss film (pin_boss.joint = "mixed-fem") has its
        # film as ``model`` (rigid, Reynolds cavitation: no history to commit)
        self.boss_joint = pin_boss_joint_from_case(case, self.engine, comm)
        self.boss_model = getattr(self.boss_joint, "model", None)
        pin = None
        if self.boss_joint is not None:
            pin = FloatingPin(case.small_end.pin_mass, case.small_end.pin_inertia, self.boss_joint)
        self.em = build_mechanism(self.engine, self.joint, self.big_joint, pin)
        # the lubricated joints' radial clearances [m], by name (solver.dynamics.engine.clearance_joints)
        clearance = {
            "small_end": case.small_end.clearance,
            "big_end": case.big_end.clearance,
            "pin_boss": case.pin_boss.clearance,
        }
        self.clearances = {name: clearance[name] for name in self.em.clearance_joints}
        # the joint the periodic test and the progress bar follow: the small end when it is lubricated
        self.lead = "small_end" if self.joint is not None or self.big_joint is None else "big_end"
        c = min(self.clearances.values(), default=case.small_end.clearance)
        n = self.em.mechanism.n_coordinates
        position = np.tile([1e-4 * c, 1e-4 * c, 1e-6], n // 3)
        self.atol = np.concatenate([position, position * self.omega])
        self.step_deg = math.degrees(case.solver.step)
        self.steps = 0  # accepted integrator steps so far
        self.timings: list[dict[str, float]] = []  # TIMING of each computed cycle (resumed ones included)
        self.cycle_history: dict[str, list[float]] = {}  # per cycle (resumed ones too): min h_min, friction
        self.fields_seconds = 0.0  # writing the ParaView fields after the cycles
        # per output state of the last integrated cycle, the committed states (time, history state) its
        # film history's rate was taken from (None: no history, or quasi-static), for the fields
        self.committed: list[list[tuple[float, np.ndarray]] | None] = []
        self.oil = FilmOil(case.oil)  # the film's oil in the cycles run now
        self.started = time.perf_counter()  # this invocation's start (run_case sets its own)
        self.earlier_wall_time = 0.0  # s, of the earlier invocations a resumed run goes on from
        self.position = (0, 0.0)  # (cycle index, crank angle) the cycles reached (solver.study.cycles)
        # the film's committed history at the last cycle's start (after its first output), the start
        # state's film part for the cycle map (solver.study.periodic)
        self.start_film: list[tuple[float, np.ndarray]] = []
        self.start_big_end_film: list[tuple[float, np.ndarray]] = []  # the big end's alike

    @property
    def film_models(self) -> list:
        """The finite-element films of the run (the small end's, the big end's, then the bosses'), for their
        counters."""
        return [model for model in (self.model, self.big_model, self.boss_model) if model is not None]

    def integrate_cycle(self, cycle: int, t0: float, q0, qd0, progress=None):
        """One 720 deg cycle from (t0, q0, qd0): (CycleOutput, end state); solver.study.cycles."""
        return cycles.integrate_cycle(self, cycle, t0, q0, qd0, progress)

    def write_fields(self, directory: Path, cycle: CycleOutput) -> list[Path]:
        """ParaView fields of the last cycle (finite-element film only; solver.study.fields); the
        seconds it took go to ``fields_seconds``."""
        if self.model is None:
            return []
        begin = time.perf_counter()
        solver = self.case.solver
        paths = fields.write_fields(
            directory,
            self.model,
            cycle.columns,
            self.committed,
            step_deg=self.step_deg,
            field_step=solver.field_step,
            field_angles=solver.field_angles,
        )
        self.fields_seconds = time.perf_counter() - begin
        return paths


def run_case(
    case_path: str | Path,
    comm: MPI.Comm,
    *,
    joint: str | None = None,
    progress: bool = False,
    resume: bool = True,
    output: str | Path | None = None,
) -> RunSummary:
    """Run one case directory; write ``results/`` beside its case.toml (or ``output``); return the summary.

    Args:
        case_path: the case directory (or its TOML file).
        comm: the communicator of this case (the film mesh is distributed over it).
        joint: override ``solver.joint`` of the case.
        progress: show a progress bar on rank 0 (cycle, crank angle, h_min).
        resume: continue from ``results/checkpoint.npz`` if it belongs to the same case.
        output: the results directory instead of ``results/`` beside the case file.

    Raises:
        InputError: a bad case (on every rank of comm).
        SimulationError: the run failed.
    """
    start = time.perf_counter()
    case = load_case(case_path)
    joint = joint or case.solver.joint
    if joint not in JOINTS:
        raise InputError(f"joint = {joint!r} is out of range (allowed: {', '.join(map(repr, JOINTS))})")
    if case.oil.thermal == "effective" and case.big_end.lubricated:
        raise InputError(
            'oil.thermal = "effective" is for the small end\'s film alone (allowed: big_end.joint = "ideal"; '
            f"got {case.big_end.joint!r})"
        )
    if case.solver.periodic_acceleration == "film" and not (
        joint == "mixed-fem" and case.small_end.pin == "fixed" and case.oil.cavitation == "jfo"
    ):
        raise InputError(
            'solver.periodic_acceleration = "film" runs the small end\'s mass-conserving film alone '
            '(allowed: joint "mixed-fem", small_end.pin = "fixed" and oil.cavitation = "jfo"; else "none" or '
            '"mpe")'
        )
    if case.small_end.pin == "floating" and joint == "ideal":
        raise InputError(
            'small_end.pin = "floating" turns in the small end\'s film (allowed: joint "mixed-fem", '
            f'"short-bearing" or "dry"; got {joint!r})'
        )
    if case.oil.thermal == "effective" and case.small_end.pin == "floating":
        raise InputError(
            'oil.thermal = "effective" is for the small end\'s film alone (allowed: small_end.pin = "fixed"; '
            'got "floating")'
        )
    if case.oil.thermal == "effective" and joint not in ("mixed-fem", "short-bearing"):
        raise InputError(
            f'oil.thermal = "effective" needs a film with a side flow (allowed: joint '
            f'"mixed-fem" or "short-bearing"; got {joint!r})'
        )
    out_dir = Path(output) if output is not None else case.directory / "results"
    if comm.rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    handler = results_io.attach_log(out_dir / "run.log", comm)
    run = None
    try:
        log.info("case %s: joint %s, solver %s", case.name, joint, __version__)
        if case.big_end.lubricated:
            log.info("big end: joint %s", case.big_end.joint)
        if case.small_end.pin == "floating":
            log.info("floating pin: the bosses' joint %s", case.pin_boss.joint)
        if defaults_note(case):
            log.info(defaults_note(case))
        ideal = simulate_ideal(engine_from_case(case), step_deg=math.degrees(case.solver.step))
        run = Run(case, comm, joint)
        run.started = start
        if joint == "ideal" and not case.big_end.lubricated:  # kinematically determined: the ideal cycle
            cycles_done, periodic = 1, True
            cycle = CycleOutput(ideal_cycle_columns(ideal), math.nan)
        else:
            fingerprint = case_fingerprint(case, joint)
            cycle, cycles_done, periodic = cycles.run_cycles(run, out_dir, fingerprint, progress, resume)
        field_paths = run.write_fields(out_dir, cycle)
        wall = time.perf_counter() - start
        summary = results_io.write_results(
            out_dir,
            case,
            run,
            cycle,
            ideal,
            joint=joint,
            cycles=cycles_done,
            periodic=periodic,
            wall_time=wall,
            fields=field_paths,
            comm=comm,
        )
        if comm.rank == 0:
            checkpoint = out_dir / "checkpoint.npz"
            if checkpoint.exists():
                checkpoint.unlink()
        log.info(
            "finished in %.1f s: h_min min %.3g um, p_max max %.3g MPa, %d cycles, periodic %s",
            wall,
            summary.h_min_min * 1e6,
            summary.p_max_max / 1e6,
            cycles_done,
            periodic,
        )
        if run.oil.thermal is not None:
            log.info(
                "film temperature %.6g C, viscosity %.6g Pa s, heat balance closure %.2g",
                summary.film_temperature,
                summary.film_viscosity,
                summary.thermal_closure,
            )
        return summary
    finally:
        results_io.detach_log(handler)
        if run is not None:
            for model in run.film_models:
                model.close()
