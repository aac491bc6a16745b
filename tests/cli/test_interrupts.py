"""Interrupted ``run`` and ``batch``: one line, exit 130, what finished kept, a rerun resumes.

The commands run in subprocesses on the analytic short-bearing joint (one 720 deg cycle takes ~2 s on a
fast machine, 10-25 s on a slow one) and are interrupted in their second cycle (INTO_CYCLE_2), once the
first cycle's checkpoint is on disk: ``run`` with SIGINT (Ctrl-C), a one-rank ``batch`` with SIGTERM, and
``mpirun -n 2 ... batch`` with SIGINT to mpirun, which sends SIGTERM to the ranks (and SIGKILL a second
later). These tests start processes (and mpirun) themselves, so they are serial. The reference for
"resumes" is the run's own log ("resuming after cycle 1") and the cycle count; for the cumulative wall
time, the first cycle's own wall time (a lower bound of the first invocation's part) and the test's
clock (an upper bound).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr

from solver.study.batch import PASSED
from tests.conftest import ROOT
from tests.study.test_batch import mpi_env

SHORT = '[solver]\njoint = "short-bearing"\nmax_cycles = 3\nstep_deg = 9\n'
IDEAL = '[solver]\njoint = "ideal"\nstep_deg = 9\n'
#: s after the first cycle's checkpoint appeared: early in cycle 2 on a fast machine (a cycle ~2 s; 2 s
#: here had let the run finish its cycle 2 and write its results) and on a slow one
INTO_CYCLE_2 = 0.3


def case(root: Path, name: str, text: str) -> Path:
    (root / name).mkdir(parents=True)
    (root / name / "case.toml").write_text(f'name = "{name}"\n{text}')
    return root / name


def start(command: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        command, cwd=ROOT, env=mpi_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def wait_for(paths: list[Path], process: subprocess.Popen, timeout: float = 400) -> None:
    """Until each of ``paths`` has appeared, the process still running. Not necessarily all at once: in a
    batch on a loaded core one case can finish (its checkpoint removed) before the other writes its first."""
    deadline = time.monotonic() + timeout
    seen: set[Path] = set()
    while True:
        seen.update(p for p in paths if p.exists())
        if len(seen) == len(paths):
            return
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.1)


def interrupt_lines(stderr: str) -> list[str]:
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    return [line for line in stderr.splitlines() if line.startswith("interrupted")]


@pytest.mark.serial
@pytest.mark.slow
def test_ctrl_c_on_run_prints_where_it_stopped_and_a_rerun_resumes(tmp_path):
    """SIGINT in cycle 2: exit 130, one line naming the case, the cycle and the crank angle and that a
    rerun resumes after cycle 1; the checkpoint is kept and no results.nc written. The rerun (the same
    command) resumes after cycle 1, and its wall_time_s adds the first invocation's part (between the
    first cycle's own wall time and the test's clock until the checkpoint appeared) to its own."""
    sb = case(tmp_path, "sb", SHORT)
    checkpoint = sb / "results" / "checkpoint.npz"
    launched = time.monotonic()
    process = start([sys.executable, "-m", "solver", "run", str(sb), "--quiet"])
    wait_for([checkpoint], process)
    seen = time.monotonic() - launched
    time.sleep(INTO_CYCLE_2)  # into cycle 2 (or still at the end of cycle 1: both are reported)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    lines = interrupt_lines(stderr)
    assert len(lines) == 1 and stderr.splitlines()[-1] == lines[0], stderr
    assert re.search(r"case sb at cycle [12], crank angle \d+ deg", lines[0]), lines[0]
    assert "resumes it after cycle 1" in lines[0]
    assert checkpoint.exists() and not (sb / "results" / "results.nc").exists()

    rerun = subprocess.run(
        [sys.executable, "-m", "solver", "run", str(sb), "--json"],
        cwd=ROOT,
        env=mpi_env(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert rerun.returncode == 0, rerun.stderr
    assert "resuming after cycle 1" in (sb / "results" / "run.log").read_text()
    report = json.loads(rerun.stdout)
    with xr.open_dataset(sb / "results" / "results.nc") as ds:
        attrs = dict(ds.attrs)
        # where h_min is, for the rigid short bearing: along the eccentricity (ecc_x, ecc_y)
        import numpy as np

        along = np.degrees(np.arctan2(ds.ecc_y.values, ds.ecc_x.values)) % 360
        np.testing.assert_allclose(ds.h_min_angle.values, along, rtol=0, atol=1e-9)
        assert np.all(ds.p_max.values >= 0) and np.nanmax(ds.p_max.values) > 1e6  # no longer NaN
    earlier = attrs["wall_time_s"] - attrs["wall_time_last_invocation_s"]
    assert attrs["timing.wall_s"][0] <= earlier <= seen  # cycle 1 was the first invocation's
    assert report["wall_time_s"] == pytest.approx(attrs["wall_time_s"])
    assert report["wall_time_last_invocation_s"] == pytest.approx(attrs["wall_time_last_invocation_s"])
    assert report["cycles"] == len(attrs["timing.wall_s"]) >= 2


@pytest.mark.serial
@pytest.mark.slow
def test_sigterm_on_a_one_rank_batch_writes_the_status_and_a_rerun_resumes(tmp_path):
    """SIGTERM while the second case is in cycle 2: exit 130, one line, batch_status.json with the
    first case complete and the second interrupted (its case_status.json says where); the rerun skips
    the first, resumes the second after cycle 1, and both are complete in the summary."""
    cases = [case(tmp_path, "a", IDEAL), case(tmp_path, "b", SHORT)]
    command = [sys.executable, "-m", "solver", "batch", *map(str, cases)]
    process = start(command)
    wait_for([cases[0] / "results" / "case_status.json", cases[1] / "results" / "checkpoint.npz"], process)
    time.sleep(INTO_CYCLE_2)  # into cycle 2 (or still at the end of cycle 1: both are reported)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    lines = interrupt_lines(stderr)
    assert len(lines) == 1 and stderr.splitlines()[-1] == lines[0], stderr
    assert "1 of 2 case(s) finished" in lines[0] and re.search(r"case b at cycle [12], crank angle", lines[0])
    assert "batch_status.json written" in lines[0] and "rerun the same command to resume" in lines[0]
    document = json.loads((tmp_path / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["complete", "interrupted"]
    assert document["interrupted"] is True
    record = json.loads((cases[1] / "results" / "case_status.json").read_text())
    assert record["status"] == "interrupted" and "resumes it after cycle 1" in record["error"]

    rerun = subprocess.run(command, cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=600)
    assert rerun.returncode == 0, rerun.stderr
    assert "resuming after cycle 1" in (cases[1] / "results" / "run.log").read_text()
    document = json.loads((tmp_path / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["skipped", "complete"]
    with xr.open_dataset(tmp_path / "summary.nc") as ds:
        assert list(ds.status.values) == ["complete", "complete"]
        assert list(ds.ran_this_invocation.values) == [0, 1]


@pytest.mark.serial
@pytest.mark.slow
def test_ctrl_c_on_mpirun_batch_writes_the_status_and_a_rerun_resumes(tmp_path):
    """``mpirun -n 2 python -m mpi4py -m solver batch`` with two short-bearing cases, one a rank, SIGINT
    to mpirun in their second cycles: mpirun sends SIGTERM to the ranks; one line from rank 0 (no MPI
    abort report, no traceback), batch_status.json with both interrupted, their checkpoints kept; mpirun
    itself exits non-zero (Open MPI gives 1 when interrupted). The rerun resumes both after cycle 1."""
    cases = [
        case(tmp_path, "a", SHORT),
        case(tmp_path, "b", SHORT.replace("[solver]", "[engine]\nspeed_rpm = 3000\n[solver]")),
    ]
    command = [
        "mpirun",
        "-n",
        "2",
        "--oversubscribe",
        sys.executable,
        "-m",
        "mpi4py",
        "-m",
        "solver",
        "batch",
        *map(str, cases),
    ]
    process = subprocess.Popen(
        command,
        cwd=ROOT,
        env=mpi_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    wait_for([c / "results" / "checkpoint.npz" for c in cases], process)
    time.sleep(INTO_CYCLE_2)  # into cycle 2 (or still at the end of cycle 1: both are reported)
    os.kill(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode != 0, stderr
    lines = interrupt_lines(stderr)
    assert len(lines) == 1 and "MPI_ABORT" not in stderr, stderr
    # on a loaded machine one case may finish between the last checkpoint and the signal: the line
    # counts it, and its status is complete
    finished = re.search(r"batch: (\d) of 2 case\(s\) finished, (\d) interrupted", lines[0])
    assert finished and int(finished[1]) + int(finished[2]) == 2 and int(finished[1]) <= 1, lines[0]
    # where: in a cycle, or between two (writing the checkpoint) when the signal came; rank 0 reports it
    # for its own case, so not when that one had finished (batch_status.json has the other's)
    assert int(finished[1]) == 1 or re.search(r"at cycle [123], crank|outside its cycles", lines[0]), lines[0]
    document = json.loads((tmp_path / "batch_status.json").read_text())
    statuses = [r["status"] for r in document["cases"]]
    assert statuses.count("interrupted") == int(finished[2]) and set(statuses) <= {"interrupted", "complete"}
    # the interrupted cases keep their checkpoints (a finished case's is removed)
    kept = [(c / "results" / "checkpoint.npz").exists() for c, s in zip(cases, statuses) if s != "complete"]
    assert all(kept), statuses

    rerun = subprocess.run(command, cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=600)
    assert rerun.returncode == 0, rerun.stderr
    for c, status in zip(cases, statuses):
        if status == "interrupted":
            assert "resuming after cycle 1" in (c / "results" / "run.log").read_text()
    document = json.loads((tmp_path / "batch_status.json").read_text())
    # the interrupted cases complete; one that had finished around the signal is skipped or, when its
    # results were not yet recorded as complete, run again (either passes: solver.study.batch.PASSED)
    for record, status in zip(document["cases"], statuses):
        assert record["status"] == "complete" if status == "interrupted" else record["status"] in PASSED


def test_ctrl_c_still_reaches_python_after_the_film_mesh():
    """gmsh's import sets SIGINT to the default action, which ends the process at once without the
    line (a mixed-fem run interrupted after its film mesh was built printed nothing, exit by signal).
    After the film mesh's gmsh set-up the handler must be Python's again: checked in a fresh
    interpreter (the test process may have imported gmsh before), exactly, no tolerance."""
    code = (  # (Python's handler first: a shell's background job inherits SIGINT ignored, as run/batch set)
        "import signal\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from solver.film.mesh import initialize_gmsh\n"
        "initialize_gmsh()\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "True", out.stdout + out.stderr
