"""The elastic bushing coupled to the film (solver.film.ehd): exact Jacobians, the Winkler law, the rigid
limit."""

from __future__ import annotations

import math

from mpi4py import MPI

import numpy as np
import pytest

from solver.film.bearing import Bearing, FilmModel, Kinematics
from solver.film.bushings import WinklerLayer
from solver.film.coupled_reynolds import ReynoldsRows
from solver.film.history import FilmHistory
from solver.film.surface import Surface

R, C, MU, OMEGA = 0.01, 10e-6, 0.01, 200.0
BRONZE = dict(thickness=1.5e-3, E=115e9, nu=0.33)  # the reference small end's bushing


def _rough():
    surface = Surface(sigma_journal=0.1e-6, sigma_bushing=0.3e-6)
    return dict(roughness=surface.roughness(), contact=surface.contact())


# a mixed-lubrication state of the engine's small end: rigid h_min = 0.3 um (h/sigma = 0.95), squeeze,
# both surfaces turning
MIXED = Kinematics(
    (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)),
    (0.05 * C * OMEGA, -0.1 * C * OMEGA),
    0.2 * OMEGA,
    -0.3 * OMEGA,
)


@pytest.mark.serial
def test_coupled_jacobian_matches_finite_differences_of_the_residual():
    """Every block of the coupled Jacobian (Reynolds in pressure and deformation, compliance, asperity
    forces) against forward differences of the coupled residual, at a generic point near the solution
    of the mixed state (rough, contact). Forward steps of 1e-7 relative give truncation errors ~1e-7 of
    the block's largest entry on these smooth functions (the VI bound is not in the residual);
    tolerance 1e-5 of the block's largest entry."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.25, elastic=WinklerLayer(**BRONZE), **_rough()
    ) as model:
        model.solve(MIXED)
        film = model.solver.ehd
        rng = np.random.default_rng(1)
        x = film.x.getArray().copy()  # the solution
        x[: film.n] += 0.01 * rng.random(film.n) * np.max(x[: film.n])
        x[film.op.bc_dofs] = film.op.bc_values[film.op.bc_dofs]  # the residual assumes the Dirichlet values
        r0 = film.residual(x)
        J = film.jacobian_matrix().toarray()
        J_fd = np.zeros_like(J)
        for j in range(film.N):
            step = 1e-7 * max(1.0, abs(x[j]))
            shifted = x.copy()
            shifted[j] += step
            J_fd[:, j] = (film.residual(shifted) - r0) / step
    n = film.n
    for rows in (slice(0, n), slice(n, None)):
        for cols in (slice(0, n), slice(n, None)):
            scale = np.abs(J_fd[rows, cols]).max()
            assert np.abs(J[rows, cols] - J_fd[rows, cols]).max() <= 1e-5 * scale, (rows, cols)


@pytest.mark.serial
def test_elastic_film_jacobian_in_asperity_contact_matches_finite_differences(film_differences):
    """The film's Jacobian with respect to the kinematics (active set frozen) with the bushing's
    deformation solved with the pressure, against central differences of full coupled solves, at the
    mixed state, where the deformation and the asperity pressure feed back on each other (the film
    kinds' test, tests/film/test_film_kinds.py, checks every kind at a hydrodynamic state). Tolerance
    1e-4 of each row's largest entry (the rigid film's mixed-state tolerance, same steps)."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    base, steps = MIXED, np.array([3e-6 * C] * 2 + [3e-6 * C * OMEGA] * 2 + [3e-6 * OMEGA])
    with FilmModel(
        bearing,
        MPI.COMM_SELF,
        omega_ref=OMEGA,
        mesh_size=0.1,
        elastic=WinklerLayer(**BRONZE),
        **_rough(),
    ) as model:
        result = model.solve(base)
        assert result.max_deformation > 0.02 * C  # the deformation matters at this state
        assert result.asperity_load > 0
        J = model.jacobian().matrix
        J_fd = film_differences(model, base, steps)
    for row in range(4):
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-4 * scale, (row, J[row], J_fd[row])


