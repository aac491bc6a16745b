"""Benchmark (not a test): the elastic JFO engine cycle against the rigid JFO cycle at the same film mesh.

    taskset -c 1 .venv/bin/python3 bench/bench_elastic_jfo.py [--cycles N] [--rounds K] [--code DIR ...]

Runs ``cases/reference-2000rpm-ehd-jfo`` (FE eye, its modes as the case chooses them, Barus oil, JFO) and
``cases/reference-2000rpm-jfo`` with the elastic case's film mesh, integrator tolerance, output step and
largest step (its ``mesh_size``, ``mesh_edge_size``, ``rtol``, ``step_deg`` and ``max_step_deg`` keys; the
other keys as shipped), each for ``--cycles`` integrated cycles from its ideal-joint start, through the
command line only (``python3 -m solver run CASE --json``), so the same script measures any version of the
package (``--code``: checkouts whose ``solver`` runs, in turn; default this one). Per run it prints the last
cycle's record (results attributes ``timing.*``): the film solves, their Newton iterations, the seconds in
them and per solve, the Jacobians, the cycle's wall time, and min h_min and the mean friction power of the
run; then the elastic / rigid ratios of the time per film solve and per cycle, round by round (the runs of a
round one after the other). The machine's speed drifts: compare only the runs of one sitting, pinned to one
core (``taskset``).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
ELASTIC, RIGID = "reference-2000rpm-ehd-jfo", "reference-2000rpm-jfo"
#: the last cycle's record read from results.nc (solver.study.results.TIMING)
TIMES = ("wall_s", "film_solves", "vi_iterations", "film_jacobians", "film_solve_s", "film_jacobian_s")


def _set(text: str, key: str, value: str | None) -> str:
    """``key = value`` in the [solver] table (None: the key removed, its default applies)."""
    pattern = rf"^{key}\s*=.*$"
    if value is None:
        return re.sub(pattern + r"\n?", "", text, flags=re.MULTILINE)
    line = f"{key} = {value}"
    if re.search(pattern, text, flags=re.MULTILINE):
        return re.sub(pattern, line, text, flags=re.MULTILINE)
    return text.replace("[solver]", f"[solver]\n{line}", 1)


def _key(text: str, key: str) -> str | None:
    found = re.search(rf"^{key}\s*=\s*([^#\s]+)", text, flags=re.MULTILINE)
    return found.group(1) if found else None


def cases(work: Path, cycles: int) -> dict[str, Path]:
    """Copies of the two cases: ``cycles`` cycles, the rigid one at the elastic one's mesh (its grading too),
    rtol, output step and largest step."""
    elastic_text = (ROOT / "cases" / ELASTIC / "case.toml").read_text()
    out = {}
    for kind, name in (("elastic", ELASTIC), ("rigid", RIGID)):
        text = (ROOT / "cases" / name / "case.toml").read_text()
        if kind == "rigid":
            for key in ("mesh_size", "mesh_edge_size", "rtol", "step_deg", "max_step_deg"):
                text = _set(text, key, _key(elastic_text, key))
        text = _set(text, "max_cycles", str(cycles))
        case = work / kind / name
        case.mkdir(parents=True)
        (case / "case.toml").write_text(text)
        out[kind] = case
    return out


def run(code: Path, case: Path) -> dict[str, float]:
    """One run by the command line from the checkout ``code``; its last cycle's timing and answers."""
    command = [sys.executable, "-m", "solver", "run", str(case), "--json", "--restart"]
    done = subprocess.run(command, capture_output=True, text=True, check=False, cwd=code)
    if done.returncode != 0:
        raise SystemExit(f"{case.name} ({code}): exit {done.returncode}\n{done.stderr[-2000:]}")
    report = json.loads(done.stdout.strip().splitlines()[-1])
    results = Path(report["results"])
    results = results if results.is_absolute() else code / results
    with xr.open_dataset(results / "results.nc" if results.is_dir() else results) as ds:
        timing = {name: float(np.atleast_1d(ds.attrs[f"timing.{name}"])[-1]) for name in TIMES}
    timing["h_min_min"] = report["h_min_min_m"]
    timing["friction_power_mean"] = report["friction_power_mean_W"]
    timing["ms_per_solve"] = 1e3 * timing["film_solve_s"] / timing["film_solves"]
    return timing


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=1, help="integrated cycles per run")
    parser.add_argument("--rounds", type=int, default=1, help="rounds of runs, each code and case in turn")
    parser.add_argument("--code", type=Path, nargs="+", default=[ROOT], help="checkouts to run, in turn")
    parser.add_argument("--only", choices=("elastic", "rigid"), help="this case only")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = cases(Path(tmp), args.cycles)
        for k in range(args.rounds):
            for code in args.code:
                found = {}
                for kind, case in work.items():
                    if args.only and kind != args.only:
                        continue
                    shutil.rmtree(case / "results", ignore_errors=True)
                    t = found[kind] = run(code.resolve(), case)
                    print(
                        f"round {k + 1} {code} {kind}: cycle {t['wall_s']:.1f} s; "
                        f"{t['film_solves']:.0f} film solves ({t['vi_iterations']:.0f} Newton iterations) "
                        f"in {t['film_solve_s']:.1f} s, "
                        f"{t['ms_per_solve']:.2f} ms each; {t['film_jacobians']:.0f} Jacobians in "
                        f"{t['film_jacobian_s']:.1f} s; min h_min {t['h_min_min']!r} m, mean friction power "
                        f"{t['friction_power_mean']!r} W",
                        flush=True,
                    )
                if len(found) == 2:
                    e, r = found["elastic"], found["rigid"]
                    print(
                        f"round {k + 1} {code}: elastic / rigid per film solve "
                        f"{e['ms_per_solve'] / r['ms_per_solve']:.2f}, "
                        f"per cycle {e['wall_s'] / r['wall_s']:.2f}",
                        flush=True,
                    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
