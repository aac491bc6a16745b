"""Patir-Cheng flow/shear-stress factors and the Wu-Zheng contact factor against the published formulas.

The reference values are computed here from the formulas as printed (transcribed independently of
solver.film.flow_factors): DESIGN.md 3.2/3.4 for gamma = 1 (Patir & Cheng 1978 Table 1, 1979 Tables 1-3;
Wu & Zheng 1989), Patir & Cheng 1978 Table 1 for gamma = 3 and 1/3; Phi_f against adaptive
quadrature of its definition, the mean of h/h_T over the gap distribution (35/96)(1 - d^2/9)^3 on
|d| <= 3, cut off at h_T = 3 eps* sigma with eps* = 1/300 (Patir & Cheng 1979).
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from scipy.integrate import quad

from solver.film import flow_factors as ff

H = np.array([0.5, 0.8, 1.0, 1.5, 2.0, 3.0, 4.5, 5.0, 6.0, 8.0])


def test_isotropic_pressure_flow():
    """phi_x = phi_y = 1 - 0.90 exp(-0.56 H); rounding-level agreement (1e-12)."""
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6)
    ref = 1 - 0.90 * np.exp(-0.56 * H)
    assert np.allclose(pc.pressure_flow_x(H), ref, rtol=1e-12)
    assert np.allclose(pc.pressure_flow_y(H), ref, rtol=1e-12)


@pytest.mark.parametrize(
    "gamma, ref",
    [
        (3.0, lambda h: 1 + 0.225 * h**-1.5),  # gamma > 1: 1 + C H^-r
        (1 / 3, lambda h: 1 - 1.18 * np.exp(-0.42 * h)),  # gamma < 1
    ],
)
def test_anisotropic_pressure_flow_and_symmetry(gamma, ref):
    """Patir & Cheng 1978 Table 1 at H >= 1 (inside both fits); phi_y(H, gamma) = phi_x(H, 1/gamma)."""
    h = H[H >= 1.0]
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6, gamma=gamma)
    assert np.allclose(pc.pressure_flow_x(h), ref(h), rtol=1e-12)
    other = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6, gamma=1 / gamma)
    assert np.allclose(pc.pressure_flow_y(h), other.pressure_flow_x(h), rtol=1e-12)


def test_shear_flow_factor():
    """Phi_s = 1.899 H^0.98 exp(-0.92 H + 0.05 H^2) (H <= 5), 1.126 exp(-0.25 H) (H > 5);
    phi_s = (sigma1^2 - sigma2^2)/sigma^2 Phi_s with 1 = bushing."""
    ref = np.where(H <= 5, 1.899 * H**0.98 * np.exp(-0.92 * H + 0.05 * H**2), 1.126 * np.exp(-0.25 * H))
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6)
    assert np.allclose(ff.shear_flow_function(H), ref, rtol=1e-12)
    assert np.allclose(pc.shear_flow(H), (0.09 - 0.01) / 0.10 * ref, rtol=1e-12)


def test_contact_factor():
    """phi_c = exp(-0.6912 + 0.782 H - 0.304 H^2 + 0.0401 H^3) for H < 3, else 1; its jump at H = 3
    is the fit's own (1.5e-3)."""
    ref = np.where(H < 3, np.exp(-0.6912 + 0.782 * H - 0.304 * H**2 + 0.0401 * H**3), 1.0)
    assert np.allclose(ff.contact_factor(H), ref, rtol=1e-12)
    assert abs(ff.contact_factor(np.array([3 - 1e-9]))[0] - 1.0) < 2e-3


def test_shear_stress_factors():
    """Phi_fs = 11.1 H^2.31 exp(-2.38 H + 0.11 H^2) (H < 7, else 0), Phi_fp = 1 - 1.40 exp(-0.66 H)."""
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.0)  # variance ratio +1
    _, Phi_fs, Phi_fp = pc.shear_stress_factors(H)
    assert np.allclose(
        Phi_fs, np.where(H < 7, 11.1 * H**2.31 * np.exp(-2.38 * H + 0.11 * H**2), 0.0), rtol=1e-12
    )
    assert np.allclose(Phi_fp, 1 - 1.40 * np.exp(-0.66 * H), rtol=1e-12)


@pytest.mark.parametrize("h", [0.7, 1.0, 2.0, 2.9, 3.1, 5.0, 10.0, 29.0, 31.0, 100.0])
def test_phi_f_equals_its_definition(h):
    """Closed form (Patir & Cheng 1979) vs quadrature of the definition. Above H = 3 the closed form
    is exact: 1e-6 (quadrature tolerance 1e-12, the series above H = 30 truncates at < 1e-8). Below
    H = 3 the published form keeps the cut-off eps* only in the logarithm and drops its O(eps*) =
    O(3e-3) polynomial terms: 3e-3."""
    f = lambda d: 35 / 96 * (1 - d * d / 9) ** 3  # noqa: E731
    low = max(-3.0, -h + 3 / 300)
    ref = quad(lambda d: h / (h + d) * f(d), low, 3.0, epsabs=0, epsrel=1e-12, limit=200)[0]
    assert ff.shear_stress_phi_f(np.array([h]))[0] == pytest.approx(ref, rel=1e-6 if h > 3 else 3e-3)


