"""Evaluating the film's forms: compiled quietly (``quiet_jit``, ``compile_form``), many linear forms
in one assembly (``BlockedVectors``) and many integrals in one kernel call (``QuadratureFunctionals``).

PETSc and dolfinx plumbing, no physics: the integrands come from solver.film.forms.
"""

from __future__ import annotations

import contextlib
import logging

from mpi4py import MPI
from petsc4py import PETSc

import basix
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from dolfinx.la import create_petsc_vector
from ufl.algorithms import expand_derivatives

log = logging.getLogger(__name__)


class _QuietJit(logging.Filter):
    """While a form is compiled: FFCx's INFO records and the C compiler's command lines (logged to
    the root logger by distutils) are dropped; FFCx's "Calling JIT C compiler" becomes one line of
    ours, once per process. A form loaded from the cache says nothing."""

    announced = False

    def filter(self, record: logging.LogRecord) -> bool:
        if (
            record.name == "ffcx"
            and "Calling JIT C compiler" in record.getMessage()
            and not _QuietJit.announced
        ):
            _QuietJit.announced = True
            log.info("compiling the film's forms for this machine: once, 5-20 s; cached in ~/.cache/fenics")
        return record.levelno >= logging.WARNING


@contextlib.contextmanager
def quiet_jit():
    """Compile forms, expressions and elements quietly (see _QuietJit)."""
    quiet = _QuietJit()
    loggers = [logging.getLogger("ffcx"), logging.getLogger()]
    for logger in loggers:
        logger.addFilter(quiet)
    try:
        yield
    finally:
        for logger in loggers:
            logger.removeFilter(quiet)


def compile_form(expression):
    """dolfinx.fem.form with FFCx's verbosity at INFO: only then does it log "Calling JIT C compiler",
    which _QuietJit turns into one line; call it under quiet_jit()."""
    return fem.form(expression, form_compiler_params={"verbosity": logging.INFO})


class BlockedVectors:
    """Several linear forms in the test function of a scalar space, assembled in one pass.

    ``integrands`` are (integrand, measure) pairs; integrands of the same measure share one kernel.

    The integrands become the components of one form in the blocked (vector) space of the same
    element, so the kernel computes their common subexpressions (film thickness, flow factors) once
    per quadrature point instead of once per form; the components are then copied into vectors of
    the scalar space (reused between calls: do not keep them across calls).
    """

    def __init__(self, V, v, integrands: list[tuple[object, object]]):
        element = V.ufl_element()
        self.size = len(integrands)
        blocked = fem.VectorFunctionSpace(V.mesh, (element.family(), element.degree()), dim=self.size)
        w = ufl.TestFunction(blocked)
        self.form = compile_form(
            sum(ufl.replace(e, {v: w[i]}) * measure for i, (e, measure) in enumerate(integrands))
        )
        self.blocked = fem_petsc.create_vector(self.form)
        n_owned = V.dofmap.index_map.size_local
        if blocked.dofmap.index_map.size_local != n_owned:
            raise RuntimeError("blocked space distributed differently from the scalar space")
        # node k of the blocked space carries the values of scalar dof order[k] (the same nodes,
        # possibly numbered differently)
        scalar_x = np.round(V.tabulate_dof_coordinates()[:n_owned], 12)
        blocked_x = np.round(blocked.tabulate_dof_coordinates()[:n_owned], 12)
        by_scalar, by_blocked = np.lexsort(scalar_x.T), np.lexsort(blocked_x.T)
        self.order = np.empty(n_owned, dtype=np.int64)
        self.order[by_blocked] = by_scalar
        if not np.allclose(scalar_x[self.order], blocked_x, atol=1e-10):
            raise RuntimeError("the blocked space's nodes differ from the scalar space's")
        self.vectors = [create_petsc_vector(V.dofmap.index_map, V.dofmap.index_map_bs) for _ in integrands]

    def __call__(self) -> list[PETSc.Vec]:
        with self.blocked.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self.blocked, self.form)
        self.blocked.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = self.blocked.getArray(readonly=True).reshape(-1, self.size)
        for i, vec in enumerate(self.vectors):
            vec.getArray()[self.order] = values[:, i]
            vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.vectors

    def close(self) -> None:
        for vec in [self.blocked, *self.vectors]:
            vec.destroy()


class QuadratureFunctionals:
    """Many integrals over one mesh in one pass: a vector-valued ``fem.Expression`` of the integrands
    (times the area element) at the quadrature points of every owned cell, summed with the weights.

    Equivalent to assembling each scalar form (same quadrature rule as FFCx's default of that
    degree), but one kernel call instead of one assembly per functional, which matters when a film
    solve needs ~10 of them.
    """

    def __init__(self, mesh, integrands: list, degree: int, *, contact_only: bool = False):
        points, self.weights = basix.make_quadrature(basix.CellType.triangle, degree)
        self.contact_only = contact_only  # evaluated only on the cells that the film's contact cells gives
        area = abs(ufl.JacobianDeterminant(mesh))
        self.size = len(integrands)
        self.expression = fem.Expression(ufl.as_vector([e * area for e in integrands]), points)
        self.cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
        self.comm = mesh.comm

    def __call__(self, cells: np.ndarray | None = None) -> np.ndarray:
        """The integrals over the owned cells, or over ``cells`` (where the others contribute 0)."""
        cells = self.cells if cells is None else cells
        local = np.zeros(self.size)
        if len(cells):
            values = self.expression.eval(cells).reshape(len(cells), len(self.weights), self.size)
            local = np.einsum("cqn,q->n", values, self.weights)
        return local if self.comm.size == 1 else self.comm.allreduce(local, op=MPI.SUM)


def functionals_by_group(mesh, integrands: dict, groups: dict) -> list[tuple[list, QuadratureFunctionals]]:
    """``{key: (integrand, group)}`` -> [(keys, QuadratureFunctionals)], one per group of ``groups``
    (``{group: (measure, contact_only)}``) that has integrands."""
    members: dict[str, list] = {}
    for key, (e, group) in integrands.items():
        members.setdefault(group, []).append((key, e))
    out = []
    for group, items in members.items():
        measure, contact_only = groups[group]
        functionals = QuadratureFunctionals(
            mesh, [e for _, e in items], measure.metadata()["quadrature_degree"], contact_only=contact_only
        )
        out.append(([key for key, _ in items], functionals))
    return out


def is_zero(expression) -> bool:
    """True when a UFL derivative is identically zero (such forms are not assembled)."""
    try:
        return isinstance(expand_derivatives(expression), ufl.constantvalue.Zero)
    except Exception:  # noqa: BLE001 - UFL cannot always simplify; then assume non-zero
        return False
