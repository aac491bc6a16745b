"""The shipped cases' answers, to compare two versions of the code (a refactoring must not move them).

    .venv/bin/python3 bench/same_answers.py --save before.json          # on the code before the change
    .venv/bin/python3 bench/same_answers.py --compare before.json       # on the code after it

Runs every shipped kind of film through the command line only (``python3 -m solver run CASE --json``), so
the same script measures any version of the package: the reference (rigid, Reynolds), the elastic eye
(EHD), the mass-conserving film (JFO), both together (EHD-JFO), the effective film temperature (two
cycles, so that the second runs at the temperature the first one's heat balance asked for), and the
reference engine with the short-bearing and the dry joint. Each case runs from its ideal-joint start for
``--cycles`` integrated cycles (the firing stroke and the 40 deg after it included), not to periodic.

Per case it records min h_min, max p_max, the mean friction power and the energy audit of the reported
cycle (the last rows of input_work, dissipated_energy and drift_work in results.nc) and, with
``--compare``, prints each one's relative change against the saved file and exits 1 when any is above
``--rtol`` (default 1e-9).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

ROOT = Path(__file__).resolve().parents[1]

#: name -> (case directory, joint, cycles)
CASES = {
    "reference": ("reference-2000rpm", None, 1),
    "ehd": ("reference-2000rpm-ehd", None, 1),
    "jfo": ("reference-2000rpm-jfo", None, 1),
    "ehd-jfo": ("reference-2000rpm-ehd-jfo", None, 1),
    "thermal": ("thermal-5w30-90C-2000rpm", None, 2),
    "short-bearing": ("reference-2000rpm", "short-bearing", 1),
    "dry": ("reference-2000rpm", "dry", 1),
}
AUDIT = ("input_work", "dissipated_energy", "drift_work")


def with_cycles(source: Path, work: Path, cycles: int) -> Path:
    """A copy of the case directory whose solver.max_cycles is ``cycles`` (its other keys as they are)."""
    case = work / source.name
    shutil.copytree(source, case, ignore=shutil.ignore_patterns("results"))
    text = (case / "case.toml").read_text()
    text, n = re.subn(r"^max_cycles\s*=\s*\d+", f"max_cycles = {cycles}", text, flags=re.MULTILINE)
    if n == 0:
        text = (
            text.replace("[solver]", f"[solver]\nmax_cycles = {cycles}", 1)
            if "[solver]" in text
            else (text + f"\n[solver]\nmax_cycles = {cycles}\n")
        )
    (case / "case.toml").write_text(text)
    return case


def answers(case: Path, joint: str | None) -> dict[str, float]:
    """Run the case by the command line; its summary and energy audit."""
    command = [sys.executable, "-m", "solver", "run", str(case), "--json", "--restart"]
    if joint is not None:
        command += ["--joint", joint]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False, cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"{case.name} ({joint}): exit {done.returncode}\n{done.stderr[-2000:]}")
    report = json.loads(done.stdout.strip().splitlines()[-1])
    out = {
        "h_min_min": report["h_min_min_m"],
        "p_max_max": report["p_max_max_Pa"],
        "friction_power_mean": report["friction_power_mean_W"],
    }
    results = ROOT / report["results"]  # (relative paths: to the directory the command ran in)
    with xr.open_dataset(results / "results.nc" if results.is_dir() else results) as ds:
        out.update({name: float(ds[name].values[-1]) for name in AUDIT})
    out["wall_s"] = time.perf_counter() - start
    return out


def relative(a: float | None, b: float | None) -> float:
    if a is None or b is None:
        return 0.0 if a is None and b is None else math.inf
    if a == b:
        return 0.0
    return abs(a - b) / max(abs(a), abs(b))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", type=Path, help="write the answers to this JSON file")
    parser.add_argument("--compare", type=Path, help="compare with the answers in this JSON file")
    parser.add_argument("--rtol", type=float, default=1e-9, help="largest relative change allowed")
    parser.add_argument("--only", nargs="+", choices=list(CASES), help="these cases only")
    args = parser.parse_args()
    saved = json.loads(args.compare.read_text()) if args.compare else {}
    found: dict[str, dict[str, float]] = {}
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only or CASES:
            directory, joint, cycles = CASES[name]
            work = Path(tmp) / name
            work.mkdir()
            found[name] = answers(with_cycles(ROOT / "cases" / directory, work, cycles), joint)
            line = f"{name:14s} {found[name]['wall_s']:7.1f} s"
            for key, value in found[name].items():
                if key == "wall_s":
                    continue
                line += f"  {key} {value!r}"
                if name in saved:
                    change = relative(value, saved[name][key])
                    worst = max(worst, change)
                    line += f" ({change:.1e})"
            print(line, flush=True)
            if args.save:  # after each case, added to what the file holds (a long run keeps what it did)
                kept = json.loads(args.save.read_text()) if args.save.exists() else {}
                part = args.save.with_name(args.save.name + ".part")
                part.write_text(json.dumps({**kept, **found}, indent=1) + "\n")
                part.replace(args.save)
    if saved:
        print(f"largest relative change: {worst:.2e} (allowed {args.rtol:g})")
        return 0 if worst <= args.rtol else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