def test_factors_below_range_are_held_and_smooth_limit():
    """Below H = 0.5 every factor but phi_s equals its value at 0.5 (documented hold); phi_s is held
    below 0.3 (test below); at H = 1e4 they are the smooth values to 1e-8."""
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6)
    low, edge, big = np.array([0.1, 0.3]), np.array([0.5, 0.5]), np.array([1e4])
    for law in (pc.pressure_flow_x, pc.pressure_flow_y):
        assert np.array_equal(law(low), law(edge))
    for a, b in zip(pc.shear_stress_factors(low), pc.shear_stress_factors(edge)):
        assert np.array_equal(a, b)
    smooth = [
        pc.pressure_flow_x(big),
        pc.pressure_flow_y(big),
        pc.shear_flow(big),
        pc.contact_factor(big),
        *pc.shear_stress_factors(big),
    ]
    assert np.allclose([s[0] for s in smooth], [1, 1, 0, 1, 1, 0, 1], atol=1e-8)


def _shear_flow_slope(H, gamma):
    return ff._interpolated(ff._shear_flow_slope_tabulated, gamma, np.asarray(H, float), np)


@pytest.mark.parametrize("gamma", [1 / 9, 1.0, 2.0, 9.0])
def test_shear_flow_factor_is_c1_below_its_fit_and_its_slope_is_its_derivative(gamma):
    """Phi_s below the fits' range (H < H_MIN = 0.5): its slope falls linearly to zero over
    SHEAR_FLOW_HOLD_WIDTH, then it is held, so value and slope are continuous (a step in the slope made
    the coupled Newton cycle where a loaded film crosses H_MIN). Checked: the fit is unchanged at and
    above H_MIN (exactly); the slope is continuous at both ends of the ramp (1e-6 relative, 1e-7
    absolute: the ramp's slope changes by ~3e-9 over the 1e-9 jump); the ramp loses slope x width / 2
    (exact for a linear slope: 1e-12); and the slope function equals the central difference of the law
    away from the ramp's ends (1e-6: the difference's truncation error, step^2 times the third
    derivative, ~1e-10 at step 1e-5)."""
    H0, w = ff.H_MIN, ff.SHEAR_FLOW_HOLD_WIDTH
    law = lambda H: ff.shear_flow_function(np.asarray(H, float), gamma)  # noqa: E731
    slope = lambda H: _shear_flow_slope(H, gamma)  # noqa: E731
    if gamma == 1.0:  # the Patir-Cheng fit itself at and above H_MIN: A1 H^a1 exp(-a2 H + a3 H^2)
        A1, a1, a2, a3, _ = ff.SHEAR_FLOW[1.0]
        H = np.array([0.5, 0.7, 2.0, 4.9])
        assert np.array_equal(law(H), A1 * H**a1 * np.exp(-a2 * H + a3 * H**2))
    d = 1e-9
    for edge in (H0, H0 - w):
        assert slope([edge - d])[0] == pytest.approx(slope([edge + d])[0], rel=1e-6, abs=1e-7)
        assert law([edge - d])[0] == pytest.approx(law([edge + d])[0], rel=1e-8)
    assert slope([0.0, 0.2, H0 - w - 1e-3]).tolist() == [0.0, 0.0, 0.0]
    assert law([0.0])[0] == pytest.approx(law([H0])[0] - slope([H0])[0] * w / 2, rel=1e-12)
    H = np.concatenate([np.linspace(0.0512, 0.9512, 37), [1.5, 3.0, 4.99, 5.01, 7.0]])
    step = 1e-5
    central = (law(H + step) - law(H - step)) / (2 * step)
    assert np.allclose(slope(H), central, rtol=1e-6, atol=1e-9)


@pytest.mark.serial
def test_ufl_expressions_equal_numpy():
    """The same law evaluated by UFL (integrated at constant H over a unit square) and by numpy:
    equal to quadrature round-off (1e-12)."""
    mesh = dmesh.create_unit_square(MPI.COMM_SELF, 2, 2)
    pc = ff.PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6, gamma=2.0)
    for h in (0.3, 1.7, 4.2, 6.5, 40.0):
        Hc = fem.Constant(mesh, h)
        laws = [
            pc.pressure_flow_x,
            pc.pressure_flow_y,
            pc.shear_flow,
            pc.contact_factor,
            lambda x, mod=np: pc.shear_stress_factors(x, mod)[0],
            lambda x, mod=np: pc.shear_stress_factors(x, mod)[1],
            lambda x, mod=np: pc.shear_stress_factors(x, mod)[2],
        ]
        for law in laws:
            value = fem.assemble_scalar(fem.form(law(Hc, mod=ufl) * ufl.dx))
            assert value == pytest.approx(float(law(np.array([h]))[0]), rel=1e-12, abs=1e-14)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(sigma_bushing=-1e-7, sigma_journal=1e-7), "sigma_bushing"),
        (dict(sigma_bushing=0.0, sigma_journal=0.0), "sigma"),
        (dict(sigma_bushing=1e-7, sigma_journal=1e-7, gamma=0.0), "peklenik_gamma"),
        (dict(sigma_bushing=1e-7, sigma_journal=1e-7, gamma=20.0), "peklenik_gamma"),
    ],
)
def test_bad_roughness_input(kwargs, name):
    from solver.errors import InputError

    with pytest.raises(InputError, match=name):
        ff.PatirCheng(**kwargs)
