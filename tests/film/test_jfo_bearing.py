"""The mass-conserving (JFO) film of a journal bearing: FilmModel(cavitation="jfo").

References, each independent of the JFO code path:

1. The mean gap of rough surfaces against scipy's adaptive quadrature of the contact factor, and its
   derivative against the contact factor (the Reynolds terms it must reproduce).
2. Where the film does not rupture (cavitation pressure far below ambient), the JFO film is the
   Reynolds film: the same forces and torques as FilmModel(cavitation="reynolds") up to the
   discretisation (conservative Couette flux against the Reynolds source: O(h^2), checked by its order).
3. The film's Jacobian against central finite differences of the solves (a cavitated, transient state).
4. Mass conservation: steady with a supply groove, the supply flow equals the side flow to round-off
   (the Reynolds condition, which creates oil in the cavity, misses it by percents); transient, the
   stored oil's change per step matches the flows to O(dt^2) (the rate form), checked by its order.
5. History: a solve that is not committed (a rejected step) leaves the next solves unchanged.
"""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest
from scipy.integrate import quad

from solver.errors import InputError
from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.factory import make_film
from solver.film.flow_factors import PatirCheng, contact_factor, mean_gap
from solver.film.spec import FilmSpec

pytestmark = pytest.mark.serial

R, B, C, MU = 0.01, 0.02, 1e-5, 0.01
OMEGA = 200.0
ROUGH = PatirCheng(sigma_bushing=0.3e-6, sigma_journal=0.1e-6)


def _model(cavitation, *, mesh_size=0.1, p_cav=-0.5e5, roughness=ROUGH, transport="limited", **bearing):
    b = Bearing(
        radius=R, width=B, clearance=C, viscosity=MU, cavitation_pressure=p_cav, inlet="none", **bearing
    )
    return FilmModel(
        b,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=mesh_size,
        cavitation=cavitation,
        roughness=roughness,
        transport=transport,
    )


def _outputs(r) -> np.ndarray:
    return np.array([*r.force, r.torque_journal, r.torque_bushing])


def test_mean_gap_integrates_the_contact_factor():
    """h_T/sigma = Hs + integral_Hs^3 (1 - phi_c): against quad to 1e-12 (the 10-point Gauss rule of
    a smooth integrand on at most [0, 3]); its slope is phi_c to the central difference's error
    (1e-8 with a step of 1e-5)."""
    for Hs in (-1.0, 0.0, 0.4, 1.7, 2.9, 3.0, 5.0):
        exact = (
            Hs
            + quad(lambda x: 1.0 - float(contact_factor(np.array([x]))[0]), max(Hs, 0.0), 3.0)[0]
            + max(-Hs, 0.0) * (1.0 - float(contact_factor(np.array([0.0]))[0]))
            if Hs < 3
            else Hs
        )
        assert float(mean_gap(np.array([Hs]))[0]) == pytest.approx(exact, abs=1e-12)
    Hs, d = np.array([-0.7, 0.2, 1.0, 2.5, 4.0]), 1e-5
    assert np.max(np.abs((mean_gap(Hs + d) - mean_gap(Hs - d)) / (2 * d) - contact_factor(Hs))) < 1e-8


@pytest.mark.parametrize("roughness", [None, ROUGH], ids=["smooth", "rough"])
def test_unruptured_film_is_the_reynolds_film(roughness):
    """Cavitation pressure -1e4 bar (the film never ruptures): forces and torques of the JFO and the
    Reynolds films differ by the discretisation only (conservative Couette flux with the gap at the
    cell, against the Reynolds source phi_c dH/dtheta): below 3e-4 of the largest output on 0.1 R,
    falling with order >= 1.5 (measured 2) on 0.05 R; the Reynolds condition alone would give the
    same, so the flow factors, shear flow and squeeze of the JFO path are those of the Reynolds forms."""
    kin = Kinematics((3e-6, 2e-6), (0.001, -0.002), OMEGA, 0.0)
    errors = []
    for h in (0.1, 0.05):
        values = {}
        for cavitation in ("reynolds", "jfo"):
            with _model(cavitation, mesh_size=h, p_cav=-1e9, roughness=roughness) as model:
                result = model.solve(kin)
                values[cavitation] = _outputs(result)
                assert result.cavitated_area_ratio == 0.0
        scale = np.abs(values["reynolds"]).max(axis=None)
        forces = np.abs(values["jfo"] - values["reynolds"])[:2].max() / scale
        torques = np.abs(values["jfo"] - values["reynolds"])[2:].max() / np.abs(values["reynolds"][2:]).max()
        errors.append(max(forces, torques))
    assert errors[0] < 3e-4
    assert math.log2(errors[0] / errors[1]) > 1.5


