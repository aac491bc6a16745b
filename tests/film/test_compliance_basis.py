"""The FE eye's layer basis (solver.film.bushings.FEEye, solver.film.compliance.Compliance.modes): the
bushing's local compression node by node plus modes of the remainder, against the closed-form layer and
the full compliance.

References: the compression of a layer bonded to a rigid housing (flat: t p / E, oedometric with nu;
curved: the plane-strain ring, solver.film.bushings.bonded_layer_coefficient), the full compliance G,
and the old eigen basis (72 modes of G) for the size of what the new basis corrects.
"""

from __future__ import annotations

import json
import logging
import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.case import load_case
from solver.errors import InputError
from solver.film.bearing import Kinematics
from solver.film.bushings import (
    FEEye,
    ModalCompliance,
    Superposed,
    WinklerLayer,
    bonded_layer_coefficient,
    winkler_coefficient,
)
from solver.film.compliance import EyeGeometry, eye_compliance, reference_loads
from solver.film.factory import make_film
from solver.film.spec import FilmSpec
from solver.film.types import Bearing
from tests.conftest import assert_one_line_error, run_cli

R, B, C, MU = 0.01, 0.02, 10e-6, 0.01
OMEGA = 3000 * 2 * math.pi / 60  # rad/s
# the small end of cases/reference-2000rpm-ehd (bronze bushing 1.5 mm, steel eye 17 mm, shank at 180 deg)
REFERENCE = EyeGeometry(bore_radius=R, width=B, bushing_thickness=1.5e-3, eye_outer_radius=0.017)


def _thin_layer(nu: float) -> EyeGeometry:
    """A 0.5 mm bushing of 5 GPa in a (nearly) rigid eye: the layer's width is 40 times its thickness."""
    return EyeGeometry(
        bore_radius=R,
        width=B,
        bushing_thickness=5e-4,
        eye_outer_radius=0.017,
        E_eye=1e15,
        E_bushing=5e9,
        nu_bushing=nu,
    )


def _film_solution(bushing, ecc: tuple[float, float]) -> tuple[np.ndarray, ...]:
    """(pressure [Pa], deformation [m], nodal forces [N], theta [rad], z [m]) at the film's nodes
    of the bearing R 10 mm, B 20 mm, c 10 um, 0.01 Pa s at 3000 rpm, inlet none, eccentricity ``ecc``."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none")
    spec = FilmSpec(bearing=bearing, omega_ref=OMEGA, bushing=bushing)
    with make_film(spec, MPI.COMM_SELF) as film:
        film.solve(Kinematics(ecc, (0.0, 0.0), OMEGA, 0.0))
        fields = film.fields_si()
        p = fields["pressure"].x.array.copy()
        w = fields["deformation"].x.array.copy() if "deformation" in fields else np.zeros_like(p)
        x = film.space.owned_coords
        areas = film.forms.operator.T_f @ np.ones(len(film.forms.operator.cells)) * R**2
    return p, w, areas * p, np.arctan2(x[:, 1], x[:, 0]), x[:, 2] * R


@pytest.mark.slow
@pytest.mark.serial
@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_thin_layer_limit(nu, tmp_path):
    """The issue's bearing (R 10 mm, B 20 mm, c 10 um, 3000 rpm, eccentricity 0.6, inlet none) on a 0.5 mm
    bushing of 5 GPa in a rigid eye: the largest deformation against the layer's compression at the
    pressure peak, k p_max. The layer is 40 thicknesses wide and the pressure peak about 10 thicknesses,
    so the layer is laterally constrained: the oedometric layer t (1+nu)(1-2nu)/(E(1-nu)) (t / E for
    nu = 0), curved: the plane-strain ring bonded to a rigid housing, 0.975 of it for nu = 0 and t = R/20,
    0.996 for nu = 0.3 (what the FE eye gives under a uniform pressure: 0.9753, test below).

    Measured on this coarse compliance (36 x 3 hats, 0.6 R elements; the default one gives the same to
    1e-4), layer basis: against the flat layer -2.50 % (nu 0, 0 modes: the layer alone is within the
    tolerance) and -0.40 % (nu 0.3, 5 modes: the free edges); against the ring 0.0 and +0.01 %.
    Asserted: 3 % against the flat layer (the issue's criterion), 0.5 % against the ring (the remainder's
    modes are truncated at 1 %, and the peak is a smooth load). The old basis (72 eigenmodes of G) on
    the same compliance misses by -10.1 % and -6.0 % (on the default one by +19 % and +21 %): it must
    miss by more than 3 %, so this test tells the bases apart."""
    geometry = _thin_layer(nu)
    compliance = eye_compliance(geometry, n_theta=36, n_z=3, element_size=0.6 * R, cache_dir=tmp_path)
    flat = winkler_coefficient(geometry.bushing_thickness, geometry.E_bushing, nu)
    ring = bonded_layer_coefficient(geometry.bushing_thickness, geometry.E_bushing, nu, R)
    peaks = {}
    for basis, modes in (("layer", 0), ("eigen", 72)):
        p, w, *_ = _film_solution(
            FEEye(geometry, modes=modes, basis=basis).reduce(compliance), (0.0, -0.6 * C)
        )
        assert np.abs(w).max() > 0.05 * C  # the deformation matters to the film
        peaks[basis] = np.abs(w).max() / p.max()
    assert peaks["layer"] / flat - 1 == pytest.approx(0.0, abs=0.03)
    assert peaks["layer"] / ring - 1 == pytest.approx(0.0, abs=5e-3)
    assert abs(peaks["eigen"] / flat - 1) > 0.03


@pytest.fixture(scope="module")
def reference_compliance(tmp_path_factory):
    """The reference small end's compliance at the default grid and element size (10 to 60 s)."""
    return eye_compliance(REFERENCE, cache_dir=tmp_path_factory.mktemp("compliance"))


