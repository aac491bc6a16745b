"""Shared fixtures: the communicator, MPI-safe temporary directories, collective teardown.

Markers: ``serial`` tests are skipped when the world has more than one rank; ``mpi`` tests are about
parallel behaviour and are run on one rank and again under ``mpirun -n 2`` (scripts/test.sh).
"""

from __future__ import annotations

import gc
import os
import shutil
import sys
import tempfile
from pathlib import Path

from mpi4py import MPI

import pytest

import solver.study.io  # noqa: F401  (imports netCDF4 quietly: see there)

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"


def pytest_collection_modifyitems(config, items):
    if MPI.COMM_WORLD.size > 1:
        skip = pytest.mark.skip(reason="serial test (world size > 1)")
        for item in items:
            if "serial" in item.keywords:
                item.add_marker(skip)


@pytest.fixture(scope="session")
def comm():
    return MPI.COMM_WORLD


@pytest.fixture
def tempdir(comm):
    """A temporary directory shared by all ranks (rank 0 creates it, the name is broadcast)."""
    path = comm.bcast(tempfile.mkdtemp(prefix="tribo-test-") if comm.rank == 0 else None, root=0)
    yield Path(path)
    comm.Barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(autouse=True)
def _collective_teardown():
    """PETSc destructors are collective: collect garbage on all ranks together (dolfinx conftest)."""
    yield
    gc.collect()
    MPI.COMM_WORLD.Barrier()


def run_cli(*args: str, cwd: Path | None = None, timeout: float = 600):
    """Run ``python -m solver ARGS`` in a subprocess with this interpreter; returns CompletedProcess."""
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("OMPI_COMM_WORLD_SIZE", None)
    return subprocess.run(
        [sys.executable, "-m", "solver", *args],
        capture_output=True,
        text=True,
        cwd=cwd or ROOT,
        timeout=timeout,
        env=env,
    )


def assert_one_line_error(result, *fragments: str) -> None:
    """Bad input as the CLI must report it: exit 2, one line ``error: ...`` with the fragments, no
    traceback, nothing on stdout."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert result.stdout == ""


def interrupt_and_resume(case: Path, monkeypatch, stop_at_cycle: int):
    """Run ``case`` until it is interrupted at the start of cycle ``stop_at_cycle`` (0-based, after the
    checkpoint of the cycle before), then run it again: it resumes from the checkpoint. Returns the
    resumed run's summary; the run log must say where it resumed."""
    from solver.study import simulation

    original = simulation.Run.integrate_cycle

    def stop(self, cycle, *args, **kwargs):
        if cycle == stop_at_cycle:
            raise KeyboardInterrupt
        return original(self, cycle, *args, **kwargs)

    monkeypatch.setattr(simulation.Run, "integrate_cycle", stop)
    with pytest.raises(KeyboardInterrupt):
        simulation.run_case(case, MPI.COMM_SELF)
    assert (case / "results" / "checkpoint.npz").exists() and not (case / "results" / "results.nc").exists()
    monkeypatch.setattr(simulation.Run, "integrate_cycle", original)
    resumed = simulation.run_case(case, MPI.COMM_SELF)
    assert f"resuming after cycle {stop_at_cycle}" in (case / "results" / "run.log").read_text()
    return resumed


def energy_balance(ds) -> tuple[float, float]:
    """(audit, outputs) relative errors of a results.nc's last cycle, over its dissipated energy: the
    audit ``input_work - dE - dissipated_energy + drift_work`` (README, Energy audit), and the older
    measure, Simpson's rule on the outputs' input and dissipated powers."""
    from scipy.integrate import simpson

    change = float(
        ds.kinetic_energy[-1] + ds.potential_energy[-1] - ds.kinetic_energy[0] - ds.potential_energy[0]
    )
    dissipated = float(ds.dissipated_energy[-1])
    audit = float(ds.input_work[-1]) - change - dissipated + float(ds.drift_work[-1])
    t = ds.time.values
    sampled = simpson(ds.dissipated_power.values, x=t)
    outputs = simpson(ds.input_power.values, x=t) - change - sampled
    return audit / dissipated, outputs / sampled
