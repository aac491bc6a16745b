"""The big end's finite-element eye (``big_end.elastic = "fe"``).

References:

- the small end's eye model (solver.film.compliance) built independently with the big eye's geometry
  written out here and its shank where the small end has it (180 deg), turned by half a turn: the big
  eye's clamp is toward the small end, 0 deg of the rod frame, the frame both films live in (the
  mechanism's attachment points give that direction);
- the clamp where it is expected: under a uniform bore pressure the bore moves least at the shank and
  most opposite it (a clamped ring; the Lame expansion of the free ring in between);
- the energy audit of a cycle with the FE big end (input work = dissipation + change of mechanical
  energy) and the deformation's size against the shell's ``t p / E`` and the eye's ``R p / E``;
- (the FE eye with the crankpin's hole, once refused: tests/study/test_big_end_eye_hole.py).
"""

from __future__ import annotations

import dataclasses
import math

from mpi4py import MPI

import numpy as np
import pytest
import xarray as xr

from solver.case import load_case
from solver.dynamics.engine import build_mechanism, engine_from_case
from solver.dynamics.joint import BIG_END_SHANK_ANGLE_DEG, DryContactJoint, big_eye_bushing
from solver.film.bushings import FEEye
from solver.study.simulation import run_case
from tests.conftest import energy_balance
from tests.study.test_big_end import make_case
from tests.study.test_big_end_history import _case

FE = 'joint = "mixed-fem"\nelastic = "fe"\n'


def test_the_rod_frame_points_from_the_big_end_to_the_small_end(tmp_path):
    """Both joints' bushing frame is the rod's: the small end's bushing centre seen from the big end's is
    along +x' (0 deg), where the big eye's shank is (the small end's, 180 deg, points back at the big
    end); exact (the attachment points are on the rod's axis)."""
    case = load_case(make_case(tmp_path / "frame", 'joint = "ideal"\n', FE))
    engine = engine_from_case(case)
    dry = DryContactJoint(radius=0.01, clearance=1e-5, stiffness=1e9)
    mechanism = build_mechanism(engine, small_end=dry, big_end=dry)
    assert mechanism.small_end.bushing_body == mechanism.big_end.bushing_body  # the rod
    d = np.subtract(mechanism.small_end.bushing_point, mechanism.big_end.bushing_point)
    assert d[0] == pytest.approx(engine.rod_length, rel=1e-15) and d[1] == 0.0
    assert math.degrees(math.atan2(d[1], d[0])) == BIG_END_SHANK_ANGLE_DEG == 0.0


