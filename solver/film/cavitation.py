"""Cavitation as a variational inequality: PETSc SNES VI for ``P >= P_cav`` (PETSc plumbing only).

The film problem is linear in P for given kinematics: the residual is ``r(P) = A P + l`` with the
Reynolds operator A and the source vector l (Couette, shear flow and squeeze terms). The Reynolds
(Swift-Stieber) cavitation condition makes it the complementarity problem (DESIGN 3.2)::

    P >= P_cav,   r(P) >= 0,   (P - P_cav) r(P) = 0

solved with PETSc's reduced-space active-set Newton method ``vinewtonrsls`` (basic line search: the
default line search stalls on this problem) and an LU factorisation of the reduced system. Because
the problem is linear, A and l are assembled once per change of kinematics (``update``), the SNES
callbacks only do ``A P + l``, and each solve starts from the previous pressure (warm start).

After a solve, the inactive (pressurised) set is known; with it frozen the problem is linear, so
the sensitivity of P to a parameter theta solves ``A_II dP_I = -(dr/dtheta)_I`` with ``dP = 0`` on
the active (cavitated) set and on Dirichlet dofs: the film's exact Jacobian for a few
back-substitutions (DESIGN 3.8).

What the caller provides: the compiled bilinear form ``a`` (the operator), the compiled linear form
``l`` (the source; ``r = a(P, v) + l(v)``), the pressure Function, the Dirichlet conditions and the
lower bound P_cav. Use the solver as a context manager: PETSc destructors are collective.
"""

from __future__ import annotations

import itertools
import logging
import weakref

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from solver.errors import FilmNotConverged

log = logging.getLogger(__name__)

DEFAULT_OPTIONS: dict[str, str | float | int] = {
    "snes_type": "vinewtonrsls",
    "snes_linesearch_type": "basic",  # the default (bt) line search stalls on the VI
    "snes_rtol": 1e-10,
    "snes_atol": 1e-10,
    "snes_stol": 0.0,
    "snes_max_it": 300,  # a cold start on a fine mesh hands the active set back a node layer per iteration
    "ksp_type": "preonly",
    "pc_type": "lu",
}

_instance_counter = itertools.count()


