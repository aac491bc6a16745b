"""The film's fast paths give what the UFL forms and PETSc's reduced-space VI give.

- ``MidpointOperator`` (solver.film.tensors): the operator and source from precomputed tensors and
  the coefficients at the midpoints in numpy (``RigidMidpointCoefficients``) against dolfinx's
  assembly of the same UFL form (with the Dirichlet rows and the lifting), to
  1e-12 of the largest entry: both sum the same products in another order, so they differ by
  round-off (~1e-15) only. Smooth and rough films, with a pressurised supply hole (lifting).
- ``PressureTorque`` (solver.film.tensors): the pressure part of the viscous torques from a fixed
  sparse matrix and the roughness law in numpy, against dolfinx's evaluation of the UFL integrand at
  the same degree-2 points, to 1e-12 relative (the same products summed in another order), for a
  solved film at several states, smooth and rough.
- ``FixedPatternLU`` (solver.film.cavitation): the VI with numeric-only refactorisations of the full
  matrix against PETSc's reduced LU: the same number of VI iterations and the same pressure to
  1e-10 (the linear systems are the same, solved with another pivot order), and the sensitivities
  (the film Jacobian) to 1e-9; with it the SNES Jacobian is a shell whose reduced matrices are empty
  (the preconditioner never applies them).
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.surface import Surface

pytestmark = pytest.mark.serial
R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0
ROUGH = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)


def _model(rough: bool, hole: bool, **kwargs) -> FilmModel:
    bearing = Bearing(
        radius=R,
        width=2 * R,
        clearance=C,
        viscosity=MU,
        inlet="none",
        supply_pressure=3e5 if hole else 0.0,
        supply_hole_angle=0.5 if hole else None,
        supply_hole_diameter=3e-3 if hole else 0.0,
    )
    surface = ROUGH if rough else None
    return FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.1,
        roughness=surface.roughness() if rough else None,
        contact=surface.contact() if rough else None,
        **kwargs,
    )


STATE = Kinematics(
    (0.93 * C * math.cos(2.0), 0.93 * C * math.sin(2.0)),
    (0.2 * C * OMEGA, -0.4 * C * OMEGA),
    OMEGA,
    0.2 * OMEGA,
)


DEEP = Kinematics(
    (0.995 * C * math.cos(4.0), 0.995 * C * math.sin(4.0)),
    (-0.3 * C * OMEGA, 0.1 * C * OMEGA),
    OMEGA,
    -0.5 * OMEGA,
)


@pytest.mark.parametrize("rough", [False, True], ids=["smooth", "rough"])
@pytest.mark.parametrize("hole", [False, True], ids=["edges", "supply-hole"])
@pytest.mark.parametrize("state", [STATE, DEEP], ids=["eps0.93", "eps0.995"])
def test_tensors_equal_the_assembly_of_the_form(rough, hole, state):
    """(eps 0.995: h/sigma down to 0.16, below the flow factors' fits, where they are held)"""
    with _model(rough, hole) as model:
        assert model.solver.vi.assembler is not None  # serial P1: the tensor path is the default
        model.set_kinematics(state)
        solver = model.solver.vi
        solver.update()
        A_tensor, l_tensor = solver.A.copy(), solver.rhs.copy()
        solver.assembler, assembler = None, solver.assembler  # dolfinx's assembly of the UFL form
        solver.update()
        solver.assembler = assembler
        dense_t, dense_f = (
            A_tensor.convert("dense").getDenseArray(),
            solver.A.convert("dense").getDenseArray(),
        )
        assert np.abs(dense_t - dense_f).max() <= 1e-12 * np.abs(dense_f).max()
        assert np.abs(l_tensor.array - solver.rhs.array).max() <= 1e-12 * np.abs(solver.rhs.array).max()
        assert np.abs(solver.rhs.array).max() > 0 and np.count_nonzero(dense_f) > 5 * model.dofs
        if hole:  # the lifting did something: source values on the hole's neighbours
            assert np.abs(solver.rhs.array).max() > 1e-3


@pytest.mark.parametrize("rough", [False, True], ids=["smooth", "rough"])
def test_fixed_pattern_lu_gives_the_reduced_iterates(rough):
    states = [
        Kinematics((e * C * math.cos(a), e * C * math.sin(a)), (r * C * OMEGA, 0.0), OMEGA, 0.0)
        for e, a, r in [
            (0.3, 0.0, 0.0),
            (0.9, 1.0, 0.5),
            (0.95, 2.5, -1.0),
            (0.5, 4.0, 2.0),
            (0.97, 5.0, 0.0),
        ]
    ]
    results = {}
    for fixed in (True, False):
        with _model(rough, False, options=None) as model:
            if not fixed:  # PETSc's reduced LU, as before
                model.solver.vi.use_reduced_lu()
            else:  # FixedPatternLU, and the SNES Jacobian a shell whose reduced matrices are not extracted
                assert model.solver.vi.snes.getJacobian()[0].getType() == "python"
            runs = []
            for state in states:
                result = model.solve(state)
                runs.append((result.iterations, model.P.x.array.copy(), model.jacobian().matrix))
            results[fixed] = runs
    for (its_f, P_f, J_f), (its_r, P_r, J_r) in zip(results[True], results[False]):
        assert its_f == its_r
        assert np.abs(P_f - P_r).max() <= 1e-10 * np.abs(P_r).max()
        assert np.abs(J_f - J_r).max() <= 1e-9 * np.abs(J_r).max()


@pytest.mark.parametrize("rough", [False, True], ids=["smooth", "rough"])
def test_couette_torques_integrated_with_the_operator(rough):
    """The Couette friction integrals taken in the operator's evaluation of the coefficients (numpy,
    RigidMidpointCoefficients) equal the UFL integrands integrated by dolfinx's quadrature functionals
    (midpoint rule both). Smooth: 1e-12. Rough: 1e-10, because Patir-Cheng's closed form of Phi_f on
    3 < h/sigma <= 30 cancels terms of up to ~2e5 (z = 10: (1 - z^2)^3 ln((z + 1)/(z - 1)) against
    z/15 (66 + ...)) to a result of ~1, so two evaluations in another order of operations differ by
    ~2e-11 relative (measured 1.9e-12 on the integral)."""
    from solver.film.functionals import QuadratureFunctionals

    with _model(rough, False) as model:
        model.set_kinematics(STATE)
        model.solver.vi.update()
        names = model.forms.operator_integral_names
        assert set(names) == {"viscous_couette_journal", "viscous_couette_bushing"}
        reference = QuadratureFunctionals(
            model.mesh, [model.forms.midpoint_integrands[n] for n in names], 1
        )()
        assert model.forms.operator.fast is not None  # the numpy evaluation (rigid film, serial P1)
        tolerance = 1e-10 if rough else 1e-12
        assert np.abs(model.forms.operator.integrals - reference).max() <= tolerance * np.abs(reference).max()
        assert np.abs(reference).min() > 0


def test_warm_start_turned_with_a_jumping_frame_saves_vi_iterations():
    """Max-gap inlet: the pin crosses its clearance (squeezing along a line past the centre), so the
    solution frame jumps by ~pi while the pressure stays in the bushing frame. Turning the last
    pressure with the frame (FrameTurn) must give the same solutions (the VI's solution is unique:
    1e-9) in fewer VI iterations than starting from the untouched last pressure (measured 116
    against 127 over the 41 solves, 7 + 3 against 11 + 10 at the jump)."""
    counts, loads = {}, {}
    for turn in (True, False):
        bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="max-gap")
        with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA) as model:
            if not turn:
                model.TURN_THRESHOLD = math.inf  # never turn the warm start
            counts[turn], loads[turn] = 0, []
            for k in range(41):
                s, a = 0.6 - 0.03 * k, 0.4
                result = model.solve(
                    Kinematics(
                        (s * C * math.cos(a) + 0.05 * C, s * C * math.sin(a)),
                        (-2 * C * OMEGA * math.cos(a), -2 * C * OMEGA * math.sin(a)),
                        0.3 * OMEGA,
                        0.0,
                    )
                )
                counts[turn] += result.iterations
                loads[turn].append(result.load)
    np.testing.assert_allclose(loads[True], loads[False], rtol=1e-9)
    assert counts[True] < counts[False]