@pytest.mark.serial
def test_the_big_eye_is_the_small_end_eye_turned_toward_the_small_end(tmp_path):
    """The big eye of ``[big_end]``'s keys is the eye written out here (crankpin radius 24 mm, width 20,
    shell 1.8 mm of [big_end_surface]'s moduli, eye 37 mm, steel, a 30 deg clamp at 0 deg; to rounding),
    and its compliance (coarse: 24 x 3 hats, 0.5 R elements, a few seconds) equals that of the same eye
    with the small end's shank (180 deg) turned by half a turn: the matrices within 1e-3 of their largest
    entry (the two meshes differ, gmsh does not mesh a turned eye as the turned mesh; measured 2.2e-4, while a
    clamp at the wrong end differs by O(1)). Under a uniform pressure the bore moves least at the shank
    (0 deg) and most opposite it (180 deg). The two eyes have different cache keys (the disk cache of the
    small end's and the big end's eyes cannot collide)."""
    from solver.film.compliance import EyeGeometry, cache_key, eye_compliance

    text = FE + "compliance_grid_theta = 24\ncompliance_grid_z = 3\ncompliance_modes = 12\n"
    case = load_case(make_case(tmp_path / "eye", 'joint = "ideal"\n', text))
    eye = big_eye_bushing(case)
    assert isinstance(eye, FEEye) and eye.grid == (24, 3) and eye.modes == 12
    surface = case.big_end_surface
    expected = EyeGeometry(
        bore_radius=0.024,
        width=0.020,
        bushing_thickness=1.8e-3,
        eye_outer_radius=0.037,
        E_eye=210e9,
        nu_eye=0.3,
        E_bushing=surface.E_bushing,
        nu_bushing=surface.nu_bushing,
        shank_angle_deg=0.0,
        shank_half_angle_deg=30.0,
    )
    # the TOML values times their unit scale: equal to rounding
    assert dataclasses.asdict(eye.geometry) == pytest.approx(dataclasses.asdict(expected), rel=1e-14, abs=0)
    small_ends = dataclasses.replace(expected, shank_angle_deg=180.0)

    R, n = 0.024, 24
    kwargs = {"n_theta": n, "n_z": 3, "element_size": 0.5 * R, "use_cache": False}
    big, turned = eye_compliance(eye.geometry, **kwargs), eye_compliance(small_ends, **kwargs)
    k, j = np.divmod(np.arange(big.size), n)
    half_turn = k * n + (j + n // 2) % n  # the node at theta + 180 deg
    G = turned.matrix[np.ix_(half_turn, half_turn)]
    error = np.abs(big.matrix - G).max() / np.abs(big.matrix).max()
    wrong = np.abs(big.matrix - turned.matrix).max() / np.abs(big.matrix).max()
    print(f"turned small-end eye: {error:.2g}; unturned {wrong:.2g}")
    assert error < 1e-3 and wrong > 0.1

    w = (big.matrix @ big.areas)[:n]  # mid-plane row, unit uniform pressure [m/Pa]
    assert np.argmin(w) == 0 and np.argmax(w) == n // 2

    keys = {cache_key(g, n, 3, 0.5 * R) for g in (eye.geometry, small_ends)}
    assert len(keys) == 2


@pytest.mark.slow
@pytest.mark.serial
def test_a_cycle_with_the_fe_big_end_closes_its_energy(tmp_path, monkeypatch):
    """The reference engine with the FE big end (small end ideal, film 0.2 R, 5 deg outputs, one cycle;
    the eye on 36 x 3 hats with 24 modes, its compliance built into a fresh cache): the energy audit
    within 1 % of the dissipated energy (the audit of solver.study.energy, as the Winkler big end's);
    the eye deforms, by more than half the shell's compression k p_max (k: the bonded layer's
    t (1 + nu)(1 - 2 nu) / (E (1 - nu)), the eye only adds to it) and less than ten times the free
    steel ring's Lame expansion under p_max everywhere (a local load bends the clamped ring more than a
    uniform one expands it, a few times: the bound is the order); its largest opening over the cycle is
    on the cap's half (cos < 0), away from the firing (outside 300-480 deg): the clamp holds the shank's
    side, where the firing load presses."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    grid = "compliance_grid_theta = 36\ncompliance_grid_z = 3\ncompliance_modes = 24\n"
    case_dir = _case(tmp_path / "fe", 'elastic = "fe"\n' + grid, 1, jfo=False)
    summary = run_case(case_dir, MPI.COMM_SELF)
    with xr.open_dataset(summary.results) as ds:
        ds = ds.load()
    assert ds.attrs["big_end.elastic"] == "fe"
    assert any((tmp_path / "cache" / "tribo-solver" / "compliance").glob("*.npz"))
    audit = energy_balance(ds)[0]
    w, p = ds.big_end_deformation_max.values, ds.big_end_p_max.values
    surface, be = load_case(case_dir).big_end_surface, load_case(case_dir).big_end
    E, nu, t = surface.E_bushing, surface.nu_bushing, be.bushing_thickness
    k = t * (1 + nu) * (1 - 2 * nu) / (E * (1 - nu))
    a, b = be.radius + t, be.eye_outer_radius
    lame = a / be.E_eye * ((b * b + a * a) / (b * b - a * a) + be.nu_eye)
    i = int(np.nanargmax(p))
    print(
        f"audit {audit:.3g}; at p_max {p[i] / 1e6:.3g} MPa: deformation {w[i] * 1e6:.3g} um, "
        f"shell {k * p[i] * 1e6:.3g} um, ring {lame * p[i] * 1e6:.3g} um; largest {np.nanmax(w) * 1e6:.3g} um"
    )
    assert abs(audit) < 0.01
    assert 0.5 * k * p[i] < w[i] < 10 * (k + lame) * p[i]
    # the cycle's largest opening is on the cap's half, under the inertia pull near the gas exchange's
    # TDC: the cap is free, the shank's side (the firing load's) clamped
    j = int(np.nanargmax(w))
    angle, crank = float(ds.big_end_deformation_max_angle[j]), float(ds.crank_angle[j])
    print(f"largest opening {w[j] * 1e6:.3g} um at {math.degrees(angle):.0f} deg (rod frame), {crank:g} deg")
    assert math.cos(angle) < 0 and not 300 < crank < 480
