"""Oil supply: a round hole, an axial groove or a circumferential groove held at the supply pressure,
and the flows through it (solver.film.bearing, solver.film.mesh).

- A concentric bearing with a full circumferential groove has the exact Poiseuille solution: on
  each land the pressure falls linearly from p_s to 0, so the side flow is
  ``Q = 2 * 2 pi R c^3 p_s / (12 mu (B - w) / 2)`` (both lands), whatever the journal speed (the gap
  is uniform: the Couette flow is divergence-free).
- Discrete mass balance: the residuals of all dofs add up to the integral of the source, so in a
  steady state supply flow + the oil the Reynolds condition creates in the cavitated zone = side
  flow, whatever the mesh; without cavitation the supply flow is the side flow.
"""

from __future__ import annotations

import math
import types
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from solver.errors import InputError
from solver.film import reynolds
from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.mesh import TAGS, AxialGroove, CircumferentialGroove

pytestmark = pytest.mark.serial
R, B, C, MU = 0.01, 0.02, 10e-6, 0.01
OMEGA = 3000 * 2 * math.pi / 60


def _poiseuille_side_flow(p_s: float, w: float) -> float:
    """Both lands of a concentric bearing with a circumferential groove of width w at p_s [m^3/s]."""
    return 2 * 2 * math.pi * R * C**3 * p_s / (12 * MU * (B - w) / 2)


@pytest.mark.parametrize("half", [True, False], ids=["half-mesh", "whole-mesh"])
def test_circumferential_groove_side_flow_is_poiseuille(half):
    """Concentric journal, circumferential groove w = 3 mm at p_s = 3 bar, still and turning at 3000
    rpm: side flow against the exact Q above.

    P1 reproduces the linear profile on a flat land exactly; the error is the faceted cylinder's: the
    edge is the inscribed polygon, short of 2 pi by 1 - sin(D/2)/(D/2) ~ D^2/24 for edges spanning
    D <= sqrt(2) h, and the triangles' planes tilt from the axis (the P1 gradient of a field linear
    in z is its projection on them), both O(h^2). Tolerance h^2/12 (2.1e-4 at h = 0.05 R, 5.2e-5 at
    0.025 R); measured -9.6e-5 and -2.2e-5 (order 2.1). The supply flow equals the side flow to 1e-10
    (no source at eps = 0: the discrete balance is exact up to the VI's tolerance; measured <= 5e-15)."""
    p_s, w = 3e5, 3e-3
    Q = _poiseuille_side_flow(p_s, w)
    bearing = Bearing(
        radius=R,
        width=B,
        clearance=C,
        viscosity=MU,
        inlet="none",
        supply_pressure=p_s,
        groove="circumferential",
        groove_width=w,
    )
    errors = []
    for h in (0.05, 0.025) if half else (0.05,):
        with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=h, half=half) as model:
            for omega in (0.0, OMEGA):
                result = model.solve(Kinematics((0.0, 0.0), (0.0, 0.0), omega, 0.0))
                assert result.p_max == pytest.approx(p_s, rel=1e-12)
                assert result.side_flow == pytest.approx(Q, rel=h**2 / 12)
                assert result.supply_flow == pytest.approx(result.side_flow, rel=1e-10)
            errors.append(abs(result.side_flow / Q - 1))
    if half:
        assert errors[0] / errors[1] > 3  # second order (4 = h^2)


def _groove_model(eps: float, p_s: float, arc_deg: float, length: float):
    bearing = Bearing(
        radius=R,
        width=B,
        clearance=C,
        viscosity=MU,
        inlet="none",
        supply_pressure=p_s,
        groove="axial",
        groove_angle=math.pi / 2,
        groove_arc=math.radians(arc_deg),
        groove_length=length,
    )
    model = FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.05)
    # journal below the centre: the gap is widest at +y (90 deg), where the groove is
    return model, model.solve(Kinematics((0.0, -eps * C), (0.0, 0.0), OMEGA, 0.0))


