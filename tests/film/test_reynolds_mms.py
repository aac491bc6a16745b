"""Order of convergence of the Reynolds operator with a manufactured solution.

On the unit cylinder (theta, Z), smooth film H = 1 - eps cos(theta), the exact solution

    P(theta, Z) = cos(pi Z / B) (1.5 + cos(theta) + 0.3 sin(2 theta))

vanishes on the edges Z = +-B/2 and is positive inside, so the cavitation bound never binds and
the VI solve is the linear Reynolds solve. The source ``f = div(H^3 grad P)`` is derived with sympy
from the formula, independently of the code's forms. For P1 elements (on the faceted cylinder, whose
geometric error is also O(h^2)) the L2 error must fall as h^2 and the H1 seminorm error as h.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
import sympy as sp
import ufl
from dolfinx import fem

from solver.film import reynolds as film
from solver.film.cavitation import CavitatingSolver
from solver.film.mesh import TAGS, FilmMeshSpec, film_mesh

WIDTH, EPS = 1.0, 0.5


def _exact_and_source():
    th, z = sp.symbols("theta z", real=True)
    P = sp.cos(sp.pi * z / WIDTH) * (sp.Rational(3, 2) + sp.cos(th) + sp.Rational(3, 10) * sp.sin(2 * th))
    H = 1 - EPS * sp.cos(th)
    f = sp.diff(H**3 * sp.diff(P, th), th) + sp.diff(H**3 * sp.diff(P, z), z)
    return P, f, th, z


def _to_ufl(expr, th, z, cos, sin, Z):
    """Substitute cos/sin of theta and z by UFL expressions (expand multiple angles first)."""
    expr = sp.expand_trig(sp.expand(expr))
    c, s = sp.symbols("c s")
    expr = expr.subs({sp.cos(th): c, sp.sin(th): s})
    fn = sp.lambdify((c, s, z), expr, modules=[{"cos": ufl.cos, "sin": ufl.sin, "pi": math.pi}, "math"])
    return fn(cos, sin, Z)


def solve_mms(comm, h: float):
    mesh, _, facet_tags = film_mesh(FilmMeshSpec(width=WIDTH, element_size=h), comm)
    V = fem.FunctionSpace(mesh, ("Lagrange", 1))
    params = film.FilmParameters(mesh)
    params.set(eps_x=EPS)
    g = film.FilmGeometry(mesh, params)
    P_exact, f, th, z = _exact_and_source()
    Pe = _to_ufl(P_exact, th, z, g.cos, g.sin, g.z)
    source = _to_ufl(f, th, z, g.cos, g.sin, g.z)
    return mms_errors(comm, V, facet_tags, g, Pe, source)


def mms_errors(comm, V, facet_tags, g, Pe, source) -> tuple[float, float]:
    """The L2 and H1-seminorm errors against ``Pe`` of the P1 solution of -div(H^3 grad P) + f = 0 with the
    geometry ``g`` and the source ``f`` (UFL), P = 0 on both edges (the VI with an inactive bound)."""
    P, v, dP = fem.Function(V), ufl.TestFunction(V), ufl.TrialFunction(V)
    dx = ufl.dx(metadata={"quadrature_degree": 6})
    residual = film.reynolds_integrand(P, v, g) + source * v  # -div(H^3 grad P) + f = 0
    a = fem.form(ufl.derivative(residual * dx, P, dP))
    L = fem.form(ufl.replace(residual, {P: ufl.zero()}) * dx)
    edges = np.concatenate([facet_tags.find(TAGS["edge_minus"]), facet_tags.find(TAGS["edge_plus"])])
    bc = fem.dirichletbc(fem.Function(V), fem.locate_dofs_topological(V, 1, edges))
    with CavitatingSolver(a, L, P, [bc], lower=-1e3) as solver:
        solver.solve()
    err_L2 = fem.form((P - Pe) ** 2 * dx)
    err_H1 = fem.form(ufl.inner(ufl.grad(P - Pe), ufl.grad(P - Pe)) * dx)
    sums = [comm.allreduce(fem.assemble_scalar(e), op=MPI.SUM) for e in (err_L2, err_H1)]
    return math.sqrt(sums[0]), math.sqrt(sums[1])


@pytest.mark.mpi
def test_reynolds_p1_converges_at_optimal_order(comm):
    """Rates over h = 0.2, 0.1, 0.05: L2 -> 2 and H1 -> 1 within 0.15.

    0.15 allows for unstructured meshes whose element size is only approximately halved (measured
    spread of the rates is about 0.05).
    """
    sizes = [0.2, 0.1, 0.05]
    errors = np.array([solve_mms(comm, h) for h in sizes])
    rates = np.log(errors[:-1] / errors[1:]) / np.log(2.0)
    assert rates[-1, 0] == pytest.approx(2.0, abs=0.15), rates
    assert rates[-1, 1] == pytest.approx(1.0, abs=0.15), rates
