"""The bore's edge relief (solver.film.relief): the profile, the Reynolds operator that carries it, the
film's fast numpy paths with it, and its effect on the load against an independent computation.

- The profile: h_r = d ((|z| - (B/2 - l)) / l)^n at the points where its formula is known by hand (0 where
  it starts, d at the edge, d/4 (parabolic) or d/2 (linear) half way), exact to round-off.
- The operator: a manufactured solution on a film with H = 1 - eps cos(theta) + H_r(z) (the source
  derived with sympy from the formula, the relief's terms H_r and dH_r/dz written out by hand): the P1
  error falls as h^2 in L2 and h in H1, as without relief (test_reynolds_mms.py); a film whose forms did
  not carry the relief would not converge to it.
- The fast paths (the midpoint operator's numpy coefficients, the pressure torque, the contact cells, the
  elastic film's rigid gap) against the UFL forms, as tests/film/test_film_tensors.py does without relief.
- The load: on a short bearing Ocvirk's theory gives the pressure for any h(theta, z) by one integral over
  z, p = -6 mu U dh0/dx int_z^{B/2} z' / h^3 dz' (half-Sommerfeld). The ratio of the load with relief to the
  load without, computed so independently of the finite-element film, tends to the film's as B/D -> 0, at
  about the theory's order (B/D)^2.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
import sympy as sp
import ufl
from dolfinx import fem

from solver.errors import InputError
from solver.film import reynolds as film
from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.mesh import FilmMeshSpec, film_mesh
from solver.film.relief import EdgeRelief
from solver.film.surface import Surface
from tests.film.test_film_tensors import assert_the_contact_cells_hold_the_contact
from tests.film.test_reynolds_mms import mms_errors

WIDTH, EPS = 1.0, 0.5  # the manufactured solution's film (unit radius and clearance), as test_reynolds_mms
RELIEF = EdgeRelief(depth=0.5, length=0.25)  # H_r from 0 at |z| = 0.25 to 0.5 at the edges |z| = 0.5


@pytest.mark.parametrize("shape, quarter", [("parabolic", 0.25), ("linear", 0.5)])
def test_the_profile_at_known_points(shape, quarter):
    """H_r = d/c ((|z| - (B/2 - l))/l)^n: 0 in the middle and where the relief starts, d/c at both edges,
    quarter * d/c half way along the relieved length (z in units of R = 10 mm, d 4 um, l 3 mm, B 20 mm, c
    10 um)."""
    relief = EdgeRelief(depth=4e-6, length=3e-3, shape=shape)
    z = np.array([0.0, 0.7, -0.7, 0.85, -0.85, 1.0, -1.0, 0.3])
    H = relief.thickness(z, radius=0.01, clearance=10e-6, width=0.02)
    np.testing.assert_allclose(H, [0.0, 0.0, 0.0, 0.4 * quarter, 0.4 * quarter, 0.4, 0.4, 0.0], atol=1e-15)


def test_a_relief_too_long_or_negative_is_refused():
    """One-line errors naming the case's fields: l must leave the bore's middle cylindrical."""
    with pytest.raises(InputError, match=r"small_end.edge_relief_length_mm = 10 is out of range"):
        EdgeRelief(depth=4e-6, length=10e-3).check_width(0.02)
    with pytest.raises(InputError, match=r"small_end.edge_relief_um = -1 is out of range"):
        EdgeRelief(depth=-1e-6, length=3e-3)
    with pytest.raises(InputError, match=r"edge_relief_shape = 'round' is out of range"):
        EdgeRelief(depth=1e-6, length=3e-3, shape="round")


def _exact_and_source():
    """P and f = div(H^3 grad P) for H = H0(theta) + r(z), with r and r' = dr/dz as symbols (the relief
    does not depend on theta): f = d/dtheta(H^3 dP/dtheta) + H^3 d2P/dz2 + 3 H^2 r' dP/dz."""
    th, z, r, dr = sp.symbols("theta z r dr", real=True)
    P = sp.cos(sp.pi * z / WIDTH) * (sp.Rational(3, 2) + sp.cos(th) + sp.Rational(3, 10) * sp.sin(2 * th))
    H = 1 - EPS * sp.cos(th) + r
    f = sp.diff(H**3 * sp.diff(P, th), th) + H**3 * sp.diff(P, z, 2) + 3 * H**2 * dr * sp.diff(P, z)
    return P, f, th, z, r, dr


def _to_ufl(expr, th, z, r, dr, cos, sin, Z, R, dR):
    expr = sp.expand_trig(sp.expand(expr))
    c, s = sp.symbols("c s")
    expr = expr.subs({sp.cos(th): c, sp.sin(th): s})
    fn = sp.lambdify(
        (c, s, z, r, dr), expr, modules=[{"cos": ufl.cos, "sin": ufl.sin, "pi": math.pi}, "math"]
    )
    return fn(cos, sin, Z, R, dR)


