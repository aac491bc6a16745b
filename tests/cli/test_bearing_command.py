"""``python3 -m solver bearing``: JSON interface and bad input (one line, exit 2, no traceback)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.conftest import run_cli

GOOD = [
    "--radius",
    "0.01",
    "--width",
    "0.02",
    "--clearance",
    "10e-6",
    "--viscosity",
    "0.01",
    "--speed",
    "3000",
]
KEYS = [
    "load_N",
    "attitude_deg",
    "eccentricity",
    "sommerfeld_So",
    "p_max_Pa",
    "h_min_m",
    "friction_torque_Nm",
    "side_flow_m3_per_s",
    "dofs",
    "newton_iterations",
    "solve_time_s",
]


def _replace(args, flag, value):
    out = list(args)
    i = out.index(flag)
    if value is None:
        del out[i : i + 2]
    else:
        out[i + 1] = value
    return out


@pytest.mark.serial
@pytest.mark.parametrize(
    "args, names",
    [
        (GOOD + ["--eccentricity", "1.0"], "--eccentricity"),
        (GOOD + ["--eccentricity", "-0.1"], "--eccentricity"),
        (_replace(GOOD, "--clearance", "0") + ["--eccentricity", "0.5"], "--clearance"),
        (_replace(GOOD, "--clearance", "-1e-6") + ["--eccentricity", "0.5"], "--clearance"),
        (_replace(GOOD, "--viscosity", "-0.01") + ["--eccentricity", "0.5"], "--viscosity"),
        (_replace(GOOD, "--radius", "abc") + ["--eccentricity", "0.5"], "--radius"),
        (_replace(GOOD, "--speed", "nan") + ["--eccentricity", "0.5"], "--speed"),
        (_replace(GOOD, "--width", None) + ["--eccentricity", "0.5"], "--width"),
        (GOOD, "--eccentricity"),  # neither --eccentricity nor --load
        (GOOD + ["--eccentricity", "0.5", "--load", "100"], "--load"),
        (GOOD + ["--eccentricity", "0.5", "--no-such-flag"], "--no-such-flag"),
        (GOOD + ["--load", "-5"], "--load"),
        (GOOD + ["--eccentricity", "0.5", "--mesh-size", "0"], "--mesh-size"),
        (GOOD + ["--eccentricity", "0.5", "--grade", "5W-30"], "--viscosity"),
        (_replace(GOOD, "--viscosity", None) + ["--eccentricity", "0.5"], "--viscosity"),
        (_replace(GOOD, "--viscosity", None) + ["--eccentricity", "0.5", "--grade", "5W-31"], "--grade"),
        (
            _replace(GOOD, "--viscosity", None)
            + ["--eccentricity", "0.5", "--kinematic-viscosity-40C", "68"],
            "--kinematic-viscosity-100C",
        ),
        (
            _replace(GOOD, "--viscosity", None)
            + ["--eccentricity", "0.5", "--grade", "5W-30", "--temperature", "400"],
            "--temperature",
        ),
        (GOOD + ["--eccentricity", "0.5", "--elastic", "winkler"], "--bushing-thickness"),
        (
            GOOD
            + [
                "--eccentricity",
                "0.5",
                "--elastic",
                "fe",
                "--bushing-thickness",
                "1.5e-3",
                "--eye-outer-radius",
                "0.017",
                "--inlet",
                "max-gap",
            ],
            "--inlet max-gap) with small_end.elastic = 'fe' (--elastic fe)",
        ),
        (GOOD + ["--eccentricity", "0.5", "--pressure-viscosity", "1"], "--pressure-viscosity"),
        (GOOD + ["--eccentricity", "0.5", "--groove-angle", "90", "--groove-arc", "30"], "--groove-length"),
        (
            GOOD
            + [
                "--eccentricity",
                "0.5",
                "--groove-angle",
                "90",
                "--groove-arc",
                "360",
                "--groove-length",
                "0.01",
            ],
            "--groove-arc",
        ),
        (
            GOOD
            + [
                "--eccentricity",
                "0.5",
                "--groove-angle",
                "90",
                "--groove-arc",
                "30",
                "--groove-length",
                "0.02",
            ],
            "--groove-length",
        ),
        (GOOD + ["--eccentricity", "0.5", "--circumferential-groove", "0.02"], "--circumferential-groove"),
        (
            GOOD
            + [
                "--eccentricity",
                "0.5",
                "--circumferential-groove",
                "0.003",
                "--hole-angle",
                "0",
                "--hole-diameter",
                "0.002",
            ],
            "two oil supplies",
        ),
        (
            GOOD + ["--eccentricity", "0.5", "--circumferential-groove", "0.003", "--inlet", "max-gap"],
            "--inlet",
        ),
        (GOOD + ["--eccentricity", "0.5", "--supply-pressure", "1e5"], "--supply-pressure"),
        (
            GOOD + ["--eccentricity", "0.5", "--circumferential-groove", "0.003", "--supply-pressure", "-1"],
            "--supply-pressure",
        ),
        (
            GOOD + ["--eccentricity", "0.5", "--hole-angle", "0", "--hole-diameter", "0.015"],
            "--hole-diameter",
        ),
        (GOOD + ["--eccentricity", "0.5", "--edge-relief", "-1e-6"], "--edge-relief"),
        (
            GOOD + ["--eccentricity", "0.5", "--edge-relief", "3e-6", "--edge-relief-length", "0.02"],
            "--edge-relief-length",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2(args, names):
    proc = run_cli("bearing", *args)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), proc.stderr
    assert names in lines[0]
    assert "Traceback" not in proc.stderr and proc.stdout == ""


@pytest.mark.serial
def test_json_output_keys_and_values(tempdir):
    """--load with --json: every key of the interface, the load carried, files written; the
    Sommerfeld number recomputed from the reported load by its definition."""
    proc = run_cli(
        "bearing", *GOOD, "--load", "2000", "--json", "--mesh-size", "0.08", "--output", str(tempdir)
    )
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    for key in KEYS:
        assert key in report
    assert report["load_N"] == pytest.approx(2000, rel=1e-6)
    assert report["force_residual_N"] <= 1e-6 * 2000
    So = 2000 * (10e-6 / 0.01) ** 2 / (0.02 * 0.02 * 0.01 * 3000 * 2 * math.pi / 60)
    assert report["sommerfeld_So"] == pytest.approx(So, rel=1e-6)
    assert report["h_min_m"] == pytest.approx(10e-6 * (1 - report["eccentricity"]), rel=1e-9)
    for name in ("bearing_pressure.xdmf", "bearing_pressure.h5", "bearing_pressure.png", "bearing.json"):
        assert (tempdir / name).stat().st_size > 0


@pytest.mark.serial
def test_circumferential_groove_reports_poiseuille_flows():
    """A concentric journal with a 3 mm circumferential groove at 3 bar: the JSON's supply and side flows
    are equal (1e-10: the discrete balance, no source at eps = 0) and the exact Poiseuille flow of the two
    lands, 2 * 2 pi R c^3 p_s / (12 mu (B - w)/2), to h^2/12 = 8.3e-4 at --mesh-size 0.1 (the faceted
    cylinder's error, tests/film/test_oil_supply.py; measured -4.5e-4)."""
    proc = run_cli(
        "bearing",
        *GOOD,
        "--eccentricity",
        "0",
        "--circumferential-groove",
        "3e-3",
        "--supply-pressure",
        "3e5",
        "--json",
        "--mesh-size",
        "0.1",
    )
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["inlet"] == "none" and report["supply"] == "circumferential-groove"
    assert report["supply_pressure_Pa"] == 3e5 and report["p_max_Pa"] == pytest.approx(3e5, rel=1e-12)
    Q = 2 * 2 * math.pi * 0.01 * 10e-6**3 * 3e5 / (12 * 0.01 * (0.02 - 3e-3) / 2)
    assert report["side_flow_m3_per_s"] == pytest.approx(Q, rel=0.1**2 / 12)
    assert report["supply_flow_m3_per_s"] == pytest.approx(report["side_flow_m3_per_s"], rel=1e-10)


@pytest.mark.serial
def test_axial_groove_under_a_load():
    """--load with an axial groove at the top (the load acts downwards): the load is carried, the supply
    delivers oil (a positive supply flow) and, the film cavitating, less than the side flow (the rest is
    the oil the Reynolds condition creates in the cavitated zone; solver.film.bearing)."""
    proc = run_cli(
        "bearing",
        *GOOD,
        "--load",
        "1000",
        "--groove-angle",
        "90",
        "--groove-arc",
        "30",
        "--groove-length",
        "0.012",
        "--supply-pressure",
        "3e5",
        "--json",
        "--mesh-size",
        "0.1",
    )
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["supply"] == "axial-groove" and report["load_N"] == pytest.approx(1000, rel=1e-6)
    assert 0 < report["supply_flow_m3_per_s"] < report["side_flow_m3_per_s"]


ROUGH = ["--sigma-journal", "0.1e-6", "--sigma-bushing", "0.3e-6"]


@pytest.mark.serial
@pytest.mark.parametrize(
    "args, name",
    [
        (["--sigma-journal", "-1e-7"], "--sigma-journal"),
        (ROUGH + ["--peklenik-gamma", "0"], "--peklenik-gamma"),
        (ROUGH + ["--nu-journal", "0.6"], "--nu-journal"),
        (ROUGH + ["--nu-bushing", "-1"], "--nu-bushing"),
        (ROUGH + ["--E-bushing", "-5e9"], "--E-bushing"),
        (ROUGH + ["--eta-beta-sigma", "0"], "--eta-beta-sigma"),
        (
            ROUGH + ["--asperity-density", "1e10", "--eta-beta-sigma", "0.04"],
            "--eta-beta-sigma",
        ),  # both: ambiguous
    ],
)
def test_bad_surface_input_is_one_line_exit_2(args, name):
    proc = run_cli("bearing", *GOOD, "--eccentricity", "0.5", *args)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and name in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.serial
def test_mixed_json_keys():
    """Rough surfaces at low speed: the new keys are present and consistent: hydro + asperity
    loads make the load (the asperity force is nearly parallel to the film force near h_min, so the
    sum of magnitudes exceeds the load by < 1 %), power = |M| omega, h_min/sigma by definition."""
    proc = run_cli(
        "bearing", *_replace(GOOD, "--speed", "30"), *ROUGH, "--load", "500", "--json", "--mesh-size", "0.1"
    )
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    for key in (
        "asperity_load_N",
        "hydro_load_N",
        "friction_coefficient",
        "power_loss_W",
        "h_min_over_sigma",
    ):
        assert key in r
    assert r["asperity_load_N"] > 0.01 * r["load_N"]
    assert r["load_N"] <= r["asperity_load_N"] + r["hydro_load_N"] <= 1.01 * r["load_N"]
    assert r["power_loss_W"] == pytest.approx(abs(r["friction_torque_Nm"]) * 30 * 2 * math.pi / 60, rel=1e-9)
    assert r["h_min_over_sigma"] == pytest.approx(r["h_min_m"] / math.hypot(0.1e-6, 0.3e-6), rel=1e-9)
    assert r["friction_coefficient"] == pytest.approx(
        abs(r["friction_torque_Nm"]) / (0.01 * r["load_N"]), rel=1e-9
    )


@pytest.mark.serial
def test_stribeck_writes_netcdf_and_png(tempdir):
    import xarray as xr

    proc = run_cli(
        "stribeck",
        *_replace(GOOD, "--speed", None),
        *ROUGH,
        "--load",
        "500",
        "--points",
        "4",
        "--speed-min",
        "10",
        "--speed-max",
        "5000",
        "--mesh-size",
        "0.1",
        "--output",
        str(tempdir),
        "--json",
    )
    assert proc.returncode == 0, proc.stderr
    with xr.open_dataset(tempdir / "stribeck.nc") as ds:
        assert ds.sizes["speed"] == 4
        assert ds.friction_coefficient.attrs["units"] == "1"
        assert np.all(np.isfinite(ds.friction_coefficient))
    assert (tempdir / "stribeck.png").stat().st_size > 10_000


@pytest.mark.serial
def test_oil_grade_and_temperature_give_the_viscosity(tempdir):
    """--grade 5W-30 --temperature 90 reports the data sheet's viscosity at 90 C (solver.oil) and
    carries the same load as --viscosity with that value (the film sees only mu: 1e-9)."""
    from solver.oil import oil_from_grade

    sheet = oil_from_grade("5W-30")
    mu = sheet.kinematic_viscosity(90.0) * 1e-6 * sheet.density(90.0)
    plain = _replace(GOOD, "--viscosity", None) + ["--eccentricity", "0.6", "--json", "--mesh-size", "0.2"]
    by_grade = json.loads(run_cli("bearing", *plain, "--grade", "5W-30", "--temperature", "90").stdout)
    by_value = json.loads(run_cli("bearing", *plain, "--viscosity", repr(mu)).stdout)
    assert by_grade["viscosity_Pa_s"] == pytest.approx(mu, rel=1e-12) and by_grade["temperature_C"] == 90.0
    assert by_grade["load_N"] == pytest.approx(by_value["load_N"], rel=1e-9)


@pytest.mark.serial
def test_elastic_bushing_reports_its_deformation(tempdir):
    """--elastic winkler: the JSON has max_deformation_m, positive (the bushing opens under the film)
    and equal to k p_max for the Winkler law with the bushing's default bronze (1e-6: the peak
    pressure and the largest deformation sit at the same node of a smooth film)."""
    args = GOOD + [
        "--eccentricity",
        "0.9",
        "--inlet",
        "none",
        "--elastic",
        "winkler",
        "--bushing-thickness",
        "1.5e-3",
        "--json",
        "--mesh-size",
        "0.15",
    ]
    report = json.loads(run_cli("bearing", *args).stdout)
    t, E, nu = 1.5e-3, 115e9, 0.33
    k = t * (1 + nu) * (1 - 2 * nu) / (E * (1 - nu))
    assert report["elastic"] == "winkler" and report["max_deformation_m"] > 0
    assert report["max_deformation_m"] == pytest.approx(k * report["p_max_Pa"], rel=1e-6)


@pytest.mark.serial
def test_a_film_that_cannot_be_solved_is_one_line_exit_1(tempdir):
    """A rigid piezoviscous film beyond q = 1/alpha has no bounded pressure (tests/film/
    test_piezoviscosity.py): the command says so in one line and exits 1, without a traceback."""
    args = _replace(_replace(GOOD, "--viscosity", "0.1"), "--speed", "76000")
    proc = run_cli(
        "bearing",
        *args,
        "--eccentricity",
        "0.95",
        "--piezoviscosity",
        "barus",
        "--pressure-viscosity",
        "2e-8",
        "--mesh-size",
        "0.2",
    )
    # (on a machine's first run the film's forms are compiled: one INFO line says so)
    lines = [line for line in proc.stderr.strip().splitlines() if not line.startswith("INFO ")]
    assert proc.returncode == 1, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("error:") and "elastic bushing" in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.serial
def test_jfo_cavitation_in_the_bearing_command():
    """--cavitation jfo under a load with a 30 deg axial groove at 2 bar: the steady film balances (supply
    flow = side flow to 1e-9, the consistent fluxes), carries the load (1e-6: the equilibrium's tolerance),
    reports its ruptured area, and needs less oil than the Reynolds condition claims to (which creates
    oil in its cavity: its side flow exceeds its supply); --degree 2 is one line, exit 2."""
    args = [
        *GOOD,
        "--load",
        "1000",
        "--groove-angle",
        "90",
        "--groove-arc",
        "30",
        "--groove-length",
        "0.01",
        "--supply-pressure",
        "2e5",
        "--cavitation-pressure=-5e4",
        "--json",
        "--mesh-size",
        "0.1",
    ]
    reports = {}
    for cavitation in ("reynolds", "jfo"):
        proc = run_cli("bearing", *args, "--cavitation", cavitation)
        assert proc.returncode == 0, proc.stderr
        reports[cavitation] = json.loads(proc.stdout)
    jfo, reynolds = reports["jfo"], reports["reynolds"]
    assert jfo["cavitation"] == "jfo" and jfo["load_N"] == pytest.approx(1000, rel=1e-6)
    assert 0.05 < jfo["cavitated_area_ratio"] < 0.95 and 0.05 < reynolds["cavitated_area_ratio"] < 0.95
    assert jfo["supply_flow_m3_per_s"] == pytest.approx(jfo["side_flow_m3_per_s"], rel=1e-9)
    assert reynolds["side_flow_m3_per_s"] > 1.01 * reynolds["supply_flow_m3_per_s"]
    proc = run_cli("bearing", *args, "--cavitation", "jfo", "--degree", "2")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0 and "serial P1 film" in proc.stderr


@pytest.mark.parametrize(
    "extra, inlet",
    [
        ([], "max-gap"),
        (["--elastic", "fe", "--bushing-thickness", "1.5e-3", "--eye-outer-radius", "0.017"], "none"),
        (["--circumferential-groove", "0.003"], "none"),
        (["--elastic", "winkler", "--bushing-thickness", "1.5e-3"], "max-gap"),
    ],
    ids=["rigid", "fe", "supply", "winkler"],
)
def test_the_default_inlet_is_the_one_the_model_allows(extra, inlet):
    """Without --inlet: max-gap where the film allows it, none where it does not (the FE eye, a supply);
    the film's rules then pass (the spec is checked before any mesh or compliance is built)."""
    import argparse

    from solver.cli.bearing import add_arguments, resolve_supply
    from solver.film_rules import check_film

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(GOOD + ["--eccentricity", "0.5", *extra])
    resolve_supply(args)
    assert args.inlet == inlet
    check_film(bushing=args.elastic, inlet=args.inlet, supply=args.supply != "none", quasi_static=True)
