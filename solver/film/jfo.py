"""Mass-conserving cavitation (JFO, Elrod-Adams): one nodal unknown, semismooth Newton in PETSc SNES.

Equation (DESIGN 8), dimensionless as in ``solver.film.scaling`` (smooth surfaces, p_cav the cavitation
pressure, theta the film fraction)::

    d(theta H)/dT + div Q = f,    Q = -D grad P + theta H U,    D = H^3 (default)
    P - P_cav >= 0,   1 - theta >= 0,   (P - P_cav)(1 - theta) = 0

with U the mean surface velocity (the Couette transport velocity, U_m t on the bearing) and f an
optional supply per unit area (manufactured solutions). In the full film theta = 1 and this is the
Reynolds equation; in the cavitated zone P = P_cav and it is the transport of theta H.

Unknown. One value u per P1 node (Elrod's switch variable, as Woloszynski et al. 2015 obtain by
swapping the columns of the Fischer-Burmeister Jacobian node by node)::

    P - P_cav = max(u, 0),   theta = 1 + min(u, 0)

so the bounds and the complementarity hold exactly, node by node, whatever the iterate. The discrete
residual is piecewise linear in u, ``r(u) = K max(u, 0) + T (1 + min(u, 0)) + b``, and Newton's
method with its generalised Jacobian ``J = K diag(u > 0) + T diag(u <= 0)`` (the Reynolds column of a
pressurised node, the transport column of a cavitated one) stops at the exact solution of the
discrete problem once the partition is right. Both K (P1 Reynolds stiffness) and T (upwinded transport
plus storage) are Z-matrices with zero column sums on a non-obtuse mesh, so every such J (prescribed
rows replaced by identity rows) is an M-matrix as long as each node is linked to a prescribed node or
has storage: LU needs no pivoting. The switch ``u > 0`` is invariant under a scaling of P, so the
pressure and film-fraction scales need not be balanced. From the full film (the default start, whose
first Newton step is the Reynolds solution without cavitation) the pocketed slider of
data/jfo_pocket_slider.md takes 4 Newton iterations on 20 to 5120 cells; Fischer-Burmeister on the
stacked pair (P, theta) takes 11-13 (30-60 with a backtracking line search), needs MUMPS (PETSc's LU
meets zero pivots) and depends on the relative scaling of P and theta; ``vinewtonrsls`` on the
stacked pair (P >= P_cav paired with the row 1 - theta) did not converge. Time steps are warm
started from the last solution; a step that moves a front far takes more iterations, since a
wrongly cavitated zone is handed back to the full film one node layer per iteration.

Discretisation (the same forms on an interval mesh and on the 2D film surface):

- Poiseuille flow: P1 Galerkin ``K_ij = integral(D grad phi_j . grad phi_i)``.
- Couette transport, conservative: the Galerkin matrix ``C_ij = -integral(H phi_j U . grad phi_i)``
  (column sums zero: whatever leaves one node enters its neighbours) with Kuzmin's discrete
  upwinding ``d_ij = max(0, C_ij, C_ji)`` added as a symmetric, zero-sum edge diffusion. In 1D this
  is the finite-volume flux ``U H_f theta_upwind`` on the dual cells with H_f the gap *at the face*
  (the primal cell's gap, integrated by the quadrature inside the cell); the upstream node's gap would
  misplace reformation behind a step by (1/2)(h1/h0)^3 dx (data/jfo_pocket_slider.md).
- Limited transport (optional, ``limited`` of ``update``/``set_operator``; the bearing film's default in
  time): the upwinding's edge diffusion is scaled edge by edge by ``1 - alpha_ij`` with the factors of
  an algebraic flux-correction limiter (``TransportLimiter``) computed from a given film fraction (in
  time the previous one), so the transport is second order where theta is smooth and monotone and stays
  upwind at extrema and fronts; the scheme stays conservative and the residual piecewise linear in u.
- Storage, lumped: node i holds ``m_i theta_i`` with ``m_i = integral(H phi_i)`` (the gap volume of
  its dual cell), and ``d(theta H)/dT`` is implicit Euler on that content: ``(m theta - c_old)/dT``
  with ``c_old`` the previous step's content (``JFOSolution.content``). Without a time step the
  problem is steady.

Boundary conditions: on given dofs u is prescribed: a value > 0 is P - P_cav (flooded), a value <= 0
is theta - 1 (a starved inlet). The consistent flux through them, from the unconstrained residual,
makes the discrete balance exact: inflow - outflow = change of the stored oil + supply, to the
solver's tolerance.

Rate form (the bearing film in the engine, ``rate`` given). The storage term is split as
``d(theta H)/dT = H dtheta/dT + theta dH/dT`` with dH/dT from the kinematics (exact, as the
Reynolds squeeze term) and only dtheta/dT by implicit Euler: node i holds ``m_i (theta_i -
theta_old_i)/dT + mdot_i theta_i`` with ``mdot_i = integral(dH/dT phi_i)``. In the full film (theta =
theta_old = 1) this is the Reynolds equation with the squeeze term of the current velocity, so the
film forces and their Jacobian see the integrator's velocities, as with the Reynolds condition; the
stored oil's discrete balance then holds to O(dT^2) per step (the content form above: exactly).
Without a time step (quasi-static) the rate form keeps ``mdot theta``.

Flow factors and shear flow fit in as given by the caller: D a tensor (H^3 phi_x, H^3 phi_y), the
Couette flux per unit film fraction any vector (``flux``, default H U; with Patir-Cheng U_mean h_T +
U_d sigma phi_s along the sliding direction), H the stored gap (the mean gap h_T on rough surfaces).

Sensitivities (``sensitivities``): at a converged solution r(u; c) = 0 on its partition, for any
parameters c of the coefficients, ``du/dc = -J^-1 dr/dc`` with J the last Newton Jacobian (the
solution's partition) and dr/dc at fixed u from the caller (the bearing film takes them at the cell
midpoints, solver.film.jfo_midpoint.MidpointJFO: the derivatives of K, of the upwinded T, whose edge
diffusion follows the entry that is its maximum, and of the storage terms).

What the caller provides: a P1 space, H and U as UFL expressions (D optional), the prescribed dofs by
name, and per solve the time step and the previous content (or film fraction, rate form). Use the
solver as a context manager: PETSc destructors are collective.
"""