def _solve_mms(comm, h: float) -> tuple[float, float]:
    mesh, _, facet_tags = film_mesh(FilmMeshSpec(width=WIDTH, element_size=h), comm)
    V = fem.FunctionSpace(mesh, ("Lagrange", 1))
    params = film.FilmParameters(mesh)
    params.set(eps_x=EPS)
    relief = RELIEF

    def thickness(z, mod):
        return relief.thickness(z, radius=1.0, clearance=1.0, width=WIDTH, mod=mod)

    g = film.FilmGeometry(mesh, params, relief=thickness)
    # the relief and its slope written out here: 0.5 s^2 and 0.5 * 2 s / l sign(z), s = (|z| - 0.25) / 0.25
    s = ufl.max_value((abs(g.z) - 0.25) / 0.25, 0.0)
    r_ufl, dr_ufl = 0.5 * s**2, ufl.sign(g.z) * 0.5 * 2.0 * s / 0.25
    P_exact, f, th, z, r, dr = _exact_and_source()
    Pe = _to_ufl(P_exact, th, z, r, dr, g.cos, g.sin, g.z, r_ufl, dr_ufl)
    source = _to_ufl(f, th, z, r, dr, g.cos, g.sin, g.z, r_ufl, dr_ufl)
    return mms_errors(comm, V, facet_tags, g, Pe, source)


@pytest.mark.mpi
def test_reynolds_with_relief_converges_at_optimal_order(comm):
    """Rates over h = 0.2, 0.1, 0.05: L2 -> 2 and H1 -> 1 within 0.15 (as test_reynolds_mms: unstructured
    meshes halve the element size only approximately). The relief's kink in dH/dz (parabolic: continuous
    slope, a jump in curvature at |z| = 0.25) leaves the source continuous."""
    sizes = [0.2, 0.1, 0.05]
    errors = np.array([_solve_mms(comm, h) for h in sizes])
    rates = np.log(errors[:-1] / errors[1:]) / np.log(2.0)
    assert rates[-1, 0] == pytest.approx(2.0, abs=0.15), rates
    assert rates[-1, 1] == pytest.approx(1.0, abs=0.15), rates


R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0
ROUGH = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)


def _model(relief, **kwargs):
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.1,
        roughness=ROUGH.roughness(),
        contact=ROUGH.contact(),
        edge_relief=relief,
        **kwargs,
    )


#: 2 um over 4 mm at each edge of a 20 mm bore with 10 um clearance: H_r up to 0.2
EDGE = EdgeRelief(depth=2e-6, length=4e-3)
DEEP = Kinematics(
    (0.995 * C * math.cos(4.0), 0.995 * C * math.sin(4.0)),
    (-0.3 * C * OMEGA, 0.1 * C * OMEGA),
    OMEGA,
    -0.5 * OMEGA,
)


@pytest.mark.serial
def test_fast_paths_carry_the_relief():
    """A rough rigid film with relief at eps 0.995 (asperity contact near the edges too): the operator and
    source from the numpy midpoint coefficients equal dolfinx's assembly of the UFL form (1e-12, as without
    relief); the pressure part of the torque from PressureTorque equals the UFL integrand's quadrature
    (1e-12); the asperity integrals over the kept contact cells equal those over the whole film (1e-14); the
    film thickness output at the nodes is c (1 - e.n) + h_r(z) (1e-12 of c); and the relief changed the
    answers (the load by more than 1 %)."""
    from solver.film.functionals import QuadratureFunctionals
    from solver.film.reynolds import shear_traction_integrands

    loads = {}
    for relief in (None, EDGE):
        with _model(relief) as model:
            result = model.solve(DEEP)
            loads[relief] = np.hypot(*result.force)
            torque = model.forms.pressure_torque
            _, _, pressure_part = shear_traction_integrands(
                model.pressure, model.space.geometry, model.space.roughness
            )
            exact = float(QuadratureFunctionals(model.mesh, [pressure_part], torque.DEGREE)()[0])
            n = torque.B.shape[1]
            eps = float(model.space.params.eps_x.value), float(model.space.params.eps_y.value)
            fast = torque(model.pressure.x.array[:n], *eps)
            assert abs(fast - exact) <= 1e-12 * abs(exact)
            assert_the_contact_cells_hold_the_contact(model)
            h = model.fields_si()["film_thickness"].x.array[:n]
            x = model.space.V.tabulate_dof_coordinates()[:n]
            z = np.abs(x[:, 2]) * R
            h_r = 0.0 if relief is None else 2e-6 * np.maximum(z - 6e-3, 0.0) ** 2 / 4e-3**2
            theta = np.arctan2(x[:, 1], x[:, 0])  # in the film's solution frame, as eps
            expected = C * (1.0 - eps[0] * np.cos(theta) - eps[1] * np.sin(theta)) + h_r
            assert np.abs(h - expected).max() <= 1e-12 * C
            if relief is not None:
                assert np.max(h_r) == pytest.approx(2e-6, rel=1e-12)  # the mesh reaches the edge
            # the operator from the numpy coefficients against dolfinx's assembly (last: converts A)
            solver = model.solver.vi
            solver.update()
            A_tensor, l_tensor = solver.A.copy(), solver.rhs.copy()
            solver.assembler, assembler = None, solver.assembler
            solver.update()
            solver.assembler = assembler
            dense_t = A_tensor.convert("dense").getDenseArray()
            dense_f = solver.A.convert("dense").getDenseArray()
            assert np.abs(dense_t - dense_f).max() <= 1e-12 * np.abs(dense_f).max()
            assert np.abs(l_tensor.array - solver.rhs.array).max() <= 1e-12 * np.abs(solver.rhs.array).max()
    assert loads[EDGE] < 0.99 * loads[None]


