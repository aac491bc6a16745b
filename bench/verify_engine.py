"""Verification study of the coupled engine (too long for CI; its table goes into docs/verification.md).

    .venv/bin/python3 bench/verify_engine.py [--case DIR] [--base-mesh H] [--base-step DEG]
        [--base-max-step DEG] [--base-rtol R] [--max-cycles N] [--periodic-tolerance T]
        [--periodic-friction-tolerance F] [--only VARIANT ...] [--keep]

Runs the reference case (or ``--case``, e.g. cases/reference-2000rpm-ehd: its keys but the solver's)
with the mixed finite-element film at a base resolution and refined
variants, and physical variants, each until periodic (at most 3 cycles), and prints:

- periodicity: cycles needed and the last cycle-to-cycle change of min h_min (and of the mean
  friction power, with ``--periodic-friction-tolerance``);
- mesh and time-step convergence (the output step halved, the integrator's largest step halved at the
  same outputs, rtol / 10): the cycle minimum of h_min and the cycle-mean friction power of each
  refinement against the base (target: changes < 2 %);
- trends: higher viscosity -> larger minimum film and smaller asperity load; rougher surfaces ->
  larger asperity load;
- the energy balance of the last cycle (crank + gas work - change of mechanical energy vs the energy
  dissipated in the joint): the results' audit (input_work, dissipated_energy, drift_work), and
  beside it the older quadrature of the outputs' powers.
"""

from __future__ import annotations

import argparse
import re
import shutil
import tempfile
from pathlib import Path

from mpi4py import MPI

import numpy as np
import xarray as xr
from scipy.integrate import simpson

from solver.study.simulation import run_case

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "cases" / "reference-2000rpm"


def make_case(work: Path, name: str, solver: dict, extra: str = "", source: Path = REFERENCE) -> Path:
    """The source case's keys but its [solver] section (which must come last), under a new name."""
    case = work / name
    case.mkdir()
    head = (source / "case.toml").read_text().split("[solver]")[0]
    head = re.sub(r'^name = ".*"$', f'name = "{name}"', head, count=1, flags=re.MULTILINE)
    body = "\n".join(f"{k} = {v}" for k, v in solver.items())
    (case / "case.toml").write_text(head + extra + "\n[solver]\n" + body + "\n")
    return case