@pytest.mark.slow
@pytest.mark.serial
def test_reference_eye_against_the_full_compliance(reference_compliance, caplog):
    """The reference eye in the layer basis at a tolerance of 1 % against the full compliance G,
    on the hat grid (where G is exact): the displacement (D + Psi_m Lam_m Psi_m^T) f against G f (max
    norm, relative) under the reference loads (uniform, 30 deg bumps opposite the shank and beside it)
    and under a film's pressure field (the issue's bearing at eccentricity 0.9, the pressure peak
    opposite the shank: f = T^T F of its nodal forces). Measured: 40 modes; 0.83/0.98/0.53 % and 0.32 %
    (the old basis, 72 eigenmodes of G: 0.33/1.51/0.79 % and 0.26 %: this bushing is stiff and the old
    basis was adequate here; what it missed is the thin layer's, test above). Asserted: 2 % for all (the
    issue's criterion) and the tolerance for the reference loads; the modes and the errors are in the
    log."""
    c = reference_compliance
    with caplog.at_level(logging.INFO, logger="solver.film.bushings"):
        bushing = FEEye(REFERENCE, modes=0, tolerance=0.01, basis="layer").reduce(c)
    layer, modal = bushing.parts
    assert isinstance(layer, WinklerLayer) and isinstance(modal, ModalCompliance)
    assert f"layer basis: the bushing layer node by node (k = {layer.coefficient:.4g} m/Pa) + " in caplog.text
    assert f"{modal.modes} modes (chosen for 1.00%); truncation error uniform " in caplog.text
    _, _, F, theta, z = _film_solution(None, (0.9 * C, 0.0))
    loads = np.column_stack([*reference_loads(c).values(), c.interpolation(theta, z).T @ F])
    errors = c.truncation_errors(loads, layer.coefficient)[modal.modes]
    assert np.all(errors < 0.02), errors
    assert np.all(errors[:3] <= 0.01)  # the tolerance the modes were chosen for


@pytest.mark.serial
def test_layer_basis_with_every_mode_is_the_local_law_plus_the_remainder(coarse_eye):
    """With every mode of the remainder kept, the solved deformation at the film's nodes is the layer's
    k p node by node plus T (G - D) T^T F (D the layer's image on the hats, T the interpolation, F the
    nodal forces of the solved pressure): checks the superposition of the two bushings in the coupled
    Newton and their scalings, to the VI tolerance (1e-8 of max w)."""
    geometry = coarse_eye.geometry
    layer = FEEye(geometry, basis="layer").layer
    k = layer.coefficient
    bushing = Superposed([layer, ModalCompliance(coarse_eye, coarse_eye.size, k)])
    p, w, F, theta, z = _film_solution(bushing, (0.0, -0.9 * C))
    T = coarse_eye.interpolation(theta, z)
    expected = k * p + T @ ((coarse_eye.matrix - coarse_eye.local_part(k)) @ (T.T @ F))
    assert np.max(np.abs(w)) > 0.05 * C
    assert np.abs(w - expected).max() <= 1e-8 * np.abs(expected).max()