def test_jacobian_matches_finite_differences():
    """A transient, cavitated state (ruptured area 0.55, a step from a committed steady state): every
    column of the Jacobian against central differences, to 1e-6 of the column's size (measured 1e-8;
    the steps are small enough for the partition to stay, large enough for round-off)."""
    with _model("jfo") as model:
        model.solve(Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0), 0.0)
        model.commit_history(model.history_state(), 0.0)
        t, omega_b = 5e-5, 30.0
        x0 = np.array([5.5e-6, 3.2e-6, 0.01, 0.004, OMEGA - omega_b])

        def outputs(x):
            return _outputs(model.solve(Kinematics((x[0], x[1]), (x[2], x[3]), x[4] + omega_b, omega_b), t))

        result = model.solve(Kinematics(tuple(x0[:2]), tuple(x0[2:4]), OMEGA, omega_b), t)
        assert 0.3 < result.cavitated_area_ratio < 0.8
        J = model.jacobian().matrix
        steps = (1e-10, 1e-10, 1e-5, 1e-5, 1e-3)
        for k, step in enumerate(steps):
            e = np.zeros(5)
            e[k] = step
            column = (outputs(x0 + e) - outputs(x0 - e)) / (2 * step)
            assert np.max(np.abs(J[:, k] - column)) <= 1e-6 * np.max(np.abs(column))


def test_limited_transport_falls_back_to_upwind_for_the_step():
    """A limited solve that does not converge (forced here) is solved again with upwinding, and so is
    every solve until the next commit (one residual per integrator step, a retried step's too); after
    the next commit the transport is limited again. Against a model with transport 'upwind' from the
    same committed state: the same forces and torques to 1e-10 during the fallback, and different by
    more than 1e-4 after it (the limiter acts on this transient, cavitated film)."""
    from solver.errors import FilmNotConverged

    kin0 = Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0)
    states = [
        Kinematics((5.5e-6, 3.2e-6), (0.01, 0.004), OMEGA, 30.0),
        Kinematics((5.6e-6, 3.3e-6), (0.012, 0.004), OMEGA, 30.0),
    ]
    with _model("jfo") as model, _model("jfo", transport="upwind") as upwind:
        for m in (model, upwind):
            m.solve(kin0, 0.0)
            m.commit_history(m.history_state(), 0.0)
        real, broken = model.solver.jfo.solve, [True]

        def failing(*args, **kwargs):  # every limited solve fails while ``broken``
            if broken[0] and model.solver.transport.derivatives.limited is not None:
                raise FilmNotConverged("forced", -5, 1)
            return real(*args, **kwargs)

        model.solver.jfo.solve = failing
        first = _outputs(model.solve(states[0], 5e-5))
        assert model.stats.transport_fallbacks == 1
        assert np.max(np.abs(first - _outputs(upwind.solve(states[0], 5e-5)))) <= 1e-10 * np.max(
            np.abs(first)
        )
        broken[0] = False
        second = _outputs(model.solve(states[1], 5e-5))  # the same step: still upwind
        assert np.max(np.abs(second - _outputs(upwind.solve(states[1], 5e-5)))) <= 1e-10 * np.max(
            np.abs(second)
        )
        for m in (model, upwind):
            m.commit_history(m.history_state(), 5e-5)
        later = [
            _outputs(m.solve(Kinematics((5.7e-6, 3.4e-6), (0.012, 0.004), OMEGA, 30.0), 1e-4))
            for m in (model, upwind)
        ]
        assert model.solver.transport.derivatives.limited is not None and model.stats.transport_fallbacks == 1
        assert np.max(np.abs(later[0] - later[1])) > 1e-4 * np.max(np.abs(later[1]))


def test_steady_supply_flow_equals_side_flow():
    """Steady rotation with an axial groove at 2 bar: what the groove feeds leaves at the edges, to
    1e-9 of the flow (the discrete flux balance is exact; round-off of LU); the Reynolds condition's
    cavity creates oil, and its balance misses by more than 1 % (the check can fail)."""
    groove = dict(
        groove="axial",
        groove_angle=math.pi / 2,
        groove_arc=math.radians(30),
        groove_length=0.01,
        supply_pressure=2e5,
    )
    kin = Kinematics((6e-6, -2e-6), (0.0, 0.0), OMEGA, 0.0)
    closure = {}
    for cavitation in ("jfo", "reynolds"):
        with _model(cavitation, **groove) as model:
            r = model.solve(kin)
            assert r.cavitated_area_ratio > 0.1 and r.side_flow > 0
            closure[cavitation] = abs(r.supply_flow - r.side_flow) / r.side_flow
    assert closure["jfo"] < 1e-9
    assert closure["reynolds"] > 1e-2