class FixedPatternLU:
    """Preconditioner (exact solver) for the reduced Newton systems of ``vinewtonrsls``.

    The reduced-space method solves ``A_II dP_I = -r_I`` on the inactive (pressurised) set I of each
    iteration. PETSc extracts A_II as a new matrix, whose nonzero pattern differs from the last one's,
    so a plain LU redoes ordering, symbolic and numeric factorisation every iteration. Here the full
    matrix K = A with the active rows and columns replaced by identity rows is factorised instead: its
    pattern never changes (PETSc's LU then refactorises numerically only), and ``K x = b`` with b = 0
    on the active set gives ``x_I = A_II^-1 b_I``, ``x_A = 0``: the same iterates. The factorisation of
    the converged inactive set also serves the sensitivities (``solve_full``).
    """

    def __init__(self, solver: "CavitatingSolver"):
        # a weak reference: the PC (owned by the solver's SNES) holds this object, so a strong one
        # would make a cycle through C that Python's garbage collector cannot see
        self.solver = weakref.proxy(solver)
        self.K = solver.A.duplicate(copy=True)
        self.K.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        self.ksp = PETSc.KSP().create(solver.comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType(_lu_package(solver.comm))
        self.b, self.x = self.K.createVecs()
        self.inactive: PETSc.IS | None = None  # of the current factorisation
        self.local: np.ndarray | None = None  # its owned entries, in the reduced vectors' order
        #: optional damping of the Newton step: ``limit(step) -> factor in (0, 1]`` on the full step
        #: (the coupled elastic film limits the change of the film thickness, solver.film.ehd)
        self.limit = None
        self.failed = False  # the last factorisation failed (see factor)

    def factor(self, inactive: PETSc.IS) -> None:
        """Numerically factorise K for this inactive set (owned global indices)."""
        A, K = self.solver.A, self.K
        A.copy(K, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        start, end = K.getOwnershipRange()
        keep = np.zeros(end - start, dtype=bool)
        keep[inactive.getIndices() - start] = True
        active = (np.flatnonzero(~keep) + start).astype(PETSc.IntType)
        K.zeroRowsColumns(active, diag=1.0)
        if self.failed:
            # MUMPS keeps the error of a failed factorisation (INFOG(1) < 0) and returns from every later
            # numeric factorisation at once, so one zero pivot would fail every later solve of this
            # film: a failed factorisation is started over, analysis included
            self.ksp.reset()
            self.failed = False
        self.ksp.setOperators(K)
        self.ksp.setUp()
        self.inactive = inactive
        self.local = inactive.getIndices() - start

    def solve_full(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x = K^-1 b (b must vanish on the active set of the factorisation)."""
        self.ksp.solve(b, x)
        reason = self.ksp.getConvergedReason()
        if reason < 0:  # a zero pivot: no Jacobian rather than a wrong one
            self.failed = True
            raise FilmNotConverged("film sensitivities: the LU factorisation failed", reason, 0)

    # -- PCShell interface (petsc4py's python PC) ------------------------------------------------
    def setUp(self, pc) -> None:  # noqa: N802 - PETSc's name
        self.factor(self.solver.snes.getVIInactiveSet())

    def apply(self, pc, x: PETSc.Vec, y: PETSc.Vec) -> None:
        # the reduced vectors hold, in order, the owned entries of the inactive set (owned indices)
        b = np.zeros(self.b.getLocalSize())
        b[self.local] = x.getArray(readonly=True)
        self.b.setArray(b)
        self.ksp.solve(self.b, self.x)
        step = self.x.getArray(readonly=True)
        if self.ksp.getConvergedReason() < 0 or not np.all(np.isfinite(step)):
            self.failed = self.failed or self.ksp.getConvergedReason() < 0
            y.set(float("nan"))  # a failed factorisation: a NaN step makes SNES diverge
            return
        factor = 1.0 if self.limit is None else self.limit(step)
        y.setArray(factor * step[self.local])

    def destroy(self, pc=None) -> None:
        for obj in (self.ksp, self.K, self.b, self.x):
            obj.destroy()


class ReducedShell:
    """The operator of a reduced Newton system of ``vinewtonrsls`` when FixedPatternLU solves it: a
    Python matrix of the reduced size with no entries. ``preonly`` applies only the preconditioner,
    which never applies its operator, so the sub-matrix PETSc would extract from the film matrix at
    every VI iteration (~0.05 ms at 1620 unknowns) is never used; a shell of the right size stands in
    for it."""

    def mult(self, mat, x, y) -> None:
        raise RuntimeError("the reduced operator is never applied (preonly with FixedPatternLU)")

    def createSubMatrix(self, mat, isrow, iscol=None, submat=None):  # noqa: N802 - PETSc's name
        n = isrow.getSize()
        if submat is not None and submat.getSize()[0] == n:
            return submat
        return PETSc.Mat().createPython(((n, n), (n, n)), ReducedShell(), comm=mat.getComm())


class _FilmShell(ReducedShell):
    """The SNES Jacobian of the fixed-pattern VI: applies the film matrix, gives empty reduced shells."""

    def __init__(self, A: PETSc.Mat):
        self.A = A

    def mult(self, mat, x, y) -> None:
        self.A.mult(x, y)


def configured_snes(comm, stem: str, options: dict) -> PETSc.SNES:
    """A new SNES with its own options prefix (``stem`` and a counter), set from ``options``; the global
    options database is left clean (FESTIM, PETSc issue 1201)."""
    snes = PETSc.SNES().create(comm)
    prefix = f"{stem}{next(_instance_counter)}_"
    snes.setOptionsPrefix(prefix)
    opts = PETSc.Options()
    for key, value in options.items():
        opts[prefix + key] = value
    snes.setFromOptions()
    for key in options:
        opts.delValue(prefix + key)
    return snes


def _lu_package(comm) -> str:
    """MUMPS in parallel; PETSc's own LU in serial (faster for these small 2D problems)."""
    if comm.size > 1:
        return "mumps"
    return "petsc"


class CavitatingSolver:
    """SNES VI for ``A P + l = 0`` with ``P >= P_cav`` (see the module docstring).

    Args:
        a: compiled bilinear form of the operator A.
        l: compiled linear form of the source l.
        P: the pressure Function (solution and warm start).
        bcs: Dirichlet conditions (ambient edges, supply holes).
        lower: the cavitation pressure P_cav (dimensionless).
        options: PETSc options merged over ``DEFAULT_OPTIONS``.
    """

    def __init__(
        self,
        a: fem.FormMetaClass,
        l: fem.FormMetaClass,
        P: fem.Function,
        bcs: list,
        lower: float,
        options: dict | None = None,
        fixed_pattern: bool = True,
        A: PETSc.Mat | None = None,
        assembler=None,
    ):
        #: replaces the dolfinx assembly of A and l when given: ``assembler(A, l_vector)`` (film.tensors)
        self.assembler = assembler
        self.a, self.l, self.P, self.bcs = a, l, P, bcs
        V = P.function_space
        self.comm = V.mesh.comm
        self.A = fem_petsc.create_matrix(a) if A is None else A
        self.rhs = fem_petsc.create_vector(l)
        self.residual_vec = fem_petsc.create_vector(l)
        self.lower = fem.Function(V)
        self.lower.x.array[:] = lower
        self.upper = fem.Function(V)
        self.upper.x.array[:] = PETSc.INFINITY
        # The bounds must not bind Dirichlet dofs whose value lies below P_cav.
        for bc in bcs:
            dofs = bc.dof_indices()[0]
            self.lower.x.array[dofs] = np.minimum(
                self.lower.x.array[dofs], bc.g.x.array[dofs] if hasattr(bc.g, "x") else lower
            )
        self.lower.x.scatter_forward()
        self._lower_value = lower
        merged = {**DEFAULT_OPTIONS, "pc_factor_mat_solver_type": _lu_package(self.comm), **(options or {})}
        self.snes = configured_snes(self.comm, "film", merged)
        self.snes.setFunction(self._residual, self.residual_vec)
        self.snes.setJacobian(self._jacobian, self.A)
        self.snes.setVariableBounds(self.lower.vector, self.upper.vector)
        # A warm start from a neighbouring solution can pass the convergence test at iteration 0
        # while the pressure where the film is thin (small H^3 weights in the residual) is stale:
        # always take one Newton step (exact for a linear problem with the right active set), and
        # measure the residual against the size of the source rather than an absolute 1e-10.
        self.snes.setForceIteration(True)
        self._rtol = float(merged["snes_rtol"])
        bc_values = [bc.g.x.array[bc.dof_indices()[0]] for bc in bcs if hasattr(bc.g, "x")]
        local_zero = all(np.all(v == 0.0) for v in bc_values) and len(bc_values) == len(bcs)
        self._homogeneous = lower == 0.0 and self.comm.allreduce(local_zero, op=MPI.LAND)
        self._sens_ksp: PETSc.KSP | None = None
        self.iterations = 0
        self.lu: FixedPatternLU | None = None
        self._shell: PETSc.Mat | None = None  # the SNES Jacobian with FixedPatternLU (_FilmShell)
        self.update()
        if (
            fixed_pattern and merged["snes_type"] == "vinewtonrsls"
        ):  # FixedPatternLU reads the VI's inactive set
            self.lu = FixedPatternLU(self)
            pc = self.snes.getKSP().getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(self.lu)
            if merged["ksp_type"] == "preonly" and self.comm.size == 1:
                # the reduced systems' operators are never applied: empty shells instead of sub-matrices
                sizes = self.A.getSizes()
                self._shell = PETSc.Mat().createPython(sizes, _FilmShell(self.A), comm=self.comm)
                self._shell.setUp()
                self.snes.setJacobian(self._jacobian, self._shell)

    def set_lower(self, lower: float) -> None:
        """A new cavitation bound P_cav (and the Dirichlet values, which the caller has set)."""
        self.lower.x.array[:] = lower
        for bc in self.bcs:
            dofs = bc.dof_indices()[0]
            self.lower.x.array[dofs] = np.minimum(self.lower.x.array[dofs], bc.g.x.array[dofs])
        self.lower.x.scatter_forward()
        bc_values = [bc.g.x.array[bc.dof_indices()[0]] for bc in self.bcs]
        local_zero = all(np.all(v == 0.0) for v in bc_values)
        self._homogeneous = lower == 0.0 and self.comm.allreduce(local_zero, op=MPI.LAND)

    def use_reduced_lu(self) -> None:
        """PETSc's LU of each reduced matrix instead of FixedPatternLU (the reference for its tests)."""
        self.lu = None
        self.snes.getKSP().getPC().setType(PETSc.PC.Type.LU)
        self.snes.setJacobian(self._jacobian, self.A)

    # -- assembly -------------------------------------------------------------------------------
    def update(self) -> None:
        """Assemble A and l for the current coefficients (call after the kinematics change)."""
        if self.assembler is not None:
            self.assembler(self.A, self.rhs)
        else:
            self.A.zeroEntries()
            fem_petsc.assemble_matrix(self.A, self.a, bcs=self.bcs)
            self.A.assemble()
            with self.rhs.localForm() as local:
                local.set(0.0)
            fem_petsc.assemble_vector(self.rhs, self.l)
            # r = A P + l on interior rows with P = g on Dirichlet dofs: l += A[:, bc] g; r_bc = P_bc - g.
            fem_petsc.apply_lifting(self.rhs, [self.a], bcs=[self.bcs], scale=-1.0)
            self.rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            fem_petsc.set_bc(self.rhs, self.bcs, scale=-1.0)
        # |l| = 1 in the homogeneous case (solve() normalises); otherwise relative to |l|.
        atol = 1e-11 if self._homogeneous else max(1e-11 * self.rhs.norm(), 1e-14)
        self.snes.setTolerances(atol=atol, rtol=self._rtol, stol=0.0)
        self._sens_ksp = None
        if self.lu is not None:
            self.lu.inactive = None  # its factorisation belongs to the previous operator

    def _residual(self, snes, x, r) -> None:
        self.A.mult(x, r)
        r.axpy(1.0, self.rhs)

    def _jacobian(self, snes, x, J, P) -> None:
        pass  # A is assembled in update(): the problem is linear

    # -- solve ----------------------------------------------------------------------------------
    def solve(self) -> int:
        """Solve the VI from the current P (warm start); returns the number of Newton iterations.

        Raises:
            FilmNotConverged: SNES diverged, or it reported convergence with the bounds violated
                (possible after a failed line search).
        """
        x = self.P.vector
        scale = 1.0
        if self._homogeneous:
            # With P_cav = 0 and zero Dirichlet values the VI is positively homogeneous in the source:
            # P(s l) = s P(l). Solving for l / |l| keeps the iteration at O(1) whatever the size of
            # the source (a tiny squeeze velocity would otherwise sit at round-off level).
            scale = self.rhs.norm()
            if scale == 0.0:  # no source (a concentric journal that only turns): P = 0
                x.set(0.0)
                x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                self.iterations = 0
                self._sens_ksp = None
                return 0
            self.rhs.scale(1.0 / scale)
            x.scale(1.0 / scale)
        fem_petsc.set_bc(x, self.bcs)  # Dirichlet values exactly, so r = A P + l holds
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.snes.solve(None, x)
        if scale != 1.0:
            self.rhs.scale(scale)
            x.scale(scale)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        reason = self.snes.getConvergedReason()
        self.iterations = self.snes.getIterationNumber()
        if reason <= 0:
            raise FilmNotConverged("film solve did not converge", reason, self.iterations)
        violation = _max(self.comm, float(np.max(self.lower.x.array - self.P.x.array, initial=0.0)))
        if violation > 1e-8 * max(1.0, self.pressure_scale()):
            raise FilmNotConverged(
                f"film solve violated the cavitation bound by {violation:.3g}", reason, self.iterations
            )
        self._sens_ksp = None
        return self.iterations

    def pressure_scale(self) -> float:
        return self.P.vector.norm(PETSc.NormType.NORM_INFINITY)

    # -- sensitivities --------------------------------------------------------------------------
    def inactive_set(self) -> PETSc.IS:
        """Global indices (owned by this rank) of the pressurised dofs of the last solution."""
        self._residual(self.snes, self.P.vector, self.residual_vec)
        x = self.P.vector.getArray(readonly=True)
        r = self.residual_vec.getArray(readonly=True)
        lo = self.lower.vector.getArray(readonly=True)
        scale = max(1.0, _max(self.comm, float(np.max(np.abs(r), initial=0.0))))
        active = (x <= lo + 1e-12 * max(1.0, self.pressure_scale())) & (r > 1e-10 * scale)
        start = self.P.vector.getOwnershipRange()[0]
        return PETSc.IS().createGeneral(np.flatnonzero(~active).astype(np.int32) + start, comm=self.comm)

    def sensitivities(self, dr: list[PETSc.Vec]) -> list[PETSc.Vec]:
        """dP = -A_II^{-1} dr_I on the inactive set, 0 elsewhere, for each residual derivative.

        ``dr`` are the derivatives of the residual with respect to parameters at fixed P (Dirichlet
        rows must be zero). One factorisation per solution, reused across calls: with the fixed
        pattern, the VI's last factorisation when its inactive set is the converged one (the usual
        case), else one numeric refactorisation.
        """
        if self.lu is not None:
            if self._sens_ksp is None:
                inactive = self.inactive_set()
                if self.lu.inactive is None or not inactive.equal(self.lu.inactive):
                    self.lu.factor(inactive)
                self._sens_ksp = self.lu.ksp
            out = []
            local = self.lu.local
            b = self.lu.b
            for d in dr:
                values = np.zeros(b.getLocalSize())
                values[local] = -d.getArray(readonly=True)[local]  # -dr on the inactive set, 0 elsewhere
                b.setArray(values)
                dP = d.duplicate()
                self.lu.solve_full(b, dP)
                out.append(dP)
            return out
        if self._sens_ksp is None:
            self._inactive = self.inactive_set()
            A_II = self.A.createSubMatrix(self._inactive, self._inactive)
            ksp = PETSc.KSP().create(self.comm)
            ksp.setOperators(A_II)
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            ksp.getPC().setFactorSolverType(_lu_package(self.comm))
            ksp.setUp()
            self._sens_ksp, self._A_II = ksp, A_II
        out = []
        for d in dr:
            d_I = d.getSubVector(self._inactive)
            dP_I = d_I.duplicate()
            self._sens_ksp.solve(d_I, dP_I)
            dP_I.scale(-1.0)
            d.restoreSubVector(self._inactive, d_I)
            dP = d.duplicate()
            dP.set(0.0)
            sub = dP.getSubVector(self._inactive)
            dP_I.copy(sub)
            dP.restoreSubVector(self._inactive, sub)
            out.append(dP)
        return out

    # -- lifetime -------------------------------------------------------------------------------
    def close(self) -> None:
        for obj in (self.snes, self.A, self.rhs, self.residual_vec, self._shell):
            if obj is not None:
                obj.destroy()
        if self.lu is not None:
            self.lu.destroy()
        self._sens_ksp = None

    def __enter__(self) -> CavitatingSolver:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _max(comm, value: float) -> float:
    """The largest value over the ranks (no message on one rank: mpi4py's allreduce pickles)."""
    return value if comm.size == 1 else comm.allreduce(value, op=MPI.MAX)