@pytest.mark.parametrize(
    "rough, elastic",
    [(False, False), (True, False), (False, True), (True, True)],
    ids=["smooth", "rough", "smooth-elastic", "rough-elastic"],
)
def test_pressure_torque_equals_the_quadrature_of_the_form(rough, elastic):
    """The pressure part of the viscous torque from PressureTorque and from the UFL integrand evaluated by
    dolfinx (solver.film.bearing.QuadratureFunctionals, the rule the forms use) at three solved states:
    equal to 1e-12 of its size, and not zero. With an elastic (Winkler) bushing the gap carries the
    deformation, which is not small there, and the flow's floor of the gap."""
    from solver.film.bushings import WinklerLayer
    from solver.film.functionals import QuadratureFunctionals
    from solver.film.reynolds import shear_traction_integrands

    bushing = WinklerLayer(thickness=1.5e-3, E=5e9, nu=0.33) if elastic else None  # a polymer layer: W ~ 0.1
    with _model(rough, False, elastic=bushing) as model:
        torque = model.forms.pressure_torque
        assert torque is not None  # serial, P1: the default
        _, _, pressure_part = shear_traction_integrands(
            model.pressure, model.space.geometry, model.space.roughness
        )
        reference = QuadratureFunctionals(model.mesh, [pressure_part], torque.DEGREE)
        for e, angle, rate in [(0.3, 0.5, 0.0), (0.93, 2.0, 0.4), (0.98, 4.5, -1.0)]:
            state = Kinematics(
                (e * C * math.cos(angle), e * C * math.sin(angle)), (0.0, rate * C * OMEGA), OMEGA, 0.0
            )
            model.solve(state)
            n = torque.B.shape[1]
            eps = float(model.space.params.eps_x.value), float(model.space.params.eps_y.value)
            W = model.W.x.array[:n] if elastic else None
            if elastic:
                assert np.max(np.abs(W)) > 0.01
            fast = torque(model.pressure.x.array[:n], *eps, W)
            exact = float(reference()[0])
            assert abs(exact) > 1e-3
            assert abs(fast - exact) <= 1e-12 * abs(exact), (e, fast, exact)
            values = model.forms.values(model.forms.contact_cells())  # the solve's functionals take it
            whole = model.mesh_spec.multiplicity * model.scales.shear_torque
            for name in ("viscous_pressure_journal", "viscous_pressure_bushing"):
                assert values[name] == pytest.approx(whole * fast, rel=1e-14)
        if elastic:  # a deformation that closes the gap below the flow's floor over part of the film
            h0, coords = torque.flow_floor, model.space.owned_coords
            rigid = 1.0 - coords[:, :2] @ np.array(eps)
            gap = h0 * (0.2 + 2.0 * np.random.default_rng(3).random(n))
            model.W.x.array[:n] = gap - rigid
            assert 0.2 < np.mean(gap < h0) < 0.8
            fast = torque(model.pressure.x.array[:n], *eps, model.W.x.array[:n])
            exact = float(reference()[0])
            assert abs(fast - exact) <= 1e-12 * abs(exact), (fast, exact)


@pytest.mark.parametrize("state", [STATE, DEEP], ids=["eps0.93", "eps0.995"])
def test_contact_integrals_on_the_contact_cells_equal_those_over_the_film(state):
    """The asperity integrals are taken on the cells FilmModel._contact_cells keeps (h/sigma below the
    Greenwood-Tripp support at a vertex, widened by the cell's extent); over every cell of the film
    they are the same to round-off (1e-14: the other cells add exact zeros), and the kept cells are
    few (the point of keeping them)."""
    with _model(True, False) as model:
        model.solve(state)
        assert_the_contact_cells_hold_the_contact(model)


def assert_the_contact_cells_hold_the_contact(model) -> None:
    """The asperity integrals of the last solve over the kept contact cells equal those over every cell
    (1e-14), are not zero, and the kept cells are fewer than half the film's."""
    cells = model.forms.contact_cells()
    assert 0 < len(cells) < 0.5 * len(model.space.owned_cells)
    for _, functionals in model.forms.scalars:
        if functionals.contact_only:
            kept, everywhere = functionals(cells), functionals(None)
            assert np.abs(everywhere).max() > 0
            assert np.abs(kept - everywhere).max() <= 1e-14 * np.abs(everywhere).max()