def test_local_part_is_the_image_of_the_local_law(coarse_eye):
    """D = k A^-1 M A^-1: symmetric, and a uniform pressure (f = A p, A the row sums of M) gives k p at
    every hat (exact up to rounding, 1e-12). M's row sums are the hat areas on the exact cylinder: the
    areas on the mesh's bore (coarse, second order) agree within 1.5 % (measured 1.1 %), and their sum,
    the bore's half area pi R B, within 1e-3 (measured 2e-4)."""
    c = coarse_eye
    M = c.hat_mass()
    areas = M.sum(axis=1)
    D = c.local_part(2.0e-15)
    np.testing.assert_allclose(D, D.T, rtol=0, atol=1e-12 * np.abs(D).max())
    np.testing.assert_allclose(D @ (areas * 1e6), 2.0e-15 * 1e6, rtol=1e-12)
    assert np.abs(c.areas / areas - 1).max() < 0.015
    assert areas.sum() == pytest.approx(math.pi * R * c.geometry.width, rel=1e-12)
    assert c.areas.sum() == pytest.approx(areas.sum(), rel=1e-3)


def test_bonded_ring_tends_to_the_flat_layer():
    """The bonded ring's coefficient is the flat (oedometric) layer's when t / R -> 0 (first order in
    t / R: relative difference below t / R), and for nu = 0 its closed form t (2 + t/R) / (E (2 + 2 t/R +
    (t/R)^2)) exactly."""
    E = 5e9
    for nu in (0.0, 0.3, 0.45):
        for t in (1e-6, 1e-4, 1e-3):
            ratio = bonded_layer_coefficient(t, E, nu, R) / winkler_coefficient(t, E, nu)
            assert abs(ratio - 1) < t / R
    e = 0.05
    assert bonded_layer_coefficient(e * R, E, 0.0, R) == pytest.approx(
        e * R * (2 + e) / (E * (2 + 2 * e + e * e)), rel=1e-12
    )
    assert WinklerLayer(5e-4, E, 0.3).coefficient == winkler_coefficient(5e-4, E, 0.3)


def test_eigen_basis_reproduces_the_old_bushing(coarse_eye):
    """``basis = "eigen"`` with 12 modes is the bushing before the layer basis, ModalCompliance(G, 12):
    the same shapes and gains, bit for bit."""
    from solver.film.scaling import FilmScales

    old = ModalCompliance(coarse_eye, 12)
    new = FEEye(coarse_eye.geometry, modes=12, basis="eigen").reduce(coarse_eye)
    assert isinstance(new, ModalCompliance)
    theta, z = np.linspace(0, 6, 50), np.linspace(0, B / 2, 50)
    scales = FilmScales(radius=R, clearance=C, viscosity=MU, omega_ref=OMEGA)
    for a, b in zip(old.shapes(theta, z, np.ones(50), scales), new.shapes(theta, z, np.ones(50), scales)):
        np.testing.assert_array_equal(getattr(a, "toarray", lambda: a)(), getattr(b, "toarray", lambda: b)())


@pytest.mark.parametrize(
    "text, message",
    [
        (
            'compliance_basis = "modal"',
            r"^small_end.compliance_basis = 'modal' is out of range \(allowed: 'eigen', 'layer'",
        ),
        (
            "compliance_tolerance = 0",
            r"^small_end.compliance_tolerance = 0 is out of range \(allowed: \(0, 1\)\)$",
        ),
        (
            "compliance_modes = -1",
            r"^small_end.compliance_modes = -1 is out of range \(allowed: an integer in \[0",
        ),
        (  # more modes than the default grid's 72 x 5 nodes
            "compliance_modes = 400",
            r"^small_end.compliance_modes = 400 is out of range \(allowed: \[0, 360\]: at most the grid's",
        ),
        (
            "compliance_grid_z = 1",
            r"^small_end.compliance_grid_z = 1 is out of range \(allowed: an integer in \[2, 65\]",
        ),
    ],
)
def test_bad_basis_keys_give_one_line_errors(tmp_path, text, message):
    """The basis keys are checked when the case is read: one line naming the key and its range."""
    (tmp_path / "case.toml").write_text(f'[small_end]\nelastic = "fe"\n{text}\n')
    with pytest.raises(InputError, match=message) as caught:
        load_case(tmp_path)
    assert "\n" not in str(caught.value)