def _balance_terms(model, groove: AxialGroove) -> tuple[float, float, int]:
    """(oil created in the cavitated zone, integral of the source) [m^3/s] and the number of cavitated
    nodes, computed here: the residuals
    r_i = r(P; phi_i) of the film's discrete equation (P1, midpoint rule as the model) summed over the
    cavitated nodes (P = 0, not on an edge or in the groove, found by their coordinates), and the
    integral of the source, both over the whole film (the half mesh twice)."""
    v = ufl.TestFunction(model.V)
    dx = ufl.dx(domain=model.mesh, metadata={"quadrature_degree": 1})
    residual = fem_petsc.assemble_vector(
        fem.form(reynolds.reynolds_integrand(model.P, v, model.space.geometry) * dx)
    )
    r = residual.getArray().copy()
    residual.destroy()
    source = fem.assemble_scalar(fem.form(reynolds.reynolds_coefficients(model.space.geometry)[2] * dx))
    x = model.V.tabulate_dof_coordinates()
    edge = np.isclose(np.abs(x[:, 2]), B / R / 2, atol=1e-9)
    offset = np.angle(np.exp(1j * (np.arctan2(x[:, 1], x[:, 0]) - groove.angle)))
    in_groove = (np.abs(offset) <= groove.arc / 2 + 1e-9) & (np.abs(x[:, 2]) <= groove.length / 2 + 1e-9)
    cavitated = (model.P.x.array <= 0.0) & ~edge & ~in_groove
    scale = model.mesh_spec.multiplicity * model.scales.flow
    return float(r[cavitated].sum()) * scale, source * scale, int(np.count_nonzero(cavitated))


def test_axial_groove_without_cavitation_conserves_mass():
    """eps = 0.1 at 3000 rpm, a 120 deg x 0.8 B groove at the widest gap and 100 bar: the film is
    pressurised everywhere (no cavitated node), so the supply flow is the side flow.

    The discrete balance: supply - side = the integral of the source U dH/dtheta, zero on the true
    cylinder; on the faceted mesh with the midpoint rule it is 6e-9 of the side flow. Tolerances:
    that balance to 1e-10 (the free dofs' residuals are below the VI's tolerance; measured 7e-17) and
    supply = side to 1e-7 (16 x the quadrature's 6e-9)."""
    model, result = _groove_model(eps=0.1, p_s=100e5, arc_deg=120.0, length=0.8 * B)
    with model:
        created, source, cavitated = _balance_terms(model, model.mesh_spec.supply)
        assert cavitated == 0 and created == 0.0
        assert result.supply_flow > 0
        assert result.supply_flow - result.side_flow == pytest.approx(source, abs=1e-10 * result.side_flow)
        assert result.supply_flow == pytest.approx(result.side_flow, rel=1e-7)