@pytest.mark.serial
def test_winkler_deformation_is_k_times_pressure():
    """Smooth film (no asperities): the solved deformation is w = k p at every node with the Winkler
    law in SI, k = t (1 + nu)(1 - 2 nu) / (E (1 - nu)) computed here: checks the coupled equations are
    solved (to the VI tolerance, 1e-10) and the scaling between the film's units and the layer's."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    t, E, nu = BRONZE["thickness"], BRONZE["E"], BRONZE["nu"]
    k = t * (1 + nu) * (1 - 2 * nu) / (E * (1 - nu))
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=WinklerLayer(**BRONZE)
    ) as model:
        result = model.solve(Kinematics((0.0, -0.9 * C), (0.0, -0.1 * C * OMEGA), OMEGA, 0.0))
        fields = model.fields_si()
        p, w = fields["pressure"].x.array, fields["deformation"].x.array
    assert result.max_deformation == pytest.approx(np.max(w), rel=1e-12)
    assert np.max(w) > 0.05 * C
    assert np.abs(w - k * p).max() <= 1e-9 * np.max(w)


@pytest.mark.serial
def test_very_stiff_bushing_gives_the_rigid_film():
    """Rigid limit: a bushing 1e9 times stiffer deforms by ~1e-16 m at this state, so forces, torques,
    peak pressure and h_min equal the rigid solver's to 1e-6 (the issue's bound; the difference is
    ~1e-10 plus the VI tolerance)."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    stiff = WinklerLayer(thickness=BRONZE["thickness"], E=BRONZE["E"] * 1e9, nu=BRONZE["nu"])
    results = []
    for elastic in (None, stiff):
        with FilmModel(
            bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=elastic, **_rough()
        ) as model:
            results.append(model.solve(MIXED))
    rigid, elastic = results
    for name in ("force", "hydro_force", "asperity_force"):
        assert np.allclose(getattr(elastic, name), getattr(rigid, name), rtol=0, atol=1e-6 * rigid.load), name
    for name in ("torque_journal", "torque_bushing", "p_max", "h_min"):
        assert getattr(elastic, name) == pytest.approx(getattr(rigid, name), rel=1e-6), name


@pytest.mark.serial
def test_the_solve_tolerance_leaves_forces_and_torques_unchanged(monkeypatch):
    """ReynoldsRows.TOLERANCE (the coupled residual at which a solve stops, 1e-8 of the film's source)
    against a solve to 1e-13 from the same warm start (the mixed state, from a neighbour 1e-5 c and
    1e-3 rad away): the default stops an iteration earlier (quadratic Newton: its last step is the one
    the tighter tolerance adds), and the forces and torque agree to 1e-6 of themselves (the residual
    left is 1e-8 of the source times the film's conditioning: 3e-8 measured)."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    neighbour = Kinematics(
        (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)),
        MIXED.ecc_rate,
        MIXED.omega_journal,
        MIXED.omega_bushing,
    )
    target = Kinematics(
        (0.97001 * C * math.cos(-1.399), 0.97001 * C * math.sin(-1.399)),
        MIXED.ecc_rate,
        MIXED.omega_journal,
        MIXED.omega_bushing,
    )
    out = {}
    for tolerance in (ReynoldsRows.TOLERANCE, 1e-13):
        monkeypatch.setattr(ReynoldsRows, "TOLERANCE", tolerance)
        with FilmModel(
            bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=WinklerLayer(**BRONZE), **_rough()
        ) as model:
            model.solve(neighbour)
            out[tolerance] = model.solve(target)
    default, tight = out.values()
    assert default.iterations < tight.iterations
    assert np.allclose(default.force, tight.force, rtol=0, atol=1e-6 * tight.load)
    assert default.torque_journal == pytest.approx(tight.torque_journal, rel=1e-6)


@pytest.mark.serial
def test_the_jacobian_after_a_one_iteration_solve_is_the_solutions():
    """A warm solve that converges in one Newton iteration has factorised its Jacobian at the start
    only; the film's Jacobian for the integrator is evaluated at the solution all the same: equal to
    the one after a cold solve of the same state to 1e-6 of each row's largest entry (measured 3e-8,
    the two solutions differing by the solve tolerance; at the start's factorisation 3e-4)."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    neighbour = Kinematics(
        (0.97001 * C * math.cos(-1.39999), 0.97001 * C * math.sin(-1.39999)),
        MIXED.ecc_rate,
        MIXED.omega_journal,
        MIXED.omega_bushing,
    )
    base = Kinematics(
        (0.97 * C * math.cos(-1.4), 0.97 * C * math.sin(-1.4)),
        MIXED.ecc_rate,
        MIXED.omega_journal,
        MIXED.omega_bushing,
    )
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=WinklerLayer(**BRONZE), **_rough()
    ) as model:
        model.solve(base)
        cold = model.jacobian().matrix
        model.solve(neighbour)
        assert model.solve(base).iterations == 1
        warm = model.jacobian().matrix
    scale = np.abs(cold).max(axis=1, keepdims=True)
    assert np.all(np.abs(warm - cold) <= 1e-6 * scale)


