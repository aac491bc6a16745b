"""Mixed lubrication in the film model: smooth limit, uniform asperity contact, Stribeck curve, trends.

References: the smooth solver itself for the limit H -> infinity (the issue's requirement that the
smooth equation comes back); Greenwood & Tripp's closed expressions for a uniform gap; Petroff's
law f = 2 pi^2 (eta N / P)(R / c) for a lightly loaded fast journal; the asperity friction
coefficient for a journal that barely turns.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.cli.stribeck import sweep
from solver.film.bearing import Bearing, FilmModel, Kinematics, equilibrium
from solver.film.surface import Surface

R, B, C, MU = 0.01, 0.02, 10e-6, 0.01


def _outputs(r):
    return np.array([*r.force, r.torque_journal, r.torque_bushing, r.p_max, r.side_flow])


@pytest.mark.serial
def test_smooth_limit_equals_smooth_solver():
    """sigma = 1e-13 m (H > 1e7 everywhere): every factor is at its smooth value and asperity contact
    vanishes, so forces, torques, p_max and side flow equal the smooth solver's to 1e-6."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU)
    kin = Kinematics((0.4 * C, -0.5 * C), (0.1 * C * 300, 0.2 * C * 300), 300.0, -50.0)
    surface = Surface(sigma_journal=0.5e-13, sigma_bushing=1e-13)
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=300.0, mesh_size=0.1) as smooth:
        ref = _outputs(smooth.solve(kin))
    with FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=300.0,
        mesh_size=0.1,
        roughness=surface.roughness(),
        contact=surface.contact(),
    ) as rough:
        result = rough.solve(kin)
    assert np.allclose(_outputs(result), ref, rtol=1e-6, atol=0)
    assert result.asperity_load == 0.0


@pytest.mark.serial
def test_half_film_equals_the_whole_film():
    """The film is solved on the half z >= 0 (symmetry about the mid-plane). The same state on a mesh
    of the whole width, mixed lubrication with asperity contact, squeeze and rotation: film and
    asperity force, both torques, p_max, contact area and side flow agree within 1 % (two different
    meshes of 0.05 R: each output is within ~0.3 % of its converged value, bench/film_mesh_convergence.py;
    a wrong factor of the half mesh's integrals would be 100 % off)."""
    bearing = Bearing(radius=R, width=B, clearance=C, viscosity=MU)
    kin = Kinematics((0.85 * C, -0.4 * C), (0.001 * C * 300, -0.002 * C * 300), 200.0, -50.0)
    surface = Surface(sigma_journal=0.3e-6, sigma_bushing=0.3e-6)
    results = []
    for half in (True, False):
        with FilmModel(
            bearing,
            MPI.COMM_SELF,
            omega_ref=300.0,
            mesh_size=0.05,
            roughness=surface.roughness(),
            contact=surface.contact(),
            half=half,
        ) as model:
            results.append(model.solve(kin))
    half_film, whole = results
    assert whole.asperity_load > 1e-3 * whole.load  # contact present: its integrals are checked too
    for name in (
        "hydro_load",
        "asperity_load",
        "torque_journal",
        "torque_bushing",
        "p_max",
        "contact_area_ratio",
        "side_flow",
    ):
        assert getattr(half_film, name) == pytest.approx(getattr(whole, name), rel=0.01), name