def test_axial_groove_with_cavitation_balances_with_the_created_oil():
    """eps = 0.5, a 30 deg x 0.6 B groove at 3 bar: the film cavitates, and the Reynolds condition
    creates oil there (the Couette flow of a full film in the diverging gap). Discrete balance:
    supply + created = side + integral of the source, to 1e-10 of the side flow (as above; measured
    2e-15). Here the supply delivers only ~4 % of the side flow: the rest is the created oil, the
    reason for a mass-conserving cavitation model."""
    model, result = _groove_model(eps=0.5, p_s=3e5, arc_deg=30.0, length=0.6 * B)
    with model:
        created, source, cavitated = _balance_terms(model, model.mesh_spec.supply)
        assert cavitated > 0 and created > 0 and result.supply_flow > 0
        assert result.supply_flow + created - result.side_flow == pytest.approx(
            source, abs=1e-10 * result.side_flow
        )
        assert result.supply_flow < 0.1 * result.side_flow


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"groove": "spiral"}, r"^groove = 'spiral' is out of range"),
        (
            {"groove": "axial", "groove_arc": 2 * math.pi, "groove_length": 0.01},
            r"^groove_arc = 6.28319 is out of range \(allowed: \(0, 2 pi\) rad\)$",
        ),
        (
            {"groove": "axial", "groove_arc": 0.5, "groove_length": 0.02},
            r"^groove_length = 0.02 is out of range",
        ),
        (
            {"groove": "axial", "groove_arc": 0.5, "groove_length": 0.01, "groove_angle": math.inf},
            r"^groove_angle = inf",
        ),
        ({"groove": "circumferential", "groove_width": 0.0}, r"^groove_width = 0 is out of range"),
        (
            {
                "groove": "circumferential",
                "groove_width": 0.003,
                "supply_hole_angle": 0.0,
                "supply_hole_diameter": 0.002,
            },
            r"one oil supply",
        ),
        (
            {
                "groove": "circumferential",
                "groove_width": 0.003,
                "supply_pressure": -2e5,
                "cavitation_pressure": -1e5,
            },
            r"^supply_pressure = -200000 is out of range \(allowed: >= cavitation_pressure",
        ),
    ],
)
def test_bad_supply_is_one_line_input_error(changes, message):
    arguments = {"radius": R, "width": B, "clearance": C, "viscosity": MU, "inlet": "none"} | changes
    with pytest.raises(InputError, match=message) as caught:
        Bearing(**arguments)
    assert "\n" not in str(caught.value)


def test_a_supply_with_the_max_gap_inlet_is_refused_by_the_spec():
    """The rule lives in solver.film_rules: a FilmSpec refuses it in one line naming key and flag."""
    from solver.film.spec import FilmSpec

    bearing = Bearing(
        radius=R, width=B, clearance=C, viscosity=MU, groove="circumferential", groove_width=0.003
    )
    with pytest.raises(
        InputError, match=r"^oil.inlet = 'max-gap' \(--inlet max-gap\) with an oil supply"
    ) as caught:
        FilmSpec(bearing=bearing, omega_ref=100.0)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "oil, shape",
    [
        (
            {
                "inlet": "axial-groove",
                "groove_angle": math.radians(200),
                "groove_arc": math.radians(40),
                "groove_length": 0.012,
            },
            AxialGroove(angle=math.radians(200), arc=math.radians(40), length=1.2),
        ),
        ({"inlet": "circumferential-groove", "groove_width": 0.004}, CircumferentialGroove(width=0.4)),
    ],
)
def test_the_small_end_of_a_case_gets_the_groove(oil, shape):
    """joint_from_case: a case's groove (rod frame = bushing frame; lengths / pin radius) reaches the film
    mesh as the supply cells, held at oil.supply_pressure_bar (the peak pressure of a still concentric
    pin is the supply pressure, 1e-12), with a positive supply flow."""
    from solver.case import Case, Oil, Solver
    from solver.dynamics.joint import joint_from_case

    case = Case(
        name="groove", directory=Path("."), oil=Oil(supply_pressure=2e5, **oil), solver=Solver(mesh_size=0.1)
    )
    engine = types.SimpleNamespace(crank_motion=types.SimpleNamespace(speed=OMEGA))
    _, model = joint_from_case(case, engine, MPI.COMM_SELF, "mixed-fem")
    with model:
        supply = model.mesh_spec.supply
        assert type(supply) is type(shape)
        for name, value in vars(shape).items():
            assert getattr(supply, name) == pytest.approx(value, rel=1e-12), name
        assert model.bearing.inlet == "none" and model.bearing.supply_pressure == 2e5
        assert len(model.space.cell_tags.find(TAGS["supply"])) > 0
        result = model.solve(Kinematics((0.0, 0.0), (0.0, 0.0), 0.0, 0.0))
        assert result.p_max == pytest.approx(2e5, rel=1e-12)
        assert result.supply_flow == pytest.approx(result.side_flow, rel=1e-10) and result.supply_flow > 0