@pytest.mark.serial
def test_elastic_bushing_carries_less_at_the_same_eccentricity_and_converges_cold():
    """At the mixed state the compliant bushing spreads the load: the peak pressure falls several-fold
    (rigid 1.3 GPa) and the asperities carry less; the cold coupled solve converges (limited steps of
    the semismooth Newton method), within the cavitation bound."""
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    out = {}
    for name, elastic in (("rigid", None), ("elastic", WinklerLayer(**BRONZE))):
        with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, elastic=elastic, **_rough()) as model:
            out[name] = model.solve(MIXED)
            if elastic is not None:
                assert np.min(model.P.x.array) >= -1e-12
    assert out["elastic"].p_max < 0.25 * out["rigid"].p_max
    assert out["elastic"].asperity_load < out["rigid"].asperity_load


@pytest.mark.serial
def test_deformation_rate_is_implicit_euler_from_the_committed_state(film_differences):
    """The deformation's rate in the squeeze term, (W - W_n) / (t - t_n) from the committed state:

    * steady: committing the quasi-static solution and solving the same kinematics later gives it
      back (zero rate) to the VI tolerance (1e-8 relative);
    * from the deformation of a lighter load (eps 0.8) to eps 0.9, the squeeze of the deforming
      bushing holds the deformation back: its change grows with the time step, and for a step long
      against the film's time scale (1e3 s) it is the quasi-static one (1e-6 relative);
    * the film's Jacobian with the rate term against central differences (as without it, 1e-5).
    """
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    kin = lambda eps: Kinematics((0.0, -eps * C), (0.0, 0.0), OMEGA, 0.0)  # noqa: E731
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=WinklerLayer(**BRONZE)
    ) as model:
        n = model.dofs
        deformation = lambda: model.fields_si()["deformation"].x.array.copy()  # noqa: E731
        steady = model.solve(kin(0.9))
        state, quasi_static = model.history_state(), deformation()
        model.commit_history(state, 0.0)
        again = model.solve(kin(0.9), 1e-4)
        assert np.abs(deformation() - quasi_static).max() <= 1e-8 * np.abs(quasi_static).max()
        assert again.load == pytest.approx(steady.load, rel=1e-8)
        model.solve(kin(0.8))
        lighter, lighter_w = model.history_state(), deformation()
        assert len(lighter) > n  # pressure, then the elastic unknowns
        changes = []
        for dt in (1e-6, 1e-5, 1e-4, 1e3):
            model.commit_history(lighter, 0.0)
            model.solve(kin(0.9), dt)
            changes.append(np.abs(deformation() - lighter_w).max())
        assert changes[0] < changes[1] < changes[2] < changes[3]
        assert np.abs(deformation() - quasi_static).max() <= 1e-6 * np.abs(quasi_static).max()
        # the Jacobian with the rate term (dt = 1e-5 s: the rate term matters)
        model.commit_history(lighter, 0.0)
        base = Kinematics((0.3 * C, -0.85 * C), (0.1 * C * OMEGA, -0.2 * C * OMEGA), OMEGA, 0.3 * OMEGA)
        model.solve(base, 1e-5)
        J = model.jacobian().matrix
        steps = np.array([1e-4 * C] * 2 + [1e-4 * C * OMEGA] * 2 + [1e-4 * OMEGA])
        J_fd = film_differences(model, base, steps, 1e-5)
    for row in range(4):
        scale = np.abs(J_fd[row]).max()
        assert np.abs(J[row] - J_fd[row]).max() <= 1e-5 * scale, (row, J[row], J_fd[row])