def test_transient_oil_balance_is_second_order_per_step():
    """A squeeze that opens and ruptures the film, from a committed steady state: per step the change
    of the stored oil minus dt (supply - side flow) is the rate form's defect, O(dt^2): halving dt
    divides it by > 3 (order > 1.58; measured 3.7). Its constant is large: the film fraction changes
    on the time scale h / (dh/dt), here 80 us, so even at dt = 5 us the defect is 20 % of the net flow
    (the content form of solver.film.jfo is exact; tests/film/test_jfo.py)."""
    defects, flows = [], 0.0
    for dt in (1e-5, 5e-6):
        with _model("jfo", groove="circumferential", groove_width=3e-3, supply_pressure=1e5) as model:
            start = model.solve(Kinematics((6e-6, 0.0), (0.0, 0.0), OMEGA, 0.0), 0.0)
            model.commit_history(model.history_state(), 0.0)
            rate = (-0.05, 0.02)  # m/s
            end = model.solve(Kinematics((6e-6 + rate[0] * dt, rate[1] * dt), rate, OMEGA, 0.0), dt)
            stored = end.oil_volume - start.oil_volume
            flows = dt * (end.supply_flow - end.side_flow)
            defects.append(abs(stored - flows))
    assert abs(flows) > 3 * defects[-1]  # the balance is led by the flows, not the defect
    assert math.log2(defects[0] / defects[1]) > 1.58


def test_uncommitted_solve_leaves_history_unchanged():
    """A solve at a later time that is never committed (a rejected step) and a solve elsewhere: the
    solve at the first state again gives the same result to 1e-9 (the warm start differs only)."""
    with _model("jfo") as model:
        model.solve(Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0), 0.0)
        model.commit_history(model.history_state(), 0.0)
        kin = Kinematics((5.2e-6, 3.1e-6), (0.004, 0.002), OMEGA, 0.0)
        first = _outputs(model.solve(kin, 5e-5))
        model.solve(Kinematics((-7e-6, 1e-6), (-0.1, 0.0), OMEGA, 0.0), 3e-4)
        again = _outputs(model.solve(kin, 5e-5))
        assert np.max(np.abs(again - first)) <= 1e-9 * np.max(np.abs(first))


def test_jfo_refuses_what_it_does_not_support():
    """One line naming the case key and the flag (solver.film_rules), before any mesh: degree 2; edges at
    the cavitation pressure without a supply (no oil can enter but along the edges' first element row:
    the steady load at eps 0.9 falls by 16 % from 0.1 to 0.025 R, against about 1 % with the edges
    flooded 0.9 bar above p_cav); the max-gap inlet with a history, unless quasi-static (whose film
    then commits no history)."""
    b = Bearing(radius=R, width=B, clearance=C, viscosity=MU)
    with pytest.raises(InputError, match="serial P1 film"):
        FilmSpec(bearing=b, omega_ref=OMEGA, degree=2, cavitation="jfo", quasi_static=True)
    with pytest.raises(InputError, match=r"^oil.cavitation = 'elrod' \(--cavitation elrod\) is out of range"):
        FilmSpec(bearing=b, omega_ref=OMEGA, cavitation="elrod")
    sealed = Bearing(radius=R, width=B, clearance=C, viscosity=MU, inlet="none")  # p_cav = 0, no supply
    with pytest.raises(InputError, match=r"^oil.cavitation_pressure_bar = 0 \(--cavitation-pressure 0 Pa\)"):
        FilmSpec(bearing=sealed, omega_ref=OMEGA, cavitation="jfo")
    with pytest.raises(InputError, match="max-gap frame"):
        FilmSpec(bearing=b, omega_ref=OMEGA, cavitation="jfo")
    spec = FilmSpec(bearing=b, omega_ref=OMEGA, mesh_size=0.2, cavitation="jfo", quasi_static=True)
    with make_film(spec, MPI.COMM_SELF) as model:
        model.solve(Kinematics((5e-6, 0.0), (0.0, 0.0), OMEGA, 0.0))  # quasi-static: allowed
        with pytest.raises(InputError, match="quasi-static film commits no history"):
            model.commit_history(model.history_state(), 0.0)


# -- the mass-conserving film on an elastic bushing (solver.film.cavitation_jfo) ---------------------------

T_BUSHING, E_BUSHING, NU_BUSHING = 1.5e-3, 115e9, 0.33  # the reference small end's bronze bushing


