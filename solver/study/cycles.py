"""The cycle loop of a coupled run: whole 720 deg cycles until periodic, checkpointed at every cycle end.

A cycle is integrated by one :class:`solver.dynamics.integrate.Stepper` (ESDIRK32 with a kept Jacobian,
Baumgarte's gains at the crank speed) from output angle to output angle: every output angle is a step
end (the cubic dense output is fine for positions but not for the relative velocity of a stiff joint,
and the film force depends on that velocity). At each output the state's variables are evaluated at
consistent velocities (solver.study.outputs), which the next interval starts from; the energy audit's
stage integrals accumulate (solver.study.energy); a film with history (the small end's, the big end's)
commits its state.

The run stops when the cycle minimum of the film thickness (of the small end when it is lubricated, else of
the big end) changes by less than ``solver.periodic_tolerance`` x clearance from one cycle to the next, and
so does each other lubricated joint's (the big end, a floating pin's bosses: each by its own clearance), at
least two cycles and at most ``solver.max_cycles``; and, when ``solver.periodic_friction_tolerance`` is set,
the cycle-mean friction power by less than that fraction of itself; with oil.thermal = "effective" also when
the cycle's heat balance closes (solver.study.film_temperature). The checkpoint (``results/checkpoint.npz``,
solver.study.io.Checkpoint) holds the state, the per-cycle histories, the thermal iteration and the films'
committed histories (the small end's and the big end's), so an interrupted run resumes from the last
finished cycle.
An interruption (KeyboardInterrupt: Ctrl-C, or SIGTERM where the command line turns it into one)
inside the cycles leaves as :class:`RunInterrupted`, which says where the run stopped and which checkpoint
is kept.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import sys
import time
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np
from tqdm import tqdm

from solver.dynamics.integrate import IntegrationError, Stepper
from solver.study import io
from solver.study.energy import STAGE_COLUMNS, EnergyAudit, input_work
from solver.study.film_temperature import set_film_temperature
from solver.study.outputs import StateOutputs
from solver.study.periodic import STATE_PARTS, CycleMap, EndState
from solver.study.relaxation import relax
from solver.study.results import TIMING, nan_reduce
from solver.study.thermal import ThermalError, cycle_mean

log = logging.getLogger(__name__)

#: the prefix of each clearance joint's columns (solver.study.outputs)
PREFIX = {"small_end": "", "big_end": "big_end_", "pin_boss": "pin_boss_"}

CHUNK_DEG = 10.0  # crank angle between progress updates
#: periodic_acceleration = "film": the film alone runs film cycles under the last cycle's motion until its
#: film fraction changes by less than this at every node over one, at most ALONE_CYCLES. The elastic JFO
#: case: periodic after 6 coupled cycles with 1e-3 and with 1e-4, the film alone 584 s against 975 s (the
#: next coupled cycle moves the film by more than that: 0.001-0.02 at a node in cycles 3-5)
ALONE_TOLERANCE = 1e-3
ALONE_CYCLES = 15


class SimulationError(RuntimeError):
    """The coupled run failed (the message names the crank angle and cycle)."""


class RunInterrupted(KeyboardInterrupt):
    """The cycles were interrupted (a KeyboardInterrupt: the batch layer lets it through like one).

    Attributes:
        case: the case name.
        cycle: the cycle it was in (1-based).
        angle: deg, the last crank angle it reached in that cycle.
        checkpoint: the checkpoint file, or None when no cycle was finished (nothing to resume).
        checkpoint_cycles: the cycles the checkpoint holds (where a rerun resumes).
    """

    def __init__(self, case: str, cycle: int, angle: float, checkpoint: Path | None, checkpoint_cycles: int):
        super().__init__(case, cycle, angle)
        self.case, self.cycle, self.angle = case, cycle, angle
        self.checkpoint, self.checkpoint_cycles = checkpoint, checkpoint_cycles

    def __str__(self) -> str:
        where = f"case {self.case} at cycle {self.cycle}, crank angle {self.angle:.0f} deg"
        if self.checkpoint is None:
            return f"{where} (no cycle finished: no checkpoint)"
        return f"{where} (checkpoint after cycle {self.checkpoint_cycles} kept: {self.checkpoint})"


@dataclasses.dataclass
class CycleOutput:
    """Arrays over the output crank angles of one cycle (SI)."""

    columns: dict[str, np.ndarray]
    h_min_min: float  # m, of the joint the periodic test follows (``prefix``)
    timing: dict[str, float] = dataclasses.field(default_factory=dict)  # see TIMING
    prefix: str = ""  # of that joint's columns: "" the small end, "big_end_" the big end

    @property
    def friction_power_mean(self) -> float:
        """W, the cycle mean of the friction power over the crank angle (as results.nc's summary) of the
        joint the periodic test follows."""
        return cycle_mean(self.columns[self.prefix + "friction_power"], self.columns["crank_angle"])


def integrate_cycle(run, cycle: int, t0: float, q0, qd0, progress=None):
    """One 720 deg cycle of ``run`` (solver.study.simulation.Run) from (t0, q0, qd0); returns
    (CycleOutput, end state (t, q, qd)). The outputs carry the cycle's ``timing`` (TIMING, without the
    checkpoint's I/O); ``run.steps`` counts the accepted steps and ``run.committed`` holds, per output
    state, the committed history states its film's rate was taken from (solver.study.fields)."""
    start = time.perf_counter()
    model, engine = run.model, run.engine
    models = run.film_models  # the small end's film and the big end's (each counts its own work)
    film_before = [m.stats.copy() for m in models]
    n_out = int(round(720.0 / run.step_deg))
    angles = np.linspace(0.0, 720.0, n_out + 1)
    # the integrator's interval ends: each output interval in equal parts (solver.max_step_deg), every
    # parts-th one an output; the steps end there as at the outputs (without an output's projection)
    parts = run.case.solver.steps_per_output
    fine = np.radians(np.linspace(0.0, 720.0, n_out * parts + 1)) + 4 * math.pi * cycle
    ends = np.asarray(engine.crank_motion.time(fine), dtype=float)
    ends[0] = t0
    times = ends[::parts]
    audit = EnergyAudit(run.em, engine.gravity)
    outputs = StateOutputs(
        run.em,
        engine,
        run.case.small_end.clearance,
        run.omega,
        audit,
        run.case.big_end.clearance,
        run.case.pin_boss.clearance,
    )
    prefix = PREFIX[run.lead]
    history = model is not None and hasattr(run.joint, "commit")  # a film with history commits its states
    # the big end's film with history (JFO film fraction, Winkler shell) commits alike (in the crankpin's
    # frame with a hole: JournalFrameFilmJoint.commit)
    big_history = run.big_has_history

    def step_accepted(t: float) -> None:
        """An accepted integrator step: a film history's state at its end starts the rate of the next
        step (implicit Euler over the step, not over the output interval)."""
        if history:
            run.joint.commit(t)
        if big_history:
            run.big_joint.commit(t)

    def output_accepted(t: float) -> None:
        """An accepted output state: a film history's state there starts the next rate (it replaces the
        commit of the step that ended there: the output's velocities are the consistent ones)."""
        if history:
            run.committed.append(model.rate_history(t) or None)
            run.joint.commit(t)
        if big_history:
            run.big_joint.commit(t)

    run.committed = []
    row, qd = outputs.at(t0, q0, qd0)
    output_accepted(t0)
    run.start_film = model.committed_history() if history else []  # the film's state the cycle starts from
    run.start_big_end_film = run.big_model.committed_history() if big_history else []  # the big end's alike
    rows = [row]
    work = np.zeros(len(STAGE_COLUMNS))  # STAGE_COLUMNS since the cycle's start
    energies = [work.copy()]
    stepper = Stepper(
        run.em.mechanism,
        t0,
        q0,
        qd,
        method="ESDIRK32",
        rtol=run.case.solver.rtol,
        atol=run.atol,
        alpha=run.omega,
        beta=run.omega,
        jacobian_reuse=True,
        on_step=step_accepted,
        stage_values=audit.stage_powers,
    )
    q, t = q0, t0
    for k in range(1, n_out + 1):
        t = float(times[k])
        try:
            for end in ends[(k - 1) * parts + 1 : k * parts]:
                stepper.advance_to(float(end))
                work += stepper.stage_integral  # the stages' work (advance_to starts its integral anew)
            q, arrival = stepper.advance_to(t)
        except IntegrationError as err:
            raise SimulationError(
                f"the {run.joint_name} run failed at crank angle {angles[k - 1]:.2f}-"
                f"{angles[k]:.2f} deg of cycle {cycle + 1}: {err}"
            ) from None
        row, qd = outputs.at(t, q, arrival)
        run.position = (cycle, float(angles[k]))  # where an interruption stops (RunInterrupted)
        stepper.restart(q, qd)  # the next interval starts from the consistent velocities
        output_accepted(t)
        rows.append(row)
        # the work along the stages, and the kinetic energy the velocities' projection adds (drift)
        work += stepper.stage_integral
        work[1] += audit.projection_energy(q, arrival, qd)
        energies.append(work.copy())
        if progress is not None and (angles[k] % CHUNK_DEG < 1e-9 or k == n_out):
            progress(cycle, angles[k], rows[-1][prefix + "h_min"])
    run.steps += stepper.steps
    columns = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    columns.update(zip(STAGE_COLUMNS, np.array(energies).T))
    columns["input_work"] = input_work(columns)
    columns["crank_angle"] = angles
    wall = time.perf_counter() - start
    timing = dict.fromkeys(TIMING, 0.0)
    timing.update(wall_s=wall, steps=stepper.steps, rejected_steps=stepper.rejected, multibody_s=wall)
    if models:  # the films' work over the cycle, summed over the films
        for m, before in zip(models, film_before):
            now = m.stats
            for name, value in (
                ("film_solves", now.solves - before.solves),
                ("vi_iterations", now.vi_iterations - before.vi_iterations),
                ("film_jacobians", now.jacobians - before.jacobians),
                ("transport_fallbacks", now.transport_fallbacks - before.transport_fallbacks),
                ("euler_rate_steps", now.euler_rate_steps - before.euler_rate_steps),
                ("film_solve_s", now.solve_seconds - before.solve_seconds),
                ("film_jacobian_s", now.jacobian_seconds - before.jacobian_seconds),
            ):
                timing[name] += value
        timing["multibody_s"] = wall - timing["film_solve_s"] - timing["film_jacobian_s"]
    return CycleOutput(columns, float(np.nanmin(columns[prefix + "h_min"])), timing, prefix), (t, q, qd)


def describe_timing(timing: dict[str, float]) -> str:
    """One line: the counts and where the seconds went (TIMING)."""
    t = timing
    return (
        f"{t['wall_s']:.1f} s; {t['film_solves']:.0f} film solves ({t['vi_iterations']:.0f} VI iterations) "
        f"{t['film_solve_s']:.1f} s, {t['film_jacobians']:.0f} film Jacobians {t['film_jacobian_s']:.1f} s, "
        f"{t['steps']:.0f} steps ({t['rejected_steps']:.0f} rejected), multibody/integrator "
        f"{t['multibody_s']:.1f} s, I/O {t['io_s']:.2f} s"
        + (
            f"; {t['transport_fallbacks']:.0f} steps fell back to the upwind transport"
            if t.get("transport_fallbacks")
            else ""
        )
        + (
            f"; {t['euler_rate_steps']:.0f} steps grew too fast for the film's BDF2 rate (implicit Euler)"
            if t.get("euler_rate_steps")
            else ""
        )
        + (
            f"; the film alone {t['film_alone_solves']:.0f} solves {t['film_alone_s']:.1f} s"
            if t.get("film_alone_solves")
            else ""
        )
    )


def describe_changes(change: dict[str, float]) -> str:
    """One line: each part's change over a cycle (solver.study.periodic.CycleMap.state_changes)."""
    units = {
        "position": "clearance (pin in its bushing)",
        "velocity": "clearance x crank speed",
        "film_fraction": "(largest at a node)",
        "deformation": "clearance (rms)",
        "temperature": "K (the heat balance's fixed point less the cycle's)",
        "big_end_film_fraction": "(largest at a node)",
        "big_end_deformation": "clearance (rms)",
    }
    return ", ".join(
        f"{name.replace('_', ' ')} {value:.3g} {units[name]}"
        for name, value in change.items()
        if math.isfinite(value)
    )


def relative_change(values: list[float]) -> float:
    """|last - previous| / |last| of a per-cycle history; inf with fewer than two cycles."""
    if len(values) < 2:
        return math.inf
    change = abs(values[-1] - values[-2])
    return change / abs(values[-1]) if values[-1] != 0 else (0.0 if change == 0 else math.inf)


class _AboveTheBar:
    """A stream for log handlers that prints through ``tqdm.write``: above the progress bar."""

    def write(self, text: str) -> None:
        if text.strip():
            tqdm.write(text.rstrip("\n"), file=sys.stderr)

    def flush(self) -> None:
        pass


@contextmanager
def _logs_above_the_bar():
    """The terminal's log handlers (stderr) write above the progress bar meanwhile; their filters and
    formats stay as they are (tqdm's own redirect drops the filters)."""
    swapped = []
    for handler in logging.getLogger().handlers:
        if type(handler) is logging.StreamHandler and handler.stream is sys.stderr:
            swapped.append((handler, handler.setStream(_AboveTheBar())))
    try:
        yield
    finally:
        for handler, stream in swapped:
            handler.setStream(stream)


def _progress_bar(case, first: int):
    """The progress bar of a run (rank 0 with progress) and its report(cycle, angle, h_min)."""
    bar = tqdm(
        total=case.solver.max_cycles * 720,
        initial=first * 720,
        unit="deg",
        desc=case.name,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} deg [{elapsed}<{remaining}] "
        "{postfix}",
    )

    def report(cycle_index, angle, h_min):
        bar.n = cycle_index * 720 + angle
        bar.set_postfix_str(
            f"cycle {cycle_index + 1}, {angle:.0f} deg, h_min {h_min * 1e6:.3f} um", refresh=False
        )
        bar.refresh()

    return bar, report