@pytest.mark.serial
def test_a_state_solved_again_at_its_commit_time_keeps_its_rate():
    """The integrator commits the state at the end of every accepted step and the next step (or the
    outputs) may solve that same state again at the same time: the rate must then come from the commit
    before (implicit Euler over the same step), giving the committed solution back (VI tolerance, 1e-8
    relative), and not the quasi-static one (which differs by the squeeze of the deforming bushing:
    more than 1 % here). Committing at an earlier time drops the later commits (a replayed history).
    """
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    kin = lambda eps: Kinematics((0.0, -eps * C), (0.0, 0.0), OMEGA, 0.0)  # noqa: E731
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=WinklerLayer(**BRONZE)
    ) as model:
        model.solve(kin(0.8))
        lighter = model.history_state()
        quasi_static = model.solve(kin(0.9)).load
        model.commit_history(lighter, 0.0)
        stepped = model.solve(kin(0.9), 1e-5)
        assert abs(stepped.load - quasi_static) > 1e-2 * quasi_static  # the rate matters at this step
        model.commit_history(model.history_state(), 1e-5)
        assert model.solve(kin(0.9), 1e-5).load == pytest.approx(stepped.load, rel=1e-8)
        # replayed from 0: the commit at 1e-5 is gone, a solve at 1e-5 steps from the state at 0 again
        model.commit_history(lighter, 0.0)
        model.solve(kin(0.95), 1e-5)
        model.commit_history(lighter, 0.0)
        assert model.solve(kin(0.9), 1e-5).load == pytest.approx(stepped.load, rel=1e-8)


def test_history_reports_a_step_whose_rate_fell_to_implicit_euler():
    """FilmHistory.commit says when the step ending at a new time was more than BDF2_MAX_RATIO times the
    one before (the rate over it was implicit Euler, as ``rate`` takes it): never for the first two
    commits, nor for a commit that replaces one at the same time (an output after its step); at a ratio
    of 2.25 not, at 2.5 yes (exact binary fractions)."""
    history = FilmHistory()
    state = np.zeros(3)
    assert not history.commit(state, 0.0)
    assert not history.commit(state, 1.0)  # one step before it: Euler by necessity, not counted
    assert not history.commit(state, 3.25)  # ratio 2.25
    inverse_step, _ = history.rate(3.25 + 2.5 * 2.25, lambda t, x: x)
    assert inverse_step == 1.0 / (2.5 * 2.25)  # the rate at ratio 2.5 is implicit Euler's 1/h
    assert history.commit(state, 3.25 + 2.5 * 2.25)  # and its commit says so
    assert not history.commit(state, 3.25 + 2.5 * 2.25)  # the same time again: replaced, not a step


