"""The engine with the mass-conserving (JFO) small end through whole firing cycles.

References: the oil balance of the film over a periodic cycle (what the edges take in and give out is
what the film stores: a conservation law, checked from results.nc alone), the complementarity in the
ParaView snapshot, and an uninterrupted run for the checkpoint (the film fraction's history must
survive a resume: exact equality, the integration is deterministic), and the energy balance of the
results' audit (the work of the driver and the gas against the change of mechanical energy and the
energy dissipated in the joint), which holds on these coarse runs too.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import simpson

from solver.study.simulation import run_case
from tests.conftest import energy_balance, interrupt_and_resume, run_cli
from tests.study.test_engine_coupled import make_case

JFO = '[oil]\ncavitation = "jfo"\ncavitation_pressure_bar = -0.9\n'
SOLVER = (
    "max_cycles = 2\nstep_deg = 2\nmesh_size = 0.2\nperiodic_tolerance = 1e-9\nfield_step_deg = 0\n"
    "field_angles_deg = [380]\n"
)


def _jfo_case(directory):
    case = make_case(directory, SOLVER)
    toml = case / "case.toml"
    text = toml.read_text()
    # the reference case documents every key: replace its [oil] values rather than adding a section
    text = text.replace("cavitation_pressure_bar = 0.0", "cavitation_pressure_bar = -0.9", 1)
    text = text.replace('cavitation = "reynolds"', 'cavitation = "jfo"', 1)
    assert 'cavitation = "jfo"' in text and "cavitation_pressure_bar = -0.9" in text
    toml.write_text(text)
    return case


@pytest.fixture(scope="module")
def jfo_run(tmp_path_factory):
    """Two cycles of the reference engine with the JFO film: coarse (0.2 R), 2 deg outputs."""
    from solver.study import io

    case = _jfo_case(tmp_path_factory.mktemp("jfo") / "straight")
    snapshots = {}
    original = io.write_film_fields

    def recording(directory, name, model):  # the fields as they are written
        snapshots[name] = {k: f.x.array.copy() for k, f in model.fields_si().items()}
        return original(directory, name, model)

    patch = pytest.MonkeyPatch()
    patch.setattr(io, "write_film_fields", recording)
    try:
        summary = run_case(case, MPI.COMM_SELF)
    finally:
        patch.undo()
    with xr.open_dataset(summary.results) as ds:
        yield summary, ds.load(), case, snapshots


@pytest.mark.slow
@pytest.mark.serial
def test_the_film_keeps_its_oil_over_the_cycle(jfo_run):
    """Oil balance of the last cycle from results.nc: the integral of (supply - side flow) plus the
    change of the stored oil, over the integral of |side flow|, below 3 % (BDF2 film fraction on 2 deg
    outputs, Simpson on those outputs: measured 0.8 % at 1 deg and 0.05 % at 0.25 deg, so it converges).
    The film ruptures over part of the bushing, as a small end does."""
    _, ds, _, _ = jfo_run
    t, side, supply, volume = (ds[k].values for k in ("time", "side_flow", "supply_flow", "oil_volume"))
    assert ds.attrs["oil.cavitation"] == "jfo"
    assert np.all(np.isfinite(volume)) and np.all(volume > 0)
    assert np.all(supply == 0.0)  # no supply hole or groove: the edges alone
    closure = (simpson(supply - side, x=t) - (volume[-1] - volume[0])) / simpson(np.abs(side), x=t)
    assert abs(closure) < 0.03
    cavitated = ds.cavitated_area_ratio.values
    assert 0.05 < cavitated.min() and cavitated.max() < 0.95


@pytest.mark.slow
@pytest.mark.serial
def test_the_results_count_the_steps_that_fell_back_to_upwinding(jfo_run):
    """timing.transport_fallbacks: one whole count per computed cycle (the limited transport is the
    default), and run.log's cycle line names it exactly when it is not zero."""
    _, ds, case, _ = jfo_run
    assert ds.attrs["solver.film_fraction_transport"] == "limited"
    counts = np.atleast_1d(ds.attrs["timing.transport_fallbacks"])
    assert len(counts) == int(ds.attrs["cycles"])
    assert np.all(np.isfinite(counts)) and np.all(counts >= 0) and np.all(counts == np.round(counts))
    lines = [row for row in (case / "results" / "run.log").read_text().splitlines() if "film solves" in row]
    assert len(lines) == len(counts)
    for line, count in zip(lines, counts):
        assert (f"; {count:.0f} steps fell back to the upwind transport" in line) == (count > 0)


@pytest.mark.slow
@pytest.mark.serial
def test_the_energy_audit_closes_on_the_coarse_jfo_cycle(jfo_run):
    """The results' energy audit of the last cycle within 1 % of the dissipated energy (the issue's
    target for the JFO engine; measured -0.86 % on these 2 deg outputs with the limited transport,
    -0.70 % with upwinding; -0.02 to -0.18 % at the default resolution, README). The pin crosses its
    clearance in a fraction of a degree here: Simpson's rule on the outputs' powers, the older
    measure, is off by more than 5 x that target (measured -9.6 %; +41 % with upwinding), so the
    audit's driver work from the crank's momentum is what closes it."""
    _, ds, _, _ = jfo_run
    audit, outputs = energy_balance(ds)
    assert abs(audit) < 0.01, audit
    assert abs(outputs) > 0.05, outputs