@pytest.mark.serial
def test_uniform_contact_of_a_concentric_pin():
    """Concentric pin, c = 0.5 um, sigma = 0.316 um: H = 1.58 < 3 everywhere. Then
    integral p_c dA = p_c(H) 2 pi R B, the asperity force vector vanishes, the asperity friction torque
    on the pin is mu_f p_c(H) 2 pi R B R (along the bushing's motion), and
    A_c/A = pi^2 (eta beta sigma)^2 F_2(H).
    Tolerance 1e-3: the faceted mesh's area is 2e-4 low at h = 0.05 R; F by quadrature (test_contact)."""
    c = 0.5e-6
    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    gt = surface.contact()
    Hs = c / gt.sigma
    omega = 100.0
    bearing = Bearing(radius=R, width=B, clearance=c, viscosity=MU)
    with FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=omega,
        mesh_size=0.05,
        roughness=surface.roughness(),
        contact=gt,
        slip_regularisation=1e-9,
    ) as model:
        r = model.solve(Kinematics((0.0, 0.0), (0.0, 0.0), omega, 0.0))
    area = 2 * math.pi * R * B
    from solver.film.contact import gt_integral

    p_c = gt.K * gt.modulus * gt_integral(2.5, Hs)
    assert Hs < 3
    assert r.asperity_normal_force == pytest.approx(p_c * area, rel=1e-3)
    assert r.asperity_load < 1e-6 * p_c * area
    # the journal turns counter-clockwise, so the (fixed) bushing drags it clockwise
    assert r.asperity_torque_journal == pytest.approx(-gt.friction * p_c * area * R, rel=1e-3)
    assert r.contact_area_ratio == pytest.approx(
        math.pi**2 * gt.eta_beta_sigma**2 * gt_integral(2.0, Hs), rel=1e-3
    )
    assert r.h_min_over_sigma == pytest.approx(Hs, rel=1e-12)


@pytest.mark.serial
def test_stribeck_curve_regimes():
    """Load 500 N (2.5 MPa on the projected area), speeds 0.01-20000 rpm:
    - at the highest speed the friction coefficient is Petroff's within 5 % (eps ~ 0.05 there, and
      Petroff's law neglects the pressure-driven shear that a small eccentricity adds);
    - at the lowest speed it is the asperity friction coefficient within 3 % (the curvature of the
      contact patch adds (integral p_c dA)/W - 1 ~ 1 %, viscous shear < 1e-4);
    - the minimum lies strictly inside the sweep and is below a tenth of both ends."""
    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    speeds = np.geomspace(0.01, 20000, 9)
    load = 500.0
    with FilmModel(
        Bearing(radius=R, width=B, clearance=C, viscosity=MU),
        MPI.COMM_SELF,
        omega_ref=2000.0,
        roughness=surface.roughness(),
        contact=surface.contact(),
        slip_regularisation=1e-3 * R * speeds[0] * 2 * math.pi / 60,
    ) as model:
        data = sweep(model, load, speeds, R)
    f = data["friction_coefficient"]
    N = speeds[-1] / 60
    petroff = 2 * math.pi**2 * MU * N / (load / (2 * R * B)) * R / C
    assert f[-1] == pytest.approx(petroff, rel=0.05)
    assert f[0] == pytest.approx(surface.asperity_friction, rel=0.03)
    i = int(np.argmin(f))
    assert 0 < i < len(f) - 1
    assert f[i] < 0.1 * min(f[0], f[-1])


@pytest.mark.serial
def test_rougher_surfaces_carry_more_by_asperities():
    """Same load and speed in the mixed regime: the asperity share grows with the roughness, and the
    minimum film h_min/sigma falls."""
    shares, H = [], []
    for scale in (1.0, 1.5, 2.0):
        surface = Surface(sigma_journal=0.1e-6 * scale, sigma_bushing=0.3e-6 * scale)
        with FilmModel(
            Bearing(radius=R, width=B, clearance=C, viscosity=MU),
            MPI.COMM_SELF,
            omega_ref=10.0,
            roughness=surface.roughness(),
            contact=surface.contact(),
        ) as model:
            eq = equilibrium(model, (0.0, -500.0), omega_journal=30 * 2 * math.pi / 60)
        shares.append(eq.result.asperity_load / eq.result.load)
        H.append(eq.result.h_min_over_sigma)
    assert shares[0] < shares[1] < shares[2]
    assert H[0] > H[1] > H[2]