def run_cycles(run, out_dir: Path, fingerprint: str, progress: bool, resume: bool):
    """Integrate cycles of ``run`` (solver.study.simulation.Run) until periodic (and, with
    oil.thermal = "effective", thermally consistent); checkpoint at cycle ends. Returns (last cycle,
    count, periodic); ``run.timings`` and ``run.cycle_history`` hold the per-cycle timing and histories."""
    case, comm, oil = run.case, run.comm, run.oil
    path = out_dir / "checkpoint.npz"
    # the other lubricated joints' cycle minima of h_min (the periodic test follows them too)
    others: dict[str, list[float]] = {name: [] for name in run.clearances if name != run.lead}
    checkpoint = io.read_checkpoint(path, fingerprint) if resume else None
    timings: list[dict[str, float]] = []
    if checkpoint is not None:
        first, t0, q0, qd0 = checkpoint.cycles, checkpoint.t, checkpoint.q, checkpoint.qd
        history, friction = checkpoint.h_min_history, checkpoint.friction_history
        others = {name: list(checkpoint.joint_histories.get(name, [])) for name in others}
        timings = checkpoint.timings
        log.info("resuming after cycle %d from %s", first, path)
        run.earlier_wall_time = checkpoint.elapsed_s
        if run.model is not None:  # an elastic bushing's deformation (JFO: film fraction) history goes on
            for time_s, film_state in checkpoint.film:
                run.model.commit_history(film_state, time_s)
            if checkpoint.film:  # and the next solve starts where the run's would have: from the cycle's end
                run.model.start_from(checkpoint.film[-1][1])
        if run.big_has_history:  # the big end's film alike (an older checkpoint has none: a fresh film)
            for time_s, film_state in checkpoint.big_end_film:
                run.big_model.commit_history(film_state, time_s)
            if checkpoint.big_end_film:
                run.big_model.start_from(checkpoint.big_end_film[-1][1])
        oil.resume(checkpoint.thermal)
    else:
        first, history, friction = 0, [], []
        t0, q0, qd0 = run.em.initial_state(0.0)
    # the cycle map's parts (solver.study.periodic): each cycle's change of each, and the extrapolation
    cycle_map = CycleMap(run, case.solver.periodic_acceleration)
    relaxing = case.solver.periodic_acceleration == "film" and "small_end" in cycle_map.films
    start = EndState(t0, q0, qd0, [])
    changes: dict[str, list[float]] = {name: [math.nan] * first for name in STATE_PARTS}
    extrapolated = [0.0] * first  # 1: the cycle started from an extrapolated state
    # film cycles of the film alone after each cycle (periodic_acceleration = "film")
    alone = [math.nan] * first
    bar, report = _progress_bar(case, first) if progress and comm.rank == 0 else (None, None)

    cycle = None
    periodic = False
    c = run.clearances.get(run.lead, case.small_end.clearance)  # of the joint the periodic test follows
    friction_tolerance = case.solver.periodic_friction_tolerance

    def h_change(values: list[float], clearance: float) -> float:
        return abs(values[-1] - values[-2]) / clearance if len(values) > 1 else math.inf

    def settled() -> tuple[bool, str]:  # (periodic by the cycles' min h_min and friction, what changed)
        extrapolated_start = bool(extrapolated and extrapolated[-1])
        lead_change = h_change(history, c)
        f_change = relative_change(friction)
        text = (
            f"min h_min = {history[-1] * 1e6:.4g} um (change {lead_change:.2g} of the clearance), "
            f"mean friction power = {friction[-1]:.6g} W (change {f_change:.2g})"
        )
        other_changes = {name: h_change(values, run.clearances[name]) for name, values in others.items()}
        for name, change in other_changes.items():
            text += f"; {name} min h_min = {others[name][-1] * 1e6:.4g} um (change {change:.2g})"
        return lead_change < case.solver.periodic_tolerance and all(
            change < case.solver.periodic_tolerance for change in other_changes.values()
        ) and (friction_tolerance is None or f_change < friction_tolerance), text + (
            " (the cycle started from the extrapolated state)" if extrapolated_start else ""
        )

    def record_others(cycle: CycleOutput) -> None:
        for name, values in others.items():
            values.append(nan_reduce(np.nanmin, cycle.columns[PREFIX[name] + "h_min"]))

    def at_film_temperature() -> None:  # the temperature the thermal iteration asks for
        if oil.thermal is not None and oil.thermal.temperature != oil.temperature:
            set_film_temperature(run, oil.thermal.temperature)

    def thermal_step(cycle_index: int, cycle: CycleOutput) -> bool:  # True: consistent (or isothermal)
        if oil.thermal is None:
            return True
        try:
            balance = oil.heat_balance(cycle.columns)
            following = oil.thermal.record(balance)
        except ThermalError as err:
            raise SimulationError(f"cycle {cycle_index + 1}: {err}") from None
        log.info(
            "cycle %d: film %.6g C, %.4g Pa s: heat %.4g W, into the oil %.4g W, carried by the side "
            "flow (%.4g mm^3/s) %.4g W, closure %.2g; next cycle at %.6g C",
            cycle_index + 1,
            balance.temperature,
            oil.viscosity,
            balance.dissipated_power,
            balance.heat_to_oil,
            balance.side_flow * 1e9,
            balance.heat_carried,
            balance.closure,
            following,
        )
        return oil.thermal.converged

    def relax_film(cycle_index: int, settled_now: bool):  # the film alone under the cycle's motion
        if settled_now or cycle_index + 1 >= case.solver.max_cycles:  # (no cycle follows)
            return None
        relaxed = relax(
            run.model,
            cycle_map.films["small_end"],
            run.joint.trace,
            run.model.committed_history(),
            ALONE_TOLERANCE,
            ALONE_CYCLES,
        )
        # the model now holds the replay's last film cycle, a few periods on: the loop commits the
        # relaxed history (moved back) as the next cycle's start, and the checkpoint holds it
        cycle.timing["film_alone_solves"] = relaxed.solves
        cycle.timing["film_alone_s"] = relaxed.seconds
        cycle.timing["wall_s"] += relaxed.seconds
        log.info(
            "cycle %d: the film alone under the cycle's motion, %d film cycles (%d solves, %.1f s): the film "
            "fraction's largest change at a node %s",
            cycle_index + 1,
            relaxed.cycles,
            relaxed.solves,
            relaxed.seconds,
            ", ".join(f"{c:.3g}" for c in relaxed.changes),
        )
        return relaxed

    run.position, saved = (first, 0.0), first  # (cycle index, crank angle) reached; cycles checkpointed
    try:
        # log lines go above the progress bar instead of through it
        with _logs_above_the_bar() if bar is not None else nullcontext():
            for index in range(first, case.solver.max_cycles):
                at_film_temperature()
                if relaxing:  # the kinematics of the film's committed states (solver.study.relaxation)
                    run.joint.trace = []
                cycle, (t0, q0, qd0) = run.integrate_cycle(index, start.t, start.q, start.qd, progress=report)
                consistent = thermal_step(index, cycle)
                start = dataclasses.replace(
                    start,
                    film=run.start_film if run.model is not None else [],
                    temperature=oil.temperature if oil.thermal is not None else math.nan,
                    big_end_film=run.start_big_end_film if run.big_has_history else [],
                )
                end = EndState(
                    t0,
                    q0,
                    qd0,
                    run.model.committed_history() if run.model is not None else [],
                    oil.thermal.model.fixed_point(oil.thermal.history[-1])
                    if oil.thermal is not None
                    else math.nan,
                    run.big_model.committed_history() if run.big_has_history else [],
                )
                change = cycle_map.state_changes(start, end)
                cycle_map.record(start, end)
                for name in STATE_PARTS:
                    changes[name].append(change[name])
                extrapolated.append(1.0 if cycle_map.extrapolated else 0.0)
                history.append(cycle.h_min_min)
                friction.append(cycle.friction_power_mean)
                record_others(cycle)
                settled_now, text = settled()
                log.info("cycle %d: %s", index + 1, text)
                log.info(
                    "cycle %d: change of the state over the cycle: %s", index + 1, describe_changes(change)
                )
                relaxed = relax_film(index, settled_now) if relaxing else None
                alone.append(relaxed.cycles if relaxed is not None else 0)
                begin = time.perf_counter()
                timings.append(cycle.timing)
                if comm.rank == 0:
                    io.write_checkpoint(
                        path,
                        io.Checkpoint(
                            fingerprint=fingerprint,
                            cycles=index + 1,
                            t=t0,
                            q=q0,
                            qd=qd0,
                            h_min_history=history,
                            friction_history=friction,
                            timings=timings,
                            thermal=oil.thermal.state() if oil.thermal is not None else None,
                            film=relaxed.history if relaxed is not None else end.film,
                            elapsed_s=run.earlier_wall_time + time.perf_counter() - run.started,
                            joint_histories=others,
                            big_end_film=run.big_model.committed_history() if run.big_has_history else [],
                        ),
                    )
                saved = index + 1
                cycle.timing["io_s"] = time.perf_counter() - begin
                cycle.timing["wall_s"] += cycle.timing["io_s"]
                log.info("cycle %d: %s", index + 1, describe_timing(cycle.timing))
                if settled_now and consistent:
                    periodic = True
                    break
                # extrapolated while the orbit is not periodic; then plain (the thermal iteration alone
                # closes the balance: an extrapolation there only moves the orbit by its noise)
                start = cycle_map.next_start(end, extrapolate=not settled_now)
                if relaxed is not None:
                    start = dataclasses.replace(end, film=relaxed.history)
                for model, film in ((run.model, start.film), (run.big_model, start.big_end_film)):
                    if start is not end and model is not None and film:
                        for time_s, film_state in film:  # each film's history moved alike
                            model.commit_history(film_state, time_s)
                        model.start_from(film[-1][1])
                if start is not end and oil.thermal is not None:  # the temperature extrapolated with them
                    oil.thermal.propose(start.temperature)
    except KeyboardInterrupt:
        index, angle = run.position
        raise RunInterrupted(case.name, index + 1, angle, path if saved else None, saved) from None
    finally:
        if bar is not None:
            bar.close()
    if cycle is None:  # resumed after the last allowed cycle: run one more to have outputs
        at_film_temperature()
        cycle, _ = run.integrate_cycle(len(history), t0, q0, qd0)
        history.append(cycle.h_min_min)
        friction.append(cycle.friction_power_mean)
        record_others(cycle)
        for name in STATE_PARTS:
            changes[name].append(math.nan)
        extrapolated.append(0.0)
        alone.append(0)
        thermal_step(len(history) - 1, cycle)
        timings.append(cycle.timing)
    run.timings = timings
    run.cycle_history = {
        "h_min_min": list(history),
        "friction_power_mean": list(friction),
        **{f"{PREFIX[name]}h_min_min": list(values) for name, values in others.items()},
        **{f"state_change_{name}": values for name, values in changes.items()},
        "extrapolated_start": extrapolated,
        "film_alone_cycles": alone,
    }
    if not settled()[0]:
        log.warning(
            "not periodic after %d cycles (tolerance %g of the clearance%s)",
            len(history),
            case.solver.periodic_tolerance,
            "" if friction_tolerance is None else f"; friction {friction_tolerance:g} of itself",
        )
    if oil.thermal is not None and not oil.thermal.converged:
        log.warning(
            "not thermally consistent after %d cycles: heat balance closure %.2g (tolerance %g)",
            len(history),
            oil.thermal.history[-1].closure,
            oil.thermal.tolerance,
        )
    return cycle, len(history), periodic