@pytest.mark.serial
def test_deformation_rate_is_second_order_in_the_step():
    """A Winkler film under a prescribed squeeze, eps = 0.8 + 0.15 sin(2 pi t / T) with T = 2 ms (the
    deformation lags the load: the rate term matters), committed after every step of N over T/4: the
    deformation at T/4 against N = 640 converges with order 2 (BDF2 through the two last commits;
    implicit Euler, the first step, measured 1.02-1.10), tolerance 0.3 on the order; at N = 10 the
    error is below 0.5 % (Euler: 2.1 %)."""
    T = 2e-3

    def kin(t):
        eps = 0.8 + 0.15 * math.sin(2 * math.pi * t / T)
        rate = 0.15 * 2 * math.pi / T * math.cos(2 * math.pi * t / T)
        return Kinematics((0.0, -eps * C), (0.0, -rate * C), OMEGA, 0.0)

    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.2, elastic=WinklerLayer(**BRONZE)
    ) as model:

        def deformation_at_quarter_period(steps: int) -> np.ndarray:
            model.solve(kin(0.0))
            model.commit_history(model.history_state(), 0.0)
            for k in range(1, steps + 1):
                t = T / 4 * k / steps
                model.solve(kin(t), t)
                model.commit_history(model.history_state(), t)
            return model.fields_si()["deformation"].x.array.copy()

        reference = deformation_at_quarter_period(640)
        errors = [
            np.abs(deformation_at_quarter_period(n) - reference).max() / np.abs(reference).max()
            for n in (10, 20, 40)
        ]
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(2)]
    assert errors[0] < 5e-3
    assert all(abs(order - 2) < 0.3 for order in orders), (errors, orders)


@pytest.mark.serial
def test_fe_deformation_is_the_compliance_applied_to_the_nodal_forces(coarse_eye):
    """With every mode kept, the solved deformation at the film's nodes is T G T^T F, with G the
    compliance matrix, T its interpolation to the film's nodes and F the nodal forces a_i p_i of the
    solved pressure (SI, formed here from the output fields): checks the modal coupling and its
    scaling against the compliance itself, to the VI tolerance (1e-8 of max w)."""
    from solver.film.bushings import ModalCompliance

    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    elastic = ModalCompliance(coarse_eye, coarse_eye.size)
    with FilmModel(bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.1, elastic=elastic) as model:
        model.solve(Kinematics((0.0, -0.9 * C), (0.0, -0.1 * C * OMEGA), OMEGA, 0.0))
        fields = model.fields_si()
        p, w = fields["pressure"].x.array, fields["deformation"].x.array
        x = model.space.owned_coords
        areas = model.forms.operator.T_f @ np.ones(len(model.forms.operator.cells)) * R**2
    T = coarse_eye.interpolation(np.arctan2(x[:, 1], x[:, 0]), x[:, 2] * R)
    expected = T @ (coarse_eye.matrix @ (T.T @ (areas * p)))
    assert np.max(np.abs(w)) > 0.05 * C
    assert np.abs(w - expected).max() <= 1e-8 * np.abs(expected).max()