def _elastic(E, *, mesh_size=0.15, **bearing):
    from solver.film.bushings import WinklerLayer

    b = Bearing(
        radius=R, width=B, clearance=C, viscosity=MU, cavitation_pressure=-0.5e5, inlet="none", **bearing
    )
    return FilmModel(
        b,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=mesh_size,
        cavitation="jfo",
        roughness=ROUGH,
        elastic=WinklerLayer(thickness=T_BUSHING, E=E, nu=NU_BUSHING),
    )


def _steady_then_step(model):
    """A steady state committed at t = 0, then a squeezing, turning state 50 us later."""
    first = model.solve(Kinematics((5e-6, 3e-6), (0.0, 0.0), OMEGA, 0.0), 0.0)
    model.commit_history(model.history_state(), 0.0)
    return first, model.solve(Kinematics((5.5e-6, 3.2e-6), (0.01, 0.004), OMEGA, 30.0), 5e-5)


def test_stiff_elastic_jfo_film_is_the_rigid_jfo_film():
    """A bushing 1e9 x stiffer than bronze (deformation ~1e-21 m): the coupled solve gives the rigid
    JFO film's forces and torques to 1e-7 (what the deformation and the solvers' tolerances leave:
    rigid and coupled residuals are the same midpoint sums, checked to 1e-15)."""
    with _elastic(E_BUSHING * 1e9) as stiff, _model("jfo", mesh_size=0.15) as rigid:
        for a, b in zip(_steady_then_step(stiff), _steady_then_step(rigid)):
            assert np.max(np.abs(_outputs(a) - _outputs(b))) <= 1e-7 * np.max(np.abs(_outputs(b)))
            assert a.cavitated_area_ratio == pytest.approx(b.cavitated_area_ratio, abs=1e-12)


def test_elastic_jfo_film_is_a_winkler_layer():
    """Bronze Winkler bushing: w = k (p + p_c) node by node with k = t (1 + nu)(1 - 2 nu)/(E (1 - nu))
    written out here, to 1e-9 of the largest w (the coupled solve's tolerance); the film ruptures."""
    k = T_BUSHING * (1 + NU_BUSHING) * (1 - 2 * NU_BUSHING) / (E_BUSHING * (1 - NU_BUSHING))
    with _elastic(E_BUSHING) as model:
        _, result = _steady_then_step(model)
        assert 0.2 < result.cavitated_area_ratio < 0.8
        w = model.fields_si()["deformation"].x.array
        p = model.fields_si()["pressure"].x.array
        p_c = (
            model.fields_si()["asperity_pressure"].x.array
            if "asperity_pressure" in model.fields_si()
            else 0.0
        )
        assert np.max(np.abs(w - k * (p + p_c))) <= 1e-9 * np.max(np.abs(w))
        assert np.max(np.abs(w)) > 1e-7  # micrometres under this load: the test is not the rigid one


def test_elastic_jfo_jacobian_matches_finite_differences():
    """Bronze Winkler bushing, the transient cavitated state: the exact Jacobian (the coupled Newton
    matrix and the JFO forms' derivatives) against central differences of solves that each start from
    the solution (so the solver's tolerance, 1e-10 of the flux, does not enter the difference), to
    1e-5 of each column (measured 1e-7 to 1e-9)."""
    with _elastic(E_BUSHING) as model:
        _, result = _steady_then_step(model)
        J = model.jacobian().matrix
        solution = model.history_state()
        x0 = np.array([5.5e-6, 3.2e-6, 0.01, 0.004, OMEGA - 30.0])

        def outputs(x):
            model.start_from(solution)
            return _outputs(model.solve(Kinematics((x[0], x[1]), (x[2], x[3]), x[4] + 30.0, 30.0), 5e-5))

        for k, step in enumerate((1e-10, 1e-10, 1e-5, 1e-5, 1e-2)):
            e = np.zeros(5)
            e[k] = step
            column = (outputs(x0 + e) - outputs(x0 - e)) / (2 * step)
            assert np.max(np.abs(J[:, k] - column)) <= 1e-5 * np.max(np.abs(column))


def test_elastic_jfo_steady_supply_flow_equals_side_flow():
    """Bronze Winkler bushing, steady rotation with an axial groove at 2 bar: supply = side flow to
    1e-9 (the coupled residual's fluxes balance as the rigid film's)."""
    groove = dict(
        groove="axial",
        groove_angle=math.pi / 2,
        groove_arc=math.radians(30),
        groove_length=0.01,
        supply_pressure=2e5,
    )
    with _elastic(E_BUSHING, **groove) as model:
        r = model.solve(Kinematics((6e-6, -2e-6), (0.0, 0.0), OMEGA, 0.0))
        assert r.cavitated_area_ratio > 0.1 and r.side_flow > 0 and r.max_deformation != 0
        assert abs(r.supply_flow - r.side_flow) <= 1e-9 * r.side_flow