from __future__ import annotations

import dataclasses
import logging

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from solver.errors import FilmNotConverged
from solver.film.cavitation import configured_snes
from solver.film.jfo_limiter import LimitedTransport, TransportLimiter, upwind_pick

log = logging.getLogger(__name__)

DEFAULT_OPTIONS: dict[str, str | float | int] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",  # full semismooth steps: r is piecewise linear
    "snes_max_it": 100,
    "snes_divergence_tolerance": -1.0,  # an iterate far from the solution can have a large residual
    "ksp_type": "preonly",
    "pc_type": "lu",
}


@dataclasses.dataclass(frozen=True)
class JFOSolution:
    """One solve (dimensionless; arrays are the owned nodal values in dof order).

    Attributes:
        pressure: P - P_cav >= 0.
        theta: film fraction <= 1.
        content: oil content m theta of each node's dual cell: the history of the next time step.
        load: integral of (P - P_cav) over the film.
        outflow: net outward flux through each named set of prescribed dofs (negative: inflow).
        iterations: Newton iterations.
    """

    pressure: np.ndarray
    theta: np.ndarray
    content: np.ndarray
    load: float
    outflow: dict[str, float]
    iterations: int


class JFOSolver:
    """Mass-conserving film on a P1 space (see the module docstring).

    Args:
        V: scalar P1 function space (interval or surface mesh).
        H: film thickness (UFL expression; steps of H should lie on nodes).
        U: Couette transport velocity (UFL vector of the mesh's geometric dimension).
        prescribed: name -> (dofs, value) of u on those dofs (value > 0: P - P_cav; <= 0: theta - 1).
        D: Poiseuille coefficient (scalar or tensor), default H^3.
        f: supply per unit area (UFL scalar), default none.
        quadrature_degree: of all the forms (None: UFL's estimate).
        options: PETSc options merged over ``DEFAULT_OPTIONS``.
        flux: Couette flux per unit film fraction (UFL vector), default H U.
        rate: dH/dT (UFL scalar): the rate form of the storage (module docstring); None: content form.
    """

    def __init__(
        self,
        V: fem.FunctionSpace,
        H,
        U,
        prescribed: dict[str, tuple[np.ndarray, float]],
        *,
        D=None,
        f=None,
        quadrature_degree: int | None = None,
        options: dict | None = None,
        flux=None,
        rate=None,
    ):
        self.V = V
        self.comm = V.mesh.comm
        metadata = {} if quadrature_degree is None else {"quadrature_degree": quadrature_degree}
        dx = ufl.dx(domain=V.mesh, metadata=metadata)
        w, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        D = H**3 if D is None else D
        flux = H * U if flux is None else flux
        self._K_form = fem.form(ufl.inner(D * ufl.grad(w), ufl.grad(v)) * dx)
        self._C_form = fem.form(-w * ufl.inner(flux, ufl.grad(v)) * dx)
        self._m_form = fem.form(H * v * dx)
        self._f_form = None if f is None else fem.form(f * v * dx)
        self._rate_form = None if rate is None else fem.form(rate * v * dx)
        self.u = fem.Function(V, name="u")
        # a cold start from the full film: the first Newton step is the Reynolds solution without
        # cavitation, and the whole region where it is below P_cav cavitates at once (from u <= 0 the
        # pressurised zone would grow by one node layer per iteration)
        self.u.x.array[:] = 1.0
        self.pressure = fem.Function(V, name="pressure")  # P - P_cav
        self.theta = fem.Function(V, name="theta")
        # each dof's share of the film area, integral(phi_i): the load is their sum with P - P_cav (P1)
        areas = fem_petsc.assemble_vector(fem.form(v * dx))
        areas.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._areas = areas.getArray(readonly=True).copy()
        areas.destroy()
        self.n_owned = V.dofmap.index_map.size_local
        self.prescribed = {
            name: (np.asarray(dofs, dtype=np.int32), float(value))
            for name, (dofs, value) in prescribed.items()
        }
        bc_dofs = [d[d < self.n_owned] for d, _ in self.prescribed.values()]
        self._bc_local = np.unique(np.concatenate(bc_dofs)) if bc_dofs else np.zeros(0, dtype=np.int32)
        self._bc_values = np.zeros(self.n_owned)
        for dofs, value in self.prescribed.values():
            self._bc_values[dofs[dofs < self.n_owned]] = value
        self._bc_global = (self._bc_local + self.u.vector.getOwnershipRange()[0]).astype(PETSc.IntType)
        self.K = fem_petsc.create_matrix(self._K_form)
        self.T = fem_petsc.create_matrix(self._C_form)
        self.m = fem_petsc.create_vector(self._m_form)
        self.mdot = self.m.duplicate() if rate is not None else None
        self.b = self.m.duplicate()  # -c_old/dT - F
        self.r = self.m.duplicate()
        self._theta_vec, self._pressure_vec, self._mask = (
            self.m.duplicate(),
            self.m.duplicate(),
            self.m.duplicate(),
        )
        merged = {
            **DEFAULT_OPTIONS,
            "pc_factor_mat_solver_type": "mumps" if self.comm.size > 1 else "petsc",
            **(options or {}),
        }
        self.snes = configured_snes(self.comm, "jfo", merged)
        self.snes.setFunction(self._residual, self.r)
        self.update()
        # the Jacobian and a work matrix with K's pattern (T has the same: both P1 forms on V)
        self.J, self._work = self.K.duplicate(copy=True), self.K.duplicate(copy=True)
        self.J.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)  # zeroRows keeps the pattern
        self.snes.setJacobian(self._jacobian, self.J)
        self.snes.setConvergenceTest(self._converged)
        self._partition: np.ndarray | None = None  # u > 0 where the last Jacobian was built
        self._scale = 1.0  # the flux scale of the current solve (solve)
        self._Ts: PETSc.Mat | None = None  # T with the storage term of the current solve

    def set_prescribed(self, prescribed: dict[str, tuple[np.ndarray, float]]) -> None:
        """New values of u on the prescribed dofs (the same dofs): a new p_ref changes a supply's."""
        self.prescribed = {
            name: (np.asarray(dofs, dtype=np.int32), float(value))
            for name, (dofs, value) in prescribed.items()
        }
        for dofs, value in self.prescribed.values():
            self._bc_values[dofs[dofs < self.n_owned]] = value

    # -- assembly -------------------------------------------------------------------------------
    def update(self, limited: LimitedTransport | None = None) -> None:
        """Assemble K, T's Couette part and the nodal gap volumes m (call after H, U or D change);
        ``limited``: the film fraction's limited transport (TransportLimiter; serial), else upwind."""
        for A, form in ((self.K, self._K_form), (self.T, self._C_form)):
            A.zeroEntries()
            fem_petsc.assemble_matrix(A, form)
            A.assemble()
        self.couette = self.T.getValuesCSR()[2]  # before upwinding (a limiter's orientation; a new array)
        _upwind(self.T, limited)
        for vec, form in ((self.m, self._m_form), (self.mdot, self._rate_form)):
            if form is None:
                continue
            with vec.localForm() as local:
                local.set(0.0)
            fem_petsc.assemble_vector(vec, form)
            vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def set_operator(
        self,
        K_values: np.ndarray,
        C_values: np.ndarray,
        m: np.ndarray,
        mdot: np.ndarray | None,
        limited: LimitedTransport | None = None,
    ) -> None:
        """``update`` from values computed elsewhere (serial): K's and the Couette matrix's values in
        their CSR layout (``csr_layout``; C before upwinding), m and mdot at the dofs. The bearing film
        computes them at the cell midpoints (solver.film.jfo_midpoint.MidpointJFO), the forms' own rule."""
        self.couette = C_values  # before upwinding (the caller's array, not written to)
        indptr, indices = self.csr_layout()
        self.K.setValuesCSR(indptr, indices, K_values)
        self.K.assemble()
        self.T.setValuesCSR(indptr, indices, C_values)
        self.T.assemble()
        _upwind(self.T, limited)
        self.m.setArray(m)
        if self.mdot is not None:
            self.mdot.setArray(mdot)

    def csr_layout(self) -> tuple[np.ndarray, np.ndarray]:
        """(indptr, indices) of K and T (one pattern: both P1 forms on V)."""
        indptr, indices, _ = self.K.getValuesCSR()
        return indptr, indices

    def _set_history(self, dT: float | None, old: np.ndarray | None) -> PETSc.Mat:
        """b = -c_old/dT - F (content form) or -m theta_old/dT - F (rate form), and the storage m/dT
        (plus mdot in the rate form) on T's diagonal (returned: T with storage)."""
        b = np.zeros(self.n_owned)
        T = self.T.duplicate(copy=True)
        m = self.m.getArray(readonly=True)
        diagonal = np.zeros(self.n_owned)
        if dT is not None:
            if self.mdot is None:  # content form: old is the content m_n theta_n
                b -= (m if old is None else np.asarray(old)) / dT
            else:  # rate form: old is theta_n
                b -= m * (1.0 if old is None else np.asarray(old)) / dT
            diagonal += m / dT
        if self.mdot is not None:
            diagonal += self.mdot.getArray(readonly=True)
        if dT is not None or self.mdot is not None:
            storage = self.m.duplicate()
            storage.setArray(diagonal)
            T.setDiagonal(storage, addv=PETSc.InsertMode.ADD)
            T.assemble()
            storage.destroy()
        if self._f_form is not None:
            F = fem_petsc.assemble_vector(self._f_form)
            F.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            b -= F.getArray(readonly=True)
            F.destroy()
        self.b.setArray(b)
        return T

    # -- nonlinear residual and its generalised Jacobian ----------------------------------------
    def _split(self, x: PETSc.Vec) -> np.ndarray:
        u = x.getArray(readonly=True)
        self._pressure_vec.setArray(np.maximum(u, 0.0))
        self._theta_vec.setArray(1.0 + np.minimum(u, 0.0))
        return u

    def _unconstrained(self, x: PETSc.Vec, r: PETSc.Vec) -> None:
        """r = K (P - P_cav) + T theta + b: minus the net outflow of each node's dual cell."""
        self._split(x)
        self.K.mult(self._pressure_vec, r)
        self._Ts.multAdd(self._theta_vec, r, r)
        r.axpy(1.0, self.b)

    def _residual(self, snes, x: PETSc.Vec, r: PETSc.Vec) -> None:
        self._unconstrained(x, r)
        if len(self._bc_local):
            values = r.getArray()
            values[self._bc_local] = (
                x.getArray(readonly=True)[self._bc_local] - self._bc_values[self._bc_local]
            )
            r.setArray(values)

    def _jacobian(self, snes, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        u = x.getArray(readonly=True)
        self._partition = u > 0.0
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        self.K.copy(J, structure=same)
        self._mask.setArray((u > 0.0).astype(float))
        J.diagonalScale(None, self._mask)
        self._Ts.copy(self._work, structure=same)
        self._mask.setArray((u <= 0.0).astype(float))
        self._work.diagonalScale(None, self._mask)
        J.axpy(1.0, self._work, structure=same)
        J.zeroRows(self._bc_global, diag=1.0)

    def _converged(self, snes, iteration: int, norms) -> int:
        """Converged when the last Newton step kept the partition (pressurised / cavitated) it was
        computed with: r is linear on that partition, so the step solved r = 0 exactly (up to the
        LU's round-off, which a residual check against the size of the terms bounds). A warm start
        that already solves the problem (|r| <= 1e-12 of the flux scale) passes at iteration 0."""

        def kept() -> bool:
            x = snes.getSolution()
            same = bool(np.array_equal(x.getArray(readonly=True) > 0.0, self._partition))
            return self.comm.allreduce(same, op=MPI.LAND) and norms[2] <= 1e-8 * self._terms(x)

        return semismooth_reason(snes, iteration, norms[2], 1e-12 * self._scale, self._partition, kept)

    def _terms(self, x: PETSc.Vec) -> float:
        """|K (P - P_cav)| + |T theta| + |b|: the size of the terms whose sum is the residual."""
        self._split(x)
        work = self.r.duplicate()
        self.K.mult(self._pressure_vec, work)
        size = work.norm()
        self._Ts.mult(self._theta_vec, work)
        size += work.norm() + self.b.norm()
        work.destroy()
        return size

    # -- solve ----------------------------------------------------------------------------------
    def solve(
        self,
        dT: float | None = None,
        content_old: np.ndarray | None = None,
        start: np.ndarray | None = None,
        theta_old: np.ndarray | None = None,
    ) -> JFOSolution:
        """Solve one (implicit Euler) step, or the steady problem when ``dT`` is None.

        Args:
            dT: time step (dimensionless); None: steady.
            content_old: content form: the previous step's ``JFOSolution.content`` (default: full
                film, m of the current gap).
            start: initial u (owned values); default: the last solution (the full film, u = 1, at
                the first solve).
            theta_old: rate form: the previous step's film fraction (default: full film).

        Raises:
            FilmNotConverged: SNES stopped without convergence.
        """
        if self.mdot is None and theta_old is not None or self.mdot is not None and content_old is not None:
            raise ValueError(
                "JFOSolver.solve: theta_old with the rate form, content_old with the content form"
            )
        if self._Ts is not None:  # (kept after a solve for its sensitivities)
            self._Ts.destroy()
        self._Ts = self._set_history(dT, content_old if self.mdot is None else theta_old)
        x = self.u.vector
        if start is not None:
            x.setArray(start)
        values = x.getArray()
        values[self._bc_local] = self._bc_values[self._bc_local]
        x.setArray(values)
        # convergence: |r| below 1e-12 of the flux scale, the residual of the film at zero gauge
        # pressure (theta = 1 inside, the prescribed values on the boundary)
        reference = x.duplicate()
        reference.setArray(np.where(np.isin(np.arange(self.n_owned), self._bc_local), values, 0.0))
        self._unconstrained(reference, self.r)
        scale = self.r.norm()
        reference.destroy()
        self._scale, self._partition = scale, None
        self.snes.solve(None, x)
        reason, iterations = self.snes.getConvergedReason(), self.snes.getIterationNumber()
        if reason <= 0:
            raise FilmNotConverged("mass-conserving film did not converge", reason, iterations)
        # consistent fluxes: outflow = -r of the unconstrained residual, summed over the set
        self._unconstrained(x, self.r)
        log.debug("JFO film: %d Newton iterations (SNES reason %d)", iterations, reason)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        u = self.u.x.array
        self.pressure.x.array[:] = np.maximum(u, 0.0)
        self.theta.x.array[:] = 1.0 + np.minimum(u, 0.0)
        r = self.r.getArray(readonly=True)
        outflow = {
            name: -self.comm.allreduce(float(np.sum(r[dofs[dofs < self.n_owned]])), op=MPI.SUM)
            for name, (dofs, _) in self.prescribed.items()
        }
        n = self.n_owned
        theta = self.theta.x.array[:n].copy()
        return JFOSolution(
            pressure=self.pressure.x.array[:n].copy(),
            theta=theta,
            content=self.m.getArray(readonly=True) * theta,
            load=self.comm.allreduce(float(self._areas @ self.pressure.x.array[:n]), op=MPI.SUM),
            outflow=outflow,
            iterations=iterations,
        )

    # -- sensitivities --------------------------------------------------------------------------
    def sensitivities(self, dr: list[np.ndarray]) -> list[np.ndarray]:
        """d(P - P_cav)/dc = -diag(u > 0) J^-1 dr/dc at the last solution, with J its Newton
        Jacobian (built again if the solution's partition is not the last one's)."""
        return [pressure for pressure, _ in self.split_sensitivities(dr)]

    def split_sensitivities(self, dr: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
        """(d(P - P_cav)/dc, dtheta/dc) per dr/dc at the last solution: du/dc = -J^-1 dr/dc split by
        the partition, the pressure's part on the pressurised nodes (u > 0) and the film fraction's on
        the others (theta = 1 + u there; zero on the prescribed dofs, whose rows of dr are zero)."""
        x = self.u.vector
        partition = x.getArray(readonly=True) > 0.0
        ksp = self.snes.getKSP()
        if self._partition is None or not np.array_equal(partition, self._partition):
            self._jacobian(self.snes, x, self.J, self.J)
            ksp.setOperators(self.J)
        rhs, du = self.r.duplicate(), self.r.duplicate()
        out = []
        for d in dr:
            rhs.setArray(-np.asarray(d))
            ksp.solve(rhs, du)
            values = du.getArray(readonly=True)
            out.append((np.where(partition, values, 0.0), np.where(partition, 0.0, values)))
        rhs.destroy()
        du.destroy()
        return out

    # -- lifetime -------------------------------------------------------------------------------
    def close(self) -> None:
        for obj in (
            self.snes,
            self.K,
            self.T,
            self.J,
            self._work,
            self.m,
            self.b,
            self.r,
            self._theta_vec,
            self._pressure_vec,
            self._mask,
            self.mdot,
            self._Ts,
        ):
            if obj is not None:
                obj.destroy()

    def __enter__(self) -> JFOSolver:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def semismooth_reason(snes: PETSc.SNES, iteration: int, fnorm: float, atol: float, partition, kept) -> int:
    """The SNES reason of a semismooth Newton iteration on a piecewise-linear residual: converged when
    |r| <= atol (a warm start that already solves the problem passes at iteration 0), or when the last
    step kept the partition it was computed with (``partition``: u > 0 where the last Jacobian was
    built; ``kept()``: that step kept it and left r at round-off); diverged on a non-finite residual
    or at the iteration limit."""
    if not np.isfinite(fnorm):
        return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
    if fnorm <= atol:
        return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
    if iteration > 0 and partition is not None and kept():
        return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_RELATIVE  # (no reason of its own)
    if iteration >= snes.getTolerances()[3]:
        return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
    return PETSc.SNES.ConvergedReason.ITERATING


def _upwind(C: PETSc.Mat, limited: LimitedTransport | None = None) -> None:
    """Kuzmin's discrete upwinding of the convection matrix C (residual convention, in place).

    Adds the edge diffusion ``d_ij = max(0, C_ij, C_ji)`` (i != j): ``C_ij -= d_ij``, ``C_ii += d_ij``.
    It is symmetric with zero row and column sums, so the scheme stays conservative, and afterwards
    every off-diagonal entry is <= 0 (the upwind flux). Needs a structurally symmetric pattern (P1).
    With ``limited`` (serial) each edge's diffusion is scaled by ``1 - alpha_ij`` (TransportLimiter).
    """
    Ct = C.transpose(PETSc.Mat())
    indptr, cols, values = C.getValuesCSR()
    indptr_t, cols_t, values_t = Ct.getValuesCSR()
    if not (np.array_equal(indptr, indptr_t) and np.array_equal(cols, cols_t)):
        raise ValueError("discrete upwinding needs a structurally symmetric matrix")
    start = C.getOwnershipRange()[0]
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr)) + start
    off = cols != rows
    d = np.where(off, np.maximum(0.0, np.maximum(values, values_t)), 0.0)
    if limited is not None:
        if C.getComm().getSize() != 1:
            raise ValueError("the limited film-fraction transport is serial")
        d = d * limited.factor(upwind_pick(values, values_t, rows, cols))
    upwinded = values - d
    row_sums = np.add.reduceat(d, indptr[:-1]) if len(d) else np.zeros(0)
    row_sums[np.diff(indptr) == 0] = 0.0
    upwinded[~off] += row_sums[rows[~off] - start]
    C.setValuesCSR(indptr, cols, upwinded)
    C.assemble()
    Ct.destroy()


__all__ = [
    "JFOSolution",
    "JFOSolver",
    "LimitedTransport",
    "TransportLimiter",
    "semismooth_reason",
    "upwind_pick",
]
