"""Batch runs (solver.study.batch, solver.study.summary, slurm/): results, summary, failures, resume, ranks,
Slurm.

The ``mpi`` tests run on one rank and under ``mpirun -n 2`` (scripts/test.sh). They use short coarse
cases: the ideal joint (about 0.1 s per case) and the analytic short-bearing joint with one 720 deg
cycle and 9 deg outputs (about 6 s per case). The 1-rank/2-rank comparison is exact up to 1e-12
relative: every case runs the same arithmetic on one rank (or on the same data on each rank of a
two-rank group; the short-bearing film has no distributed mesh), so only the order of the cases over
the ranks changes, which must not change any number.

Cases that must fail are real failures: an out-of-range value (InputError inside run_case) and a TOML
syntax error; exceptions of other kinds, exceptions on one rank of a group, and uneven run times
use a stand-in runner. The Slurm scripts are checked with ``bash -n``, their ``#SBATCH`` lines are
parsed, and they are run locally (no srun here: they fall back to mpirun) on a tiny batch; these
tests start mpirun themselves, so they are serial.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from solver.cli import main
from solver.errors import InputError
from solver.study import batch

ROOT = Path(__file__).resolve().parents[2]
COARSE = "max_cycles = 1\nstep_deg = 9\n"
IDEAL = f'[solver]\njoint = "ideal"\n{COARSE}'
SHORT = f'[solver]\njoint = "short-bearing"\n{COARSE}'


def write_cases(comm, root: Path, cases: dict[str, str]) -> list[Path]:
    """Case directories ``root/<name>/case.toml`` (rank 0 writes; all ranks get the paths)."""
    if comm.rank == 0:
        for name, text in cases.items():
            (root / name).mkdir(parents=True, exist_ok=True)
            (root / name / "case.toml").write_text(text)
    comm.Barrier()
    return [root / name for name in cases]


def results_ok(case: Path) -> bool:
    return batch.results_complete(case / "results" / "results.nc")


def open_summary(path: Path):
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return ds.load()


def mpi_env() -> dict[str, str]:
    """Environment for starting mpirun from a test (no inherited Open MPI job state)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "OMPI_MCA_orte", "PMIX_"))}
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        PYTHONPATH=str(ROOT),
        OMPI_MCA_rmaps_base_oversubscribe="1",
    )
    return env


# -- a sweep of four short cases, then reruns -----------------------------------------------------------


@pytest.fixture(scope="module")
def study(comm):
    """A sweep of four cases (joint x speed: two ideal, two short-bearing), expanded and run once."""
    root = Path(comm.bcast(tempfile.mkdtemp(prefix="tribo-batch-") if comm.rank == 0 else None, root=0))
    if comm.rank == 0:
        (root / "base").mkdir()
        (root / "base" / "case.toml").write_text(f"[solver]\n{COARSE}")
        (root / "study.toml").write_text(
            '[sweep]\nbase = "base"\n[sweep.parameters]\n"solver.joint" = ["ideal", "short-bearing"]\n'
            '"engine.speed_rpm" = [3000, 4000]\n'
        )
    comm.Barrier()
    status = main(["batch", str(root / "study.toml")])
    yield root, status
    comm.Barrier()
    if comm.rank == 0:
        shutil.rmtree(root, ignore_errors=True)


@pytest.mark.mpi
def test_four_cases_give_four_results_and_a_four_row_summary(comm, study):
    root, status = study
    assert status == 0
    cases = root / "study"
    names = [
        "joint-ideal_speed_rpm-3000",
        "joint-ideal_speed_rpm-4000",
        "joint-short-bearing_speed_rpm-3000",
        "joint-short-bearing_speed_rpm-4000",
    ]
    assert all(results_ok(cases / name) for name in names)
    ds = open_summary(cases / "summary.nc")
    assert list(ds["case"].values) == names and ds.sizes["case"] == 4
    assert list(ds["solver.joint"].values) == ["ideal", "ideal", "short-bearing", "short-bearing"]
    assert list(ds["engine.speed_rpm"].values) == [3000.0, 4000.0, 3000.0, 4000.0]
    assert ds["engine.speed_rpm"].attrs["units"] == "rpm"
    assert ds.attrs["varied_parameters"] == "solver.joint, engine.speed_rpm"
    assert ds.attrs["solver.max_cycles"] == 1  # constant parameters are attributes
    for name in ("h_min_min", "p_max_max", "F_asperity_max", "friction_power_mean", "run_time"):
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    film = ds.sel(case=names[2:])
    assert np.all((film.h_min_min > 0) & (film.h_min_min < 10e-6))  # inside the 10 um clearance
    assert np.all(film.friction_power_mean > 0) and np.all(ds.run_time > 0)
    assert list(ds["status"].values) == ["complete"] * 4
    # the numbers are those of the results files (the run's own summary attributes)
    for name in names[2:]:
        import xarray as xr

        with xr.open_dataset(cases / name / "results" / "results.nc") as res:
            assert float(ds.h_min_min.sel(case=name)) == pytest.approx(float(res.h_min.min()), rel=1e-12)
    assert (cases / "summary_h_min_min.png").stat().st_size > 1000
    document = json.loads((cases / "batch_status.json").read_text())
    assert document["all_passed"] and document["n_cases"] == 4 and document["world_size"] == comm.size
    assert [r["case"] for r in document["cases"]] == names
    record = json.loads((cases / names[2] / "results" / "case_status.json").read_text())
    assert record["status"] == "complete" and record["ranks"] == 1 and record["metrics"]["h_min_min"] > 0