def metrics(path: Path) -> dict[str, float]:
    """The study's numbers from a results.nc. ``energy_error``: the last cycle's energy audit,
    (input_work - change of mechanical energy - dissipated_energy + drift_work) / dissipated_energy;
    ``energy_error_outputs``: the older measure, Simpson's rule on the outputs' input and dissipated
    powers, which samples the crank driver's torque too coarsely where the pin crosses its clearance
    (docs/verification.md, the reference case's study)."""
    with xr.open_dataset(path) as ds:
        t = ds.time.values
        change = float(
            ds.kinetic_energy[-1] + ds.potential_energy[-1] - ds.kinetic_energy[0] - ds.potential_energy[0]
        )
        dissipated = float(ds.dissipated_energy[-1])
        audit = float(ds.input_work[-1]) - change - dissipated + float(ds.drift_work[-1])
        sampled = simpson(ds.dissipated_power.values, x=t)
        outputs = simpson(ds.input_power.values, x=t) - change - sampled
        friction = ds.attrs.get("history.friction_power_mean")  # a scalar after one cycle (netCDF)
        friction = None if friction is None else np.atleast_1d(friction)
        # the periodic test's measure, signed: (last - previous) / last
        last_change = float("nan")
        if friction is not None and len(friction) > 1:
            last_change = (friction[-1] - friction[-2]) / friction[-1]
        return {
            "h_min_min": float(ds.h_min.min()),
            "friction_power_mean": float(ds.friction_power.mean()),
            "friction_last_change": last_change,
            "F_asperity_max": float(ds.F_asperity.max()),
            "p_max_max": float(ds.p_max.max()),
            "cycles": int(ds.attrs["cycles"]),
            "periodic": ds.attrs["periodic"],
            "wall": float(ds.attrs["wall_time_s"]),
            "energy_error": audit / dissipated,
            "energy_error_outputs": outputs / sampled,
            "dissipated_J": dissipated,
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", type=Path, default=REFERENCE, help="the case whose keys the variants take")
    parser.add_argument("--base-mesh", type=float, default=0.15)
    parser.add_argument("--base-step", type=float, default=5.0)
    parser.add_argument(
        "--base-max-step",
        type=float,
        default=None,
        help="solver.max_step_deg of the base (the integrator's largest step below the output step; default: "
        "the output step); 'output step / 2' halves both, 'largest step / 2' halves this one",
    )
    parser.add_argument("--base-rtol", type=float, default=1e-5)
    parser.add_argument(
        "--base-edge",
        type=float,
        default=None,
        help="solver.mesh_edge_size of the base (the film graded toward the edges; default: uniform); "
        "the variant 'mesh edges / 2' halves it",
    )
    parser.add_argument(
        "--base-modes",
        type=int,
        default=None,
        help="small_end.compliance_modes of the base (an FE eye's case); the variant 'modes x 2' doubles it",
    )
    parser.add_argument("--max-cycles", type=int, default=3)
    parser.add_argument(
        "--periodic-tolerance",
        type=float,
        default=0.01,
        help="solver.periodic_tolerance of every variant (the change of the cycle minimum of h_min, "
        "/ clearance, below which a run is periodic)",
    )
    parser.add_argument(
        "--periodic-friction-tolerance",
        type=float,
        default=None,
        help="solver.periodic_friction_tolerance of every variant (the relative change "
        "of the cycle-mean friction power that must hold as well; default: not checked)",
    )
    parser.add_argument(
        "--no-base", action="store_true", help="skip the base run (run it in another process)"
    )
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--only", nargs="*", default=None, help="run only these variants (and the base)")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="verify-engine-"))
    base = {
        "joint": '"mixed-fem"',
        "max_cycles": args.max_cycles,
        "periodic_tolerance": args.periodic_tolerance,
        "mesh_size": args.base_mesh,
        "step_deg": args.base_step,
        "rtol": args.base_rtol,
        "field_angles_deg": "[]",
        "field_step_deg": 0,
    }
    if args.periodic_friction_tolerance is not None:
        base["periodic_friction_tolerance"] = args.periodic_friction_tolerance
    if args.base_edge is not None:
        base["mesh_edge_size"] = args.base_edge
    largest = args.base_step if args.base_max_step is None else args.base_max_step
    if args.base_max_step is not None:
        base["max_step_deg"] = args.base_max_step
    modes = "" if args.base_modes is None else f"[small_end]\ncompliance_modes = {args.base_modes}\n"
    variants = {
        "base": (base, modes),
        "mesh / 1.5": ({**base, "mesh_size": round(args.base_mesh / 1.5, 4)}, modes),
        # the outputs and the integrator's largest step halved together
        "output step / 2": ({**base, "step_deg": args.base_step / 2, "max_step_deg": largest / 2}, modes),
        # the integrator's largest step halved at the same outputs: the time refinement itself (the error
        # test does not bound the steps below the outputs' bound: docs/verification.md)
        "largest step / 2": ({**base, "max_step_deg": largest / 2}, modes),
        "rtol / 10": ({**base, "rtol": args.base_rtol / 10}, modes),
        "viscosity x 2": (base, "[oil]\nviscosity_Pa_s = 0.020\n"),
        "roughness x 1.5": (base, "[surface]\nsigma_pin_um = 0.15\nsigma_bushing_um = 0.45\n"),
    }
    if args.base_edge is not None:  # the element size halved where it is smallest
        variants["mesh edges / 2"] = ({**base, "mesh_edge_size": round(args.base_edge / 2, 5)}, modes)
    if args.base_modes is not None:
        variants["modes x 2"] = (base, f"[small_end]\ncompliance_modes = {2 * args.base_modes}\n")
    rows = {}
    if args.only:
        variants = {k: v for k, v in variants.items() if (k == "base" and not args.no_base) or k in args.only}
    for label, (solver, extra) in variants.items():
        name = label.replace(" ", "").replace("/", "-").replace(".", "p")
        case = make_case(work, name, solver, source=args.case)
        if extra:  # sections must come before [solver]; rewrite the file with the extra section merged
            text = (case / "case.toml").read_text()
            section, body = extra.split("\n", 1)
            keys = [line.split("=")[0].strip() for line in body.splitlines() if "=" in line]
            lines = [line for line in text.splitlines() if line.split("=")[0].strip() not in keys]
            text = "\n".join(lines).replace(section + "\n", section + "\n" + body, 1)
            (case / "case.toml").write_text(text)
        summary = run_case(case, MPI.COMM_SELF, progress=True)
        rows[label] = metrics(summary.results)
        print(label, rows[label], flush=True)
    if "base" not in rows:
        return
    b = rows["base"]
    print(
        f"\nbase: mesh {args.base_mesh} R, outputs every {args.base_step} deg, "
        f"rtol {args.base_rtol:g}, periodic "
        f"tolerance {args.periodic_tolerance:g}, friction {args.periodic_friction_tolerance} "
        f"(cycles: {b['cycles']}, periodic: {b['periodic']})"
    )
    print(
        "| variant | cycles | min h_min [um] | change | mean friction power [W] | change | friction's "
        "change in the last cycle | max asperity force [N] | max p_max [MPa] | energy balance error "
        "(audit; outputs' Simpson) | wall [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, r in rows.items():
        dh = (r["h_min_min"] / b["h_min_min"] - 1) * 100
        dp = (r["friction_power_mean"] / b["friction_power_mean"] - 1) * 100
        print(
            f"| {label} | {r['cycles']} | {r['h_min_min'] * 1e6:.4f} | {dh:+.2f} % | "
            f"{r['friction_power_mean']:.3f} | "
            f"{dp:+.2f} % | {100 * r['friction_last_change']:+.2f} % | {r['F_asperity_max']:.0f} | "
            f"{r['p_max_max'] / 1e6:.0f} | {100 * r['energy_error']:+.3f} % "
            f"({100 * r['energy_error_outputs']:+.2f} %) | {r['wall']:.0f} |"
        )
    if "viscosity x 2" not in rows or "roughness x 1.5" not in rows:
        return
    v, s = rows["viscosity x 2"], rows["roughness x 1.5"]
    print(
        f"\ntrend viscosity x 2: min h_min {'larger' if v['h_min_min'] > b['h_min_min'] else 'NOT larger'}, "
        f"max asperity force {'smaller' if v['F_asperity_max'] < b['F_asperity_max'] else 'NOT smaller'}"
    )
    print(
        f"trend roughness x 1.5: max asperity force "
        f"{'larger' if s['F_asperity_max'] > b['F_asperity_max'] else 'NOT larger'}"
    )
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