def test_case_keys(tmp_path):
    """A case that states nothing gets the eigen basis with its modes chosen for a truncation error of 0.1 %
    (compliance_modes = 0: the elastic engine cases' converged choice, docs/verification.md); one that
    states the layer basis and another tolerance gets those."""
    (tmp_path / "case.toml").write_text('[small_end]\nelastic = "fe"\n')
    se = load_case(tmp_path).small_end
    assert (se.compliance_modes, se.compliance_basis, se.compliance_tolerance) == (0, "eigen", 0.001)
    (tmp_path / "case.toml").write_text(
        '[small_end]\nelastic = "fe"\ncompliance_modes = 0\ncompliance_basis = "layer"\n'
        "compliance_tolerance = 0.02\n"
    )
    se = load_case(tmp_path).small_end
    assert (se.compliance_modes, se.compliance_basis, se.compliance_tolerance) == (0, "layer", 0.02)
    assert (se.compliance_grid_theta, se.compliance_grid_z) == (72, 5)  # the grid before the keys
    (tmp_path / "case.toml").write_text(
        '[small_end]\nelastic = "fe"\ncompliance_grid_theta = 144\ncompliance_grid_z = 9\n'
        "compliance_modes = 1296\n"
    )
    se = load_case(tmp_path).small_end
    assert (se.compliance_grid_theta, se.compliance_grid_z, se.compliance_modes) == (144, 9, 1296)


#: the new-user small end (R 12 mm, B 22 mm, c 12 um, 5W-30 at 110 C, 750 rpm; bushing 1.5 mm, eye 19 mm)
NEW_USER_EYE = [
    *("--radius", "0.012", "--width", "0.022", "--clearance", "12e-6", "--grade", "5W-30"),
    *("--temperature", "110", "--speed", "750", "--elastic", "fe", "--bushing-thickness", "1.5e-3"),
    *("--eye-outer-radius", "0.019", "--inlet", "none", "--json"),
]


def test_bad_compliance_grid_on_the_command_line_is_one_line():
    """--compliance-grid outside [12, 720] x [2, 65], or more modes than its nodes: one line, exit 2."""
    base = [*NEW_USER_EYE, "--eccentricity", "0.5"]
    assert_one_line_error(run_cli("bearing", *base, "--compliance-grid", "8", "5"), "--compliance-grid = 8 5")
    assert_one_line_error(
        run_cli("bearing", *base, "--compliance-grid", "36", "3", "--compliance-modes", "109"),
        "--compliance-modes = 109",
        "[0, 108]",
    )


@pytest.mark.serial
@pytest.mark.slow
def test_the_compliance_grid_converges_at_second_order_under_a_moderate_load():
    """The new-user small end at eccentricity 0.9 (about 0.92 kN: the film smooth, far from the edges),
    every mode of the compliance kept, on the grids 36 x 3, 72 x 5 (the default) and 144 x 9 (each
    spacing about halved): the load converges, the successive differences shrinking by at least 3 (the
    hats are bilinear, second order: 4; measured 4.12 N, then 0.68 N: 6.1), and the default grid is
    within 0.2 % of the finest (measured 0.07 %). Under the 20 kN load, where the film's minimum sits at
    the bushing's edges, the grid is not converged (docs/verification.md)."""
    loads = []
    for n_theta, n_z in ((36, 3), (72, 5), (144, 9)):
        proc = run_cli(
            "bearing",
            *NEW_USER_EYE,
            "--eccentricity",
            "0.9",
            "--compliance-grid",
            str(n_theta),
            str(n_z),
            "--compliance-modes",
            str(n_theta * n_z),
        )
        assert proc.returncode == 0, proc.stderr
        loads.append(json.loads(proc.stdout)["load_N"])
    first, second = abs(loads[0] - loads[1]), abs(loads[1] - loads[2])
    assert first / second >= 3.0, loads
    assert abs(loads[1] - loads[2]) <= 2e-3 * loads[2], loads