@pytest.mark.mpi
def test_rerun_skips_finished_cases(comm, study):
    root, _ = study
    cases = root / "study"
    before = {p: p.stat().st_mtime_ns for p in cases.glob("*/results/results.nc")}
    start = time.perf_counter()
    assert main(["batch", str(root / "study.toml")]) == 0
    assert time.perf_counter() - start < 10  # the two short-bearing cases alone take longer
    assert {p: p.stat().st_mtime_ns for p in cases.glob("*/results/results.nc")} == before
    document = json.loads((cases / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["skipped"] * 4 and document["all_passed"]
    assert open_summary(cases / "summary.nc").sizes["case"] == 4


@pytest.mark.mpi
def test_rerun_after_an_interruption_runs_only_the_unfinished_cases(comm, study):
    """Interrupted runs leave no results.nc (or a .part file, or a truncated file): those cases run again."""
    root, _ = study
    cases = root / "study"
    ideal_3000, ideal_4000 = cases / "joint-ideal_speed_rpm-3000", cases / "joint-ideal_speed_rpm-4000"
    if comm.rank == 0:
        (ideal_3000 / "results" / "results.nc").rename(ideal_3000 / "results" / ".results.nc.part")
        data = (ideal_4000 / "results" / "results.nc").read_bytes()
        (ideal_4000 / "results" / "results.nc").write_bytes(data[: len(data) // 2])
    comm.Barrier()
    assert not results_ok(ideal_3000) and not results_ok(ideal_4000)
    edited = cases / "joint-short-bearing_speed_rpm-3000"
    before = (edited / "results" / "results.nc").stat().st_mtime_ns
    assert main(["batch", str(root / "study.toml")]) == 0
    document = json.loads((cases / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["complete", "complete", "skipped", "skipped"]
    assert results_ok(ideal_3000) and results_ok(ideal_4000)
    assert (edited / "results" / "results.nc").stat().st_mtime_ns == before


# -- failures ---------------------------------------------------------------------------------------------


@pytest.mark.mpi
def test_bad_cases_are_recorded_and_the_others_go_on(comm, tempdir):
    cases = write_cases(
        comm,
        tempdir,
        {
            "a-good": IDEAL,
            "b-out-of-range": IDEAL + "[small_end]\nclearance_um = 20000\n",
            "c-good": IDEAL.replace("[solver]", "[engine]\nspeed_rpm = 3000\n[solver]"),
            "d-bad-toml": IDEAL + "[oil\n",
            "e-good": IDEAL.replace("[solver]", "[engine]\nspeed_rpm = 5000\n[solver]"),
        },
    )
    assert main(["batch", *map(str, cases)]) == 1
    for case in cases:
        assert results_ok(case) == case.name.endswith("good")
    document = json.loads((tempdir / "batch_status.json").read_text())
    assert not document["all_passed"]
    status = {r["case"]: r for r in document["cases"]}
    assert status["b-out-of-range"]["status"] == "invalid"
    assert "small_end.clearance_um" in status["b-out-of-range"]["error"]
    assert status["d-bad-toml"]["status"] == "invalid" and "invalid TOML" in status["d-bad-toml"]["error"]
    record = json.loads((tempdir / "b-out-of-range" / "results" / "case_status.json").read_text())
    assert record["status"] == "invalid" and "Traceback" in record["traceback"]
    ds = open_summary(tempdir / "summary.nc")
    assert list(ds["status"].values) == ["complete", "invalid", "complete", "invalid", "complete"]
    assert "small_end.clearance_um" in str(ds["error"].values[1])
    np.testing.assert_array_equal(ds["engine.speed_rpm"].values, [2000.0, 2000.0, 3000.0, math.nan, 5000.0])
    assert ds["small_end.clearance_um"].values[1] == 20000.0
    assert np.all(np.isnan(ds.run_time.values[[1, 3]])) and np.all(ds.run_time.values[[0, 2, 4]] > 0)
    # a rerun tries the failed cases again (and only those)
    assert main(["batch", *map(str, cases)]) == 1
    document = json.loads((tempdir / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["skipped", "invalid", "skipped", "invalid", "skipped"]


class Boom(RuntimeError):
    pass


@pytest.mark.mpi
@pytest.mark.parametrize("ranks_per_case", [1, 2])
def test_an_exception_on_any_rank_of_a_group_fails_only_that_case(comm, tempdir, ranks_per_case):
    if ranks_per_case > comm.size:
        pytest.skip("needs two ranks")
    cases = write_cases(comm, tempdir, {f"case{i}": IDEAL for i in range(4)})
    ran = []

    def runner(case_dir, group):
        assert group.size == ranks_per_case and group is not MPI.COMM_WORLD
        if case_dir.name == "case1" and group.rank == group.size - 1:  # on one rank of the group only
            raise Boom("the film solver exploded")
        ran.append(case_dir.name)

    plan = batch.BatchPlan(cases=tuple(cases), output=tempdir)
    result = batch.run_batch(plan, comm, ranks_per_case=ranks_per_case, runner=runner, summary=False)
    assert result.exit_status == 1
    if comm.rank == 0:
        status = {r["case"]: r for r in result.records}
        assert [status[f"case{i}"]["status"] for i in range(4)] == [
            "complete",
            "failed",
            "complete",
            "complete",
        ]
        assert status["case1"]["error"] == "Boom: the film solver exploded"
        assert "Boom" in status["case1"]["traceback"]
    all_ran = sorted(sum(comm.allgather(ran), []))
    assert set(all_ran) == {"case0", "case2", "case3"} | ({"case1"} if ranks_per_case > 1 else set())


@pytest.mark.mpi
def test_bad_batch_input_is_an_input_error_on_every_rank(comm, tempdir):
    with pytest.raises(InputError, match="no such file"):
        main_raising(comm, ["batch", str(tempdir / "missing")])
    cases = write_cases(comm, tempdir, {"one": IDEAL})
    with pytest.raises(InputError, match="ranks-per-case"):
        batch.run_batch(
            batch.BatchPlan(cases=tuple(cases), output=tempdir), comm, ranks_per_case=comm.size + 1
        )
    assert main(["batch", str(tempdir / "missing")]) == 2


def main_raising(comm, argv):
    """The batch command with InputError propagated (to check it is raised on every rank)."""
    from solver.cli import _parser
    from solver.cli import batch as batch_cli

    return batch_cli.run(_parser().parse_args(argv), comm)


# -- ranks ------------------------------------------------------------------------------------------------


@pytest.mark.mpi
def test_groups_split_the_world(comm):
    for k in range(1, comm.size + 1):
        group, index, count = batch.split_groups(comm, k)
        assert count == comm.size // k and index == min(comm.rank // k, count - 1)
        assert group.size == (k if index < count - 1 else comm.size - k * (count - 1))
        group.Free()
    with pytest.raises(InputError, match="out of range"):
        batch.split_groups(comm, comm.size + 1)
    with pytest.raises(InputError, match="out of range"):
        batch.split_groups(comm, 0)


@pytest.mark.mpi
@pytest.mark.parametrize("schedule", ["dynamic", "static"])
def test_dynamic_schedule_balances_uneven_cases(comm, tempdir, schedule):
    """Case 0 takes as long as the seven others together: dynamically, the other rank takes those."""
    cases = write_cases(comm, tempdir, {f"case{i}": IDEAL for i in range(8)})

    def runner(case_dir, group):
        time.sleep(1.4 if case_dir.name == "case0" else 0.2)

    plan = batch.BatchPlan(cases=tuple(cases), output=tempdir)
    result = batch.run_batch(plan, comm, schedule=schedule, runner=runner, summary=False)
    assert result.exit_status == 0
    if comm.rank == 0:
        per_rank = [sum(r["world_rank"] == rank for r in result.records) for rank in range(comm.size)]
        assert sum(per_rank) == 8
        if comm.size == 2:
            owner = next(r["world_rank"] for r in result.records if r["case"] == "case0")
            if schedule == "dynamic":
                assert per_rank[owner] <= 2 and per_rank[1 - owner] >= 6, per_rank
            else:
                assert per_rank == [4, 4]


@pytest.mark.mpi
def test_one_and_two_ranks_give_identical_numbers(comm, tempdir):
    """The same short-bearing cases on one rank, on two ranks (one case each), on a two-rank group (one
    case)."""
    import xarray as xr

    if comm.size < 2:
        pytest.skip("compares a 1-rank batch with a 2-rank one: run under mpirun -n 2")

    specs = {
        "fast": SHORT.replace("[solver]", "[engine]\nspeed_rpm = 4000\n[solver]"),
        "slow": SHORT.replace("[solver]", "[engine]\nspeed_rpm = 3000\n[solver]"),
    }
    variants = ["serial", "world", "group2"]
    plans = {
        v: batch.BatchPlan(cases=tuple(write_cases(comm, tempdir / v, specs)), output=tempdir / v)
        for v in variants
    }
    plans["group2"] = dataclasses.replace(
        plans["group2"], cases=plans["group2"].cases[:1]
    )  # one case will do
    if comm.rank == 0:
        assert batch.run_batch(plans["serial"], MPI.COMM_SELF).exit_status == 0
    comm.Barrier()
    assert batch.run_batch(plans["world"], comm).exit_status == 0
    assert batch.run_batch(plans["group2"], comm, ranks_per_case=2).exit_status == 0
    reference = open_summary(tempdir / "serial" / "summary.nc")
    for variant in variants[1:]:
        other = open_summary(tempdir / variant / "summary.nc")
        names = list(other["case"].values)
        for name in ("h_min_min", "p_max_max", "F_asperity_max", "friction_power_mean"):
            np.testing.assert_allclose(
                other[name].values,
                reference[name].sel(case=names).values,
                rtol=1e-12,
                atol=0,
                equal_nan=True,
                err_msg=f"{variant}: {name}",
            )
        for case in names:
            with (
                xr.open_dataset(tempdir / "serial" / case / "results" / "results.nc") as a,
                xr.open_dataset(tempdir / variant / case / "results" / "results.nc") as b,
            ):
                for name in a.data_vars:
                    np.testing.assert_allclose(
                        b[name].values,
                        a[name].values,
                        rtol=1e-12,
                        atol=0,
                        equal_nan=True,
                        err_msg=f"{variant}/{case}: {name}",
                    )
    assert np.all(np.isfinite(reference.h_min_min.values))


# -- discovery and shards -----------------------------------------------------------------------------------


@pytest.mark.serial
def test_discovery(tmp_path):
    cases = write_cases(MPI.COMM_SELF, tmp_path / "set", {"b": IDEAL, "a": IDEAL})
    plan = batch.discover([tmp_path / "set"])
    assert [c.name for c in plan.cases] == ["a", "b"] and plan.output == (tmp_path / "set").resolve()
    plan = batch.discover([cases[0], tmp_path / "set"])  # duplicates are dropped, the order kept
    assert [c.name for c in plan.cases] == ["b", "a"]
    other = write_cases(MPI.COMM_SELF, tmp_path / "other", {"a": IDEAL})
    with pytest.raises(InputError, match="two cases are both named a"):
        batch.discover([tmp_path / "set", other[0]])
    with pytest.raises(InputError, match="without a \\[sweep\\] table"):
        batch.discover([cases[0] / "case.toml"])
    with pytest.raises(InputError, match="no case.toml"):
        batch.discover([tmp_path])


def test_shards_are_disjoint_and_cover_the_batch():
    plan = batch.BatchPlan(cases=tuple(Path(f"c{i}") for i in range(11)), output=Path("."))
    for count in (1, 2, 3, 4, 11, 16):
        shards = [plan.shard(i, count).cases for i in range(count)]
        flat = [c for shard in shards for c in shard]
        assert sorted(flat) == sorted(plan.cases) and len(flat) == len(set(flat))


# -- a killed run -------------------------------------------------------------------------------------


@pytest.mark.serial
@pytest.mark.slow
def test_a_killed_batch_leaves_no_half_written_results(tmp_path):
    """SIGKILL in the middle of the second case: every results.nc present is complete; the rerun skips it."""
    cases = write_cases(
        MPI.COMM_SELF,
        tmp_path,
        {
            "a": SHORT.replace("[solver]", "[engine]\nspeed_rpm = 4000\n[solver]"),
            "b": SHORT.replace("[solver]", "[engine]\nspeed_rpm = 3000\n[solver]"),
        },
    )
    command = [sys.executable, "-m", "solver", "batch", *map(str, cases)]
    process = subprocess.Popen(
        command,
        cwd=ROOT,
        env=mpi_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (cases[0] / "results" / "case_status.json").exists():
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.2)
        time.sleep(1.0)  # inside the second case
        os.killpg(process.pid, signal.SIGKILL)
    finally:
        process.wait(timeout=60)
    for case in cases:
        path = case / "results" / "results.nc"
        assert not path.exists() or results_ok(case), case.name
    assert results_ok(cases[0]) and not results_ok(cases[1])
    rerun = subprocess.run(command, cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    document = json.loads((tmp_path / "batch_status.json").read_text())
    assert [r["status"] for r in document["cases"]] == ["skipped", "complete"]


# -- Slurm ------------------------------------------------------------------------------------------------

SLURM = ROOT / "slurm"
SCRIPTS = [SLURM / "batch.sbatch", SLURM / "batch_array.sbatch"]
SBATCH_OPTION = re.compile(r"^#SBATCH\s+(--[a-z][a-z-]*)(=\S+)?\s*$")


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_slurm_script_syntax_and_directives(script):
    """bash -n passes; every #SBATCH line is one long option and comes before the first command."""
    subprocess.run(["bash", "-n", str(script)], check=True)
    lines = script.read_text().splitlines()
    assert lines[0].startswith("#!")
    first_command = next(i for i, line in enumerate(lines) if line.strip() and not line.startswith("#"))
    directives = [(i, line) for i, line in enumerate(lines) if line.startswith("#SBATCH")]
    assert directives and all(i < first_command for i, _ in directives)
    options = [SBATCH_OPTION.match(line) for _, line in directives]
    assert all(options), [line for (_, line), m in zip(directives, options) if not m]
    names = {m.group(1) for m in options}
    assert {"--job-name", "--ntasks", "--time", "--output"} <= names
    assert "--array" not in names  # the array range is given at submission (and the summary step is no array)
    assert "-m mpi4py -m solver batch" in script.read_text()


def tiny_batch(root: Path) -> Path:
    """A sweep of three ideal cases."""
    (root / "base").mkdir(parents=True)
    (root / "base" / "case.toml").write_text(IDEAL)
    sweep = root / "tiny.toml"
    sweep.write_text('[sweep]\nbase = "base"\n[sweep.parameters]\n"engine.speed_rpm" = [1000, 2000, 3000]\n')
    return sweep


def run_script(script: Path, *args: str, **env: str) -> subprocess.CompletedProcess:
    environment = mpi_env()
    for name in [k for k in environment if k.startswith("SLURM_")]:
        del environment[name]
    environment.update(PYTHON=sys.executable, PATH="/usr/bin:/bin", **env)  # no srun on this PATH
    return subprocess.run(
        ["bash", str(script), *args], cwd=ROOT, env=environment, capture_output=True, text=True, timeout=300
    )


@pytest.mark.serial
def test_slurm_batch_script_runs_locally_under_mpirun(tmp_path):
    sweep = tiny_batch(tmp_path)
    result = run_script(SLURM / "batch.sbatch", str(sweep), NTASKS="2")
    assert result.returncode == 0, result.stderr
    assert "mpirun -n 2" in result.stderr and "solver batch" in result.stderr
    document = json.loads((tmp_path / "tiny" / "batch_status.json").read_text())
    assert document["world_size"] == 2 and document["all_passed"] and document["n_cases"] == 3
    assert open_summary(tmp_path / "tiny" / "summary.nc").sizes["case"] == 3


@pytest.mark.serial
def test_slurm_array_script_runs_disjoint_shards_then_the_summary(tmp_path):
    sweep = tiny_batch(tmp_path)
    assert run_script(SLURM / "batch_array.sbatch", str(sweep)).returncode == 2  # not an array task
    ran = []
    for task in ("0", "1"):
        result = run_script(
            SLURM / "batch_array.sbatch",
            str(sweep),
            SLURM_ARRAY_TASK_ID=task,
            SLURM_ARRAY_TASK_MAX="1",
            NTASKS="1",
        )
        assert result.returncode == 0, result.stderr
        document = json.loads((tmp_path / "tiny" / f"batch_status.shard-{task}-of-2.json").read_text())
        ran.append([r["case"] for r in document["cases"] if r["status"] == "complete"])
    assert ran == [["speed_rpm-1000", "speed_rpm-3000"], ["speed_rpm-2000"]]  # disjoint, together all
    assert not (tmp_path / "tiny" / "summary.nc").exists()  # shards write no summary
    result = run_script(SLURM / "batch_array.sbatch", "--summary-only", str(sweep))
    assert result.returncode == 0, result.stderr
    ds = open_summary(tmp_path / "tiny" / "summary.nc")
    assert list(ds["engine.speed_rpm"].values) == [1000.0, 2000.0, 3000.0]
    assert list(ds["status"].values) == ["complete"] * 3