@pytest.mark.serial
def test_the_elastic_film_s_rigid_gap_carries_the_relief():
    """A Winkler bushing with relief: the coupled Newton's rigid gap plus the deformation (what it limits
    its steps and finds h_min with) is the film thickness of the forms at every node (1e-12 of c), and
    h_min is the least of them."""
    from solver.film.bushings import WinklerLayer

    bushing = WinklerLayer(thickness=1.5e-3, E=5e9, nu=0.33)
    with _model(EDGE, elastic=bushing) as model:
        result = model.solve(DEEP, time_s=None)
        n = model.space.n
        H = model.solver.ehd.rigid_gap + model.W.x.array[:n]
        h = model.fields_si()["film_thickness"].x.array[:n]
        assert np.abs(H * C - h).max() <= 1e-12 * C
        assert np.max(model.space.dof_relief) == pytest.approx(0.2, rel=1e-12)
        assert result.h_min == pytest.approx(min(h.min(), result.h_min), rel=1e-12)


def _short_bearing_load(width: float, relief: EdgeRelief | None, eps: float) -> float:
    """|F| of Ocvirk's short bearing with the relieved gap h = c (1 + eps cos theta) + h_r(z),
    half-Sommerfeld: dp/dz = 6 mu U (dh0/dx) z / h^3 (the constant factor 6 mu U / R left out: it cancels in
    the ratio), p = 0 at the edges, by the trapezoidal rule on a grid of 4000 x 2000 points (twice as fine
    changes the ratio by < 1e-6)."""
    theta = np.linspace(0.0, 2.0 * np.pi, 4001)[:-1]
    z = np.linspace(0.0, 0.5 * width, 2001)
    h_r = np.zeros_like(z) if relief is None else relief.thickness(z, radius=1.0, clearance=1.0, width=width)
    h = C * (1.0 + eps * np.cos(theta))[:, None] + h_r[None, :]
    f = z[None, :] / h**3
    segments = 0.5 * (f[:, 1:] + f[:, :-1]) * np.diff(z)[None, :]
    from_edge = np.concatenate(
        [np.cumsum(segments[:, ::-1], axis=1)[:, ::-1], np.zeros((len(theta), 1))], axis=1
    )
    p = np.maximum(0.0, C * eps * np.sin(theta)[:, None] * from_edge)
    w = np.trapz(p, z, axis=1)
    return math.hypot(np.trapz(w * np.cos(theta), theta), np.trapz(w * np.sin(theta), theta))


def _film_load(width: float, relief: EdgeRelief | None, eps: float, mesh_size: float) -> float:
    bearing = Bearing(radius=R, width=width, clearance=C, viscosity=MU, inlet="max-gap")
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=mesh_size, edge_relief=relief) as model:
        return float(np.hypot(*model.solve(Kinematics((0.0, -eps * C), (0.0, 0.0), OMEGA, 0.0)).force))


@pytest.mark.serial
@pytest.mark.slow
def test_the_relief_s_load_loss_tends_to_the_short_bearing_s():
    """The load with a 3 um parabolic relief over half the half width at each edge, over the load
    without, at eps 0.6, c 10 um, R 10 mm: the film's ratio against Ocvirk's for B/D = 0.25 and 0.125, the
    film's elements 1/20 of the width in both. The short-bearing theory is exact as B/D -> 0 with an error
    of order (B/D)^2: measured 2.67 % and 0.85 % (a factor 3.1 for half the width; the theory's ratio,
    0.6413, is the same for both widths, the relief scaling with them). Asserted: below 1.2 % at B/D 0.125,
    and falling at least 2.5 times from B/D 0.25 (order >= 1.3 where 2 is expected; the film's own
    discretisation and its Reynolds cavitation boundary, against the theory's half-Sommerfeld one, blur
    the factor), and the relief costs more than 30 % of the load (the check sees it)."""
    misfit = []
    for width in (0.5 * R, 0.25 * R):
        relief = EdgeRelief(depth=3e-6, length=width / 4)
        theory = _short_bearing_load(width, relief, 0.6) / _short_bearing_load(width, None, 0.6)
        film = _film_load(width, relief, 0.6, width / R / 20) / _film_load(width, None, 0.6, width / R / 20)
        misfit.append(abs(film / theory - 1.0))
        assert theory < 0.7
    assert misfit[1] < 0.012, misfit
    assert misfit[0] > 2.5 * misfit[1], misfit