@pytest.mark.serial
def test_schur_complement_gives_the_whole_lu_iterates(coarse_eye, monkeypatch):
    """SchurLU (the coupled VI's reduced systems by the Schur complement of the film block, for a few
    modes) against an LU of the whole coupled matrix (MUMPS, the method before it): from a cold start at
    the mixed state (rough, contact: the pin in asperity contact; on this coarse film half of the film
    block's factorisations meet a zero pivot of PETSc's LU, and SchurLU takes MUMPS for those) and along
    warm starts, the same
    Newton iterations, the same pressure and deformation to 1e-9 of their largest values (the same
    linear systems, solved in another order), and the same Jacobian to 1e-8 of each row's largest entry
    (the sensitivities reuse the factorisation). Both ways of solving the Schur system are taken (the
    run must count both): directly with the complement of its own factorisation, and by GMRES
    preconditioned with an earlier one (to 1e-12, so the Newton iterates do not change). A complement
    made non-finite before the third state's solve (as a failed factorisation leaves it) is formed
    anew: that solve's iterates do not change either."""
    from solver.film.bushings import ModalCompliance
    from solver.film.coupled_lu import SchurLU

    packages = []
    factor_film_block = SchurLU._factor_film_block

    def recorded(self):
        factor_film_block(self)
        packages.append(self._package)

    monkeypatch.setattr(SchurLU, "_factor_film_block", recorded)
    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    states = [MIXED] + [
        Kinematics(tuple(np.array(MIXED.ecc) * f), MIXED.ecc_rate, MIXED.omega_journal, MIXED.omega_bushing)
        for f in (0.99, 0.97, 1.005)
    ]
    runs = []
    for whole in (False, True):
        with FilmModel(
            bearing,
            MPI.COMM_SELF,
            omega_ref=OMEGA,
            mesh_size=0.1,
            elastic=ModalCompliance(coarse_eye, 24),
            **_rough(),
        ) as model:
            assert isinstance(model.solver.ehd.block.lu, SchurLU)
            if whole:
                model.solver.ehd.block.use_whole_lu()
            out = []
            for k, state in enumerate(states):
                if k == 2 and not whole:  # a failed complement (NaN) is formed anew, not used to precondition
                    lu = model.solver.ehd.block.lu
                    lu.S = (np.full_like(lu.S[0], np.nan), lu.S[1])
                result = model.solve(state)
                out.append((result.iterations, model.solver.ehd.state(), model.jacobian().matrix))
            runs.append(out)
            if not whole:
                lu = model.solver.ehd.block.lu
                assert lu.n_formed >= 2 and lu.n_krylov > 0, (lu.n_formed, lu.n_krylov)
            if not whole:  # the modal blocks as dense arrays against the sparse products (1e-12), at the
                film = (
                    model.solver.ehd
                )  # solution's pressure with the deformation removed: the rigid gap, in contact
                film.residual(np.concatenate([film.state()[: film.n], np.zeros(film.m)]))
                dense = film.jacobian_matrix().toarray()
                film.dense = False
                sparse = film.jacobian_matrix().toarray()
                film.dense = True
                assert np.abs(dense - sparse).max() <= 1e-12 * np.abs(sparse).max()
                assert (
                    np.count_nonzero(sparse[film.n :, film.n :] - np.identity(film.m)) > 0
                )  # (contact in J_qq)
    assert "mumps" in packages and "petsc" in packages  # (both factorisations of the film block were taken)
    for (its, x, J), (its_ref, x_ref, J_ref) in zip(*runs):
        n = len(x) - 24
        assert its == its_ref
        assert np.abs(x[:n] - x_ref[:n]).max() <= 1e-9 * np.abs(x_ref[:n]).max()
        assert np.abs(x[n:] - x_ref[n:]).max() <= 1e-9 * np.abs(x_ref[n:]).max()
        assert np.all(np.abs(J - J_ref) <= 1e-8 * np.abs(J_ref).max(axis=1, keepdims=True))


@pytest.mark.serial
def test_a_failed_cold_start_of_the_elastic_reynolds_film_is_reported_as_such(monkeypatch):
    """A coupled solve that fails with no accepted state to continue from: the Reynolds block has no damped
    retry (the JFO block has), so the film reports FilmNotConverged, which the equilibrium search and the
    integrator handle (they step back). Found when the Reynolds block's damped LU (a preconditioner, not a
    retry) was taken for the retry: a TypeError and a traceback from `bearing --load` (the FE eye at 20 kN
    with an edge relief, compliance grid 72 x 9)."""
    from solver.errors import FilmNotConverged
    from solver.film.ehd import CoupledNewton

    def fail(self):
        raise FilmNotConverged("elastic film solve did not converge", -9, 33)

    bearing = Bearing(radius=R, width=2 * R, clearance=C, viscosity=MU, inlet="none")
    with FilmModel(
        bearing, MPI.COMM_SELF, omega_ref=OMEGA, mesh_size=0.25, elastic=WinklerLayer(**BRONZE)
    ) as model:
        monkeypatch.setattr(CoupledNewton, "solve", fail)
        with pytest.raises(FilmNotConverged, match="did not converge"):
            model.solve(Kinematics((0.0, -0.9 * C), (0.0, 0.0), OMEGA, 0.0))
