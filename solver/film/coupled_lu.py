"""The linear solvers of the coupled elastic film (solver.film.ehd): ``SchurLU``, the Schur complement of
the film block for a few deformation modes, and ``DampedLU``, the semismooth method's LU with a limited
step. PETSc and scipy plumbing: both are Python PCs of the coupled SNES.
"""

from __future__ import annotations

import math
import weakref

from petsc4py import PETSc

import numpy as np
import scipy.linalg
import scipy.linalg.lapack

from solver.errors import FilmNotConverged
from solver.film.ehd import LayeredBlocks, ModalBorder, ScaledBorder, as_array

_getrs = scipy.linalg.lapack.get_lapack_funcs("getrs", (np.zeros(1),))
#: the film block's fill-reducing ordering for PETSc's LU: quotient minimum degree, whose factors of the
#: elastic JFO film (1405 nodes) hold 41k entries against nested dissection's (PETSc's default) 51k: its
#: refactorisation 1.9 against 3.1 ms, the 183 back-substitutions of a Schur complement 25 against 32 ms (on
#: a loaded core; docs/benchmarks.md)
ORDERING = PETSc.Mat.OrderingType.QMD


class SchurLU:
    """Solver of the reduced Newton systems of the coupled VI with a few deformation modes (m << n), by
    the Schur complement of the film block: the same iterates as an LU of the whole matrix (its Schur
    system solved directly or by GMRES to 1e-12).

    On the inactive set (pressurised dofs and every mode) the system is ``[[A, B], [C, D]] [dP; dq] =
    [b_P; b_q]`` with A the film block (its active rows and columns replaced by identity rows, as in
    FixedPatternLU: one fixed pattern, numeric refactorisations only), B = dR_P/dq with the active rows
    zeroed, C = dR_q/dP with the active columns zeroed and D = dR_q/dq (m x m)::

        S = D - C A^-1 B (m x m),   dq = S^-1 (b_q - C A^-1 b_P),   dP = A^-1 (b_P - B dq)

    The film block is an M-matrix (its rows become small where the gap closes, but stay diagonally
    dominant), so PETSc's LU without pivoting serves it; the dense borders, which made the whole
    matrix need MUMPS's pivoting, only enter S. The borders may come as their factors
    (solver.film.ehd.ModalBorder, ScaledBorder: products with vectors without the n x m arrays); B is
    formed only with a complement. Forming S costs m back-substitutions (A^-1 B) and a dense LU; S
    changes little from one Newton iteration, and one film solve, to the next, so it is formed only
    when needed: the Schur system of a new factorisation is solved by GMRES preconditioned
    with the last S formed (each iteration one back-substitution, ~5 on the engine cycle, to 1e-12),
    and S is formed anew when that takes more than MAX_KRYLOV iterations (about one factorisation in
    six on the engine cycle). One Newton step then costs an LU of the film matrix (~0.4 ms at 1620
    dofs) and a few back-substitutions, against MUMPS's ~7 ms on the whole matrix with 72 modes.
    Interface of FixedPatternLU (``factor``, ``solve_full``, the PCShell methods).

    The film is a cavitation block of the coupled Newton with the Jacobian's blocks at its last state
    (``blocks``: the film block a CSR matrix in the operator's layout, the borders dense or as factors):
    solver.film.coupled_reynolds.ReynoldsRows, whose VI gives the inactive set of each Newton step
    (``bounded``), or solver.film.cavitation_jfo.JFORows, whose semismooth Newton has no bounds (every
    unknown in every system: ``bounded=False``).
    """

    def __init__(self, film, bounded: bool = True):
        self.film = weakref.proxy(film)  # (owned by the film's SNES: no reference cycle through C)
        op, n = film.op, film.n
        # the film block's pattern is the operator's (A(H) of ReynoldsRows.rows)
        self._indptr, self._indices = op.indptr.astype(PETSc.IntType), op.indices.astype(PETSc.IntType)
        self.K = PETSc.Mat().createAIJ(
            (n, n), csr=(self._indptr, self._indices, np.zeros(len(op.indices))), comm=film.comm
        )
        self.K.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        self.ksp = PETSc.KSP().create(film.comm)
        self._use("petsc")  # of the film block's current factorisation: PETSc's own (else MUMPS)
        self.b, self.x = (
            PETSc.Vec().createSeq(film.N, comm=film.comm),
            PETSc.Vec().createSeq(film.N, comm=film.comm),
        )
        self._bP, self._xP = self.K.createVecs()
        #: without bounds the set of every unknown, factorised for every Newton step
        self.everything = (
            None
            if bounded
            else PETSc.IS().createGeneral(np.arange(film.N, dtype=PETSc.IntType), comm=film.comm)
        )
        self.inactive: PETSc.IS | None = None
        self.local: np.ndarray | None = None
        self.limit = None
        self.failed = False
        # LU of the last Schur complement formed (exact for its factorisation, then a preconditioner)
        self.S = None
        self._exact = False
        self.n_formed = self.n_krylov = 0  # Schur complements formed, Krylov iterations (statistics)
        # the layer basis (solver.film.ehd.LayeredBlocks): (kept nodes, dR_u/dq_L on the eliminated columns,
        # d there) of the current factorisation, the kept nodes of the last complement formed, the row of
        # each entry of the film block's pattern
        self._layer: tuple | None = None
        self._kept_formed: np.ndarray | None = None
        self._rows = np.repeat(np.arange(n), np.diff(op.indptr))

    #: Krylov iterations on the Schur system before its complement is formed anew (m back-substitutions)
    MAX_KRYLOV = 6
    #: relative residual of the Schur system at which the Krylov iteration stops (the direct solve's level)
    KRYLOV_TOLERANCE = 1e-12

    def factor(self, inactive: PETSc.IS) -> None:
        """Factorise for this inactive set (indices into (u, q)); the blocks are the film's (the
        borders dense: SchurLU serves the modal film). Only the film block is factorised here; the Schur
        complement is formed (m back-substitutions) the first time, after a failure, when the last one
        no longer preconditions the Schur system well (``_schur_solve``) and for the sensitivities
        (``solve_full``)."""
        film, n = self.film, self.film.n
        keep = np.zeros(film.N, dtype=bool)
        keep[inactive.getIndices()] = True
        active = np.flatnonzero(~keep[:n]).astype(PETSc.IntType)
        if isinstance(film.blocks, LayeredBlocks):
            A, B, C, D = self._eliminate(film.blocks, keep[:n])
        else:
            A, B, C, D = film.blocks
            self._layer = None
        self.K.setValuesCSR(self._indptr, self._indices, A.data)
        self.K.assemble()
        self.K.zeroRowsColumns(active, diag=1.0)
        self._factor_film_block()
        self.B, self.C, self.D = _zeroed(B, active, axis=0), _zeroed(C, active, axis=1), D
        self._exact = False  # whether self.S is this factorisation's Schur complement
        if (
            self.S is None
            or self.S[0].shape[0] != D.shape[0]
            or not np.all(np.isfinite(self.S[0]))  # (a failed one preconditions nothing)
            or (self._layer is not None and not np.array_equal(self._layer[0], self._kept_formed))
        ):
            self._form_schur()
        self.inactive = inactive
        self.local = inactive.getIndices()

    def _eliminate(self, blocks: LayeredBlocks, inactive: np.ndarray) -> tuple:
        """The layer basis's blocks with the node-by-node deformation q_L eliminated where its row is
        dq_L - d du = b_L (every node off the cells in asperity contact), so that the film block keeps
        its pattern: ``A + L diag(d)`` on those columns; the borders are q_L at the other nodes
        (``blocks.kept``) and the modes. Keeps what ``_solve`` needs to eliminate and recover q_L."""
        n, kept = self.film.n, blocks.kept
        free = np.ones(n)
        free[kept] = 0.0
        d_free = blocks.d * free
        L_rows = blocks.L.copy()  # dR_u/dq_L on the inactive rows (the active ones are no equations)
        L_rows.data = L_rows.data * inactive[self._rows]
        A = blocks.A.copy()
        A.data = A.data + L_rows.data * d_free[self._indices]
        L_free = L_rows.copy()  # its columns of the eliminated q_L
        L_free.data = L_free.data * free[self._indices]
        B = np.hstack([L_rows[:, kept].toarray(), blocks.B_modes])
        C = np.zeros((len(kept) + blocks.C_modes.shape[0], n))
        C[np.arange(len(kept)), kept] = -blocks.d[kept]
        C[len(kept) :] = blocks.C_modes
        self._layer = (kept, L_free, d_free)
        return A, B, C, blocks.D

    def _form_schur(self) -> None:
        """S = D - C A^-1 B of the current factorisation (m back-substitutions, one dense LU)."""
        n, m = self.film.n, self.B.shape[1]
        self._kept_formed = None if self._layer is None else self._layer[0]
        if m == 0:  # no borders (the layer basis without modes and contact): nothing to form
            self.S, self._exact = (np.zeros((0, 0)), np.zeros(0, np.int32)), True
            return
        rhs = PETSc.Mat().createDense((n, m), array=np.asfortranarray(as_array(self.B)), comm=self.film.comm)
        X = PETSc.Mat().createDense((n, m), comm=self.film.comm)
        X.setUp()
        try:  # (a factorisation that failed, MUMPS's at a far iterate, refuses to solve)
            self.ksp.getPC().getFactorMatrix().matSolve(rhs, X)
            X_array = X.getDenseArray().copy()
        except PETSc.Error:
            X_array = np.full((n, m), np.nan)
        finally:
            rhs.destroy()
            X.destroy()
        with np.errstate(all="ignore"):
            S = self.D - self.C @ X_array
        self.S = scipy.linalg.lu_factor(S, check_finite=False)
        self._exact = True
        self.n_formed += 1
        if not (np.all(np.isfinite(X_array)) and np.all(np.isfinite(self.S[0]))):
            self.failed = True

    def _film_solve(self, b: np.ndarray) -> np.ndarray:
        """A^-1 b with the film block's factorisation (one back-substitution)."""
        self._bP.setArray(b)
        try:
            self.ksp.solve(self._bP, self._xP)
        except PETSc.Error:  # (MUMPS's solve phase after its factorisation failed)
            self.failed = True
            return np.full_like(b, np.nan)
        if self.ksp.getConvergedReason() < 0:
            self.failed = True
        return self._xP.getArray(readonly=True).copy()

    def _schur_solve(self, r: np.ndarray) -> np.ndarray:
        """S^-1 r for this factorisation's S = D - C A^-1 B: directly with its own complement, else by
        GMRES preconditioned (on the right) with the last complement formed, whose Schur system differs
        from this one by the change of the film block since (a few iterations, one back-substitution
        each; the basis orthogonalised by classical Gram-Schmidt applied twice, the least-squares
        problem by Givens rotations); when that does not reach KRYLOV_TOLERANCE in MAX_KRYLOV
        iterations the complement is formed anew and used directly."""
        if self._exact:
            return self._schur_lu_solve(r)
        norm = float(np.linalg.norm(r))
        if not math.isfinite(norm):  # the residual of a far iterate overflowed: the step is NaN, the
            self.failed = True  # SNES fails and the film solve with it (FilmNotConverged)
            return np.full_like(r, np.nan)
        if norm == 0.0:
            return np.zeros_like(r)
        k_max = self.MAX_KRYLOV
        basis = np.zeros((k_max + 1, r.size))
        triangle = np.zeros((k_max, k_max))  # the Hessenberg matrix, rotated to upper triangular
        cosines, sines = np.zeros(k_max), np.zeros(k_max)
        rhs = np.zeros(k_max + 1)  # the rotated right-hand side norm e_1: |rhs[k + 1]| is the residual
        rhs[0] = norm
        basis[0] = r / norm
        for k in range(k_max):
            w = self._schur_apply(self._schur_lu_solve(basis[k]))
            if self.failed or not np.all(np.isfinite(w)):  # a failed back-substitution: the step is NaN,
                self.failed = True  # the SNES fails and the film solve with it (FilmNotConverged)
                return np.full_like(r, np.nan)
            V = basis[: k + 1]
            h = V @ w
            w = w - h @ V
            correction = V @ w
            w -= correction @ V
            h += correction
            h_next = float(np.linalg.norm(w))
            for i in range(k):  # the earlier rotations
                h[i], h[i + 1] = (
                    cosines[i] * h[i] + sines[i] * h[i + 1],
                    -sines[i] * h[i] + cosines[i] * h[i + 1],
                )
            radius = math.hypot(h[k], h_next)
            cosines[k], sines[k] = (h[k] / radius, h_next / radius) if radius > 0.0 else (1.0, 0.0)
            h[k] = radius
            triangle[: k + 1, k] = h
            rhs[k + 1] = -sines[k] * rhs[k]
            rhs[k] *= cosines[k]
            if abs(rhs[k + 1]) <= self.KRYLOV_TOLERANCE * norm or h_next == 0.0:
                self.n_krylov += k + 1
                y = scipy.linalg.solve_triangular(
                    triangle[: k + 1, : k + 1], rhs[: k + 1], check_finite=False
                )
                return self._schur_lu_solve(y @ basis[: k + 1])
            basis[k + 1] = w / h_next
        self.n_krylov += k_max
        self._form_schur()
        return self._schur_lu_solve(r)

    def _schur_apply(self, v: np.ndarray) -> np.ndarray:
        """S v = D v - C A^-1 B v (one back-substitution)."""
        return self.D @ v - self.C @ self._film_solve(self.B @ v)

    def _schur_lu_solve(self, v: np.ndarray) -> np.ndarray:
        """The last complement formed, solved for v (LAPACK's getrs on its LU)."""
        x, _ = _getrs(*self.S, v)  # (its info is non-zero only for invalid arguments)
        return x

    def _factor_film_block(self) -> None:
        """LU of the film block: PETSc's own (numeric refactorisation of the fixed pattern); at a zero
        pivot (an iterate far from the solution can close the gap so far that a row vanishes) MUMPS,
        which pivots, for this factorisation, and PETSc's own again for the next one."""
        if self.failed or self._package != "petsc":
            self._use("petsc")
            self.failed = False
        self.ksp.setOperators(self.K)
        self.ksp.setUp()
        self._bP.set(0.0)  # a zero pivot shows only in a solve's reason
        self.ksp.solve(self._bP, self._xP)
        if self.ksp.getConvergedReason() < 0:
            self._use("mumps")
            self.ksp.setOperators(self.K)
            self.ksp.setUp()

    def _use(self, package: str) -> None:
        """A new LU of the film block by ``package`` (analysis included at the next set-up); PETSc's own is
        ordered by ORDERING, MUMPS orders its own."""
        self.ksp.reset()
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType(package)
        if package == "petsc":
            self.ksp.getPC().setFactorOrdering(ORDERING)
        self._package = package

    def _solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b through the Schur complement. A far iterate can overflow (its residual, or the
        step): the result is then not finite, which the callers test (a failed step, FilmNotConverged),
        so numpy's warnings about it are silenced here rather than shown to the user."""
        n = self.film.n
        if self.failed:  # (this factorisation failed: no step)
            return np.full_like(b, np.nan)
        with np.errstate(all="ignore"):
            if self._layer is None:
                y0 = self._film_solve(b[:n])
                dq = self._schur_solve(b[n:] - self.C @ y0)
                return np.concatenate([y0 - self._film_solve(self.B @ dq), dq])
            # the layer basis: b = (b_u, b_L, b_modes); dq_L = b_L + d du off the kept nodes (``_eliminate``)
            kept, L_free, d_free = self._layer
            b_u, b_L = b[:n], b[n : 2 * n]
            y0 = self._film_solve(b_u - L_free @ b_L)
            if self.B.shape[1]:
                dq = self._schur_solve(np.concatenate([b_L[kept], b[2 * n :]]) - self.C @ y0)
                du = y0 - self._film_solve(self.B @ dq)
            else:  # no contact, no modes (a WinklerLayer): the film block is the whole system
                dq, du = np.zeros(0), y0
            dL = b_L + d_free * du
            dL[kept] = dq[: len(kept)]
            return np.concatenate([du, dL, dq[len(kept) :]])

    def solve_full(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x = K^-1 b (b must vanish on the active set of the factorisation). For the sensitivities:
        several right-hand sides, of another kind than Newton's, so the complement is formed first
        (GMRES from the last one took more iterations on them than forming it costs)."""
        if not self._exact:
            self._form_schur()
        x.setArray(self._solve(b.getArray(readonly=True)))
        if self.failed or not np.all(np.isfinite(x.getArray(readonly=True))):
            self.failed = True
            raise FilmNotConverged("elastic film sensitivities: the factorisation failed", -1, 0)

    # -- PCShell interface ----------------------------------------------------------------------------
    def setUp(self, pc) -> None:  # noqa: N802 - PETSc's name
        self.factor(self.film.snes.getVIInactiveSet() if self.everything is None else self.everything)

    def apply(self, pc, x: PETSc.Vec, y: PETSc.Vec) -> None:
        b = np.zeros(self.film.N)
        b[self.local] = x.getArray(readonly=True)
        step = self._solve(b)
        if self.failed or not np.all(np.isfinite(step)):
            self.failed = True
            y.set(float("nan"))
            return
        factor = 1.0 if self.limit is None else self.limit(step)
        y.setArray(factor * step[self.local])

    def destroy(self, pc=None) -> None:
        for obj in (self.ksp, self.K, self.b, self.x, self._bP, self._xP, self.everything):
            if obj is not None:
                obj.destroy()


def _zeroed(border, active: np.ndarray, axis: int):
    """A border with the active set's rows (``axis`` 0: dR_u/dq) or columns (1: dR_q/du) zeroed; the border
    itself when nothing is active (the JFO film's semismooth Newton)."""
    if not len(active):
        return border
    if isinstance(border, (ModalBorder, ScaledBorder)):
        return border.zeroed(active)
    border = border.copy()
    border[(slice(None),) * axis + (active,)] = 0.0
    return border


class DampedLU:
    """Python PC of the coupled VI: an LU of the semismooth Newton matrix (its pattern is fixed, so
    PETSc refactorises it numerically only) and the step scaled by ``limit(step)`` (a bound method,
    held weakly: the PC is owned by its film's SNES, so no reference cycle goes through C)."""

    def __init__(self, comm, limit):
        self.limit = weakref.WeakMethod(limit)
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.failed = False

    def setUp(self, pc) -> None:  # noqa: N802 - PETSc's name
        A, _ = pc.getOperators()
        if self.failed:  # as FixedPatternLU.factor: MUMPS would keep the failed factorisation's error
            self.ksp.reset()
            self.failed = False
        self.ksp.setOperators(A)
        self.ksp.setUp()

    def apply(self, pc, x: PETSc.Vec, y: PETSc.Vec) -> None:
        self.ksp.solve(x, y)
        if self.ksp.getConvergedReason() < 0:
            self.failed = True
            y.set(float("nan"))
            return
        y.scale(self.limit()(y.getArray(readonly=True)))

    def destroy(self, pc=None) -> None:
        self.ksp.destroy()