@pytest.mark.slow
@pytest.mark.serial
def test_the_paraview_snapshot_carries_the_film_fraction(jfo_run):
    """The snapshot at 380 deg holds the film fraction beside the pressure, with values in [0, 1] and a
    ruptured zone (some below 1) where the pressure is at the cavitation pressure."""
    _, _, case, snapshots = jfo_run
    xdmf = (case / "results" / "film_380.0deg.xdmf").read_text()
    assert 'Name="film_fraction"' in xdmf and 'Name="pressure_Pa"' in xdmf
    (fields,) = snapshots.values()
    theta, pressure = fields["film_fraction"], fields["pressure"]
    assert theta.min() >= 0.0 and theta.max() <= 1.0 and theta.min() < 0.99
    assert np.allclose(pressure[theta < 1.0], -0.9e5, rtol=0, atol=1e-6)


@pytest.mark.slow
@pytest.mark.serial
def test_interrupted_jfo_run_resumes_with_its_film_fraction(jfo_run, tmp_path, monkeypatch):
    """Stopped after the first cycle and resumed from the checkpoint, the run ends with the same numbers
    as the uninterrupted one (exact): the committed film fractions are in the checkpoint."""
    straight, _, _, _ = jfo_run
    resumed = interrupt_and_resume(_jfo_case(tmp_path / "interrupted"), monkeypatch, 1)
    with xr.open_dataset(straight.results) as a, xr.open_dataset(resumed.results) as b:
        for name in ("ecc_x", "ecc_y", "h_min", "oil_volume", "cavitated_area_ratio"):
            np.testing.assert_array_equal(a[name].values, b[name].values)


@pytest.mark.serial
@pytest.mark.parametrize(
    "old, new, message",
    [
        # the max-gap inlet turns the film with the pin, which a film fraction's history cannot follow
        (
            'inlet = "none"',
            'inlet = "max-gap"',
            "oil.inlet = 'max-gap' (--inlet max-gap) with oil.cavitation = 'jfo' (--cavitation jfo)",
        ),
        # inlet none, no supply, edges at the cavitation pressure: no oil can enter but along the edges
        (
            "cavitation_pressure_bar = -0.9",
            "cavitation_pressure_bar = 0.0",
            "oil.cavitation_pressure_bar = 0 (--cavitation-pressure 0 Pa) with oil.cavitation = 'jfo'",
        ),
    ],
    ids=["max-gap", "sealed-edges"],
)
def test_jfo_refuses_a_case_in_one_line(tmp_path, old, new, message):
    """What the JFO film cannot take: one line naming the key and what is allowed, exit 2, nothing written."""
    case = _jfo_case(tmp_path / "refused")
    toml = case / "case.toml"
    text = toml.read_text()
    assert old in text
    toml.write_text(text.replace(old, new, 1))
    result = run_cli("run", str(case), "--quiet")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert "Traceback" not in result.stderr and not (case / "results" / "results.nc").exists()


@pytest.mark.slow
@pytest.mark.serial
def test_the_elastic_jfo_small_end_runs_the_firing_cycle(tmp_path):
    """One coarse cycle (0.15 R, 5 deg outputs) with a Winkler bushing and the JFO film: the whole cycle,
    the bushing deforming by micrometres at firing, the film ruptured over part of the bushing and its
    oil balance from results.nc within 3 % of the side flow's integral (the coarse rigid cycle: 0.8 %
    at 1 deg; this one's first cycle starts from a centred pin and a full film); the energy audit
    within 1 % of the dissipated energy (measured -0.27 %; the outputs' Simpson: +20 %)."""
    case = make_case(
        tmp_path / "winkler-jfo",
        "max_cycles = 1\nstep_deg = 5\nmesh_size = 0.15\nfield_step_deg = 0\nfield_angles_deg = []\n",
    )
    toml = case / "case.toml"
    text = toml.read_text()
    text = text.replace('elastic = "none"', 'elastic = "winkler"\nbushing_thickness_mm = 1.5', 1)
    text = text.replace("cavitation_pressure_bar = 0.0", "cavitation_pressure_bar = -0.9", 1)
    text = text.replace('cavitation = "reynolds"', 'cavitation = "jfo"', 1)
    toml.write_text(text)
    summary = run_case(case, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        assert ds.attrs["oil.cavitation"] == "jfo" and ds.attrs["small_end.elastic"] == "winkler"
        assert ds.crank_angle.values[-1] == 720
        assert 0.5e-6 < float(ds.deformation_max.sel(crank_angle=slice(360, 420)).max()) < 10e-6
        cavitated = ds.cavitated_area_ratio.values[1:]  # (the start is the full film)
        assert 0.05 < cavitated.min() and cavitated.max() < 0.95
        t, side, volume = ds.time.values, ds.side_flow.values, ds.oil_volume.values
        closure = (simpson(-side, x=t) - (volume[-1] - volume[0])) / simpson(np.abs(side), x=t)
        assert abs(closure) < 0.03
        audit, _ = energy_balance(ds)
        assert abs(audit) < 0.01, audit
