"""The film's forms and functionals: the Reynolds residual's operator, the outputs (forces, torques,
contact, flows) and the pieces of their Jacobian, common to every film kind.

``FilmForms`` builds them once on a FilmSpace (solver.film.space): the compiled bilinear and linear forms
of the Reynolds residual, the midpoint-rule operator (serial P1, solver.film.tensors), the output
functionals grouped by quadrature (solver.film.functionals) and the Jacobian's explicit and pressure
parts. ``values`` gives every output in SI at the solved state, ``jacobian`` the outputs' derivatives
from the pressure's (and deformation's) sensitivities. SI scales are read from the space's current
scales at each call, so a new viscosity needs no new form.

Friction of a cavitated film. In the mass-conserving film's cavitated zone the gap holds oil streamers
that fill the fraction theta of it (DESIGN 8); only they shear, so the Couette shear is weighted by the
film fraction, ``theta mu (U1 - U2)/h`` (with the shear-stress factors on rough surfaces), as in Elrod's
model (Elrod 1981; DESIGN 3.4: the film is taken as full "unless a mass-conserving model says
otherwise"). theta = 1 in the full film, and in the cavitated zone p = p_cav, so the pressure part
``h/2 dp/dx`` needs no weight. The film fraction is a P1 Function set from the solver's solution
(``set_film_fraction``); the Jacobian adds the torques' change through it (``dF``). The Reynolds VI
film has no film fraction and keeps the full-film shear; a JFO film with ``cavitated_shear = "full"``
(solver.film.spec) keeps it too (the behaviour before 2026-11-27).

Flows. The side flow (out of both edges) and the supply flow (from the supply into the film) are the
consistent fluxes of the discrete equation: ``r(P; w)`` with w = 1 on the edge (supply) dofs and 0
elsewhere, i.e. the sum of the residuals of those dofs, in m^3/s. Their sum over all dofs is the
integral of the source, so in a steady state the discrete balance is exact.
"""

from __future__ import annotations

import math

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from dolfinx.mesh import meshtags

from solver.film import reynolds
from solver.film.functionals import BlockedVectors, compile_form, functionals_by_group, is_zero
from solver.film.mesh import TAGS
from solver.film.space import FilmSpace
from solver.film.tensors import MidpointOperator, PressureTorque, RigidMidpointCoefficients
from solver.film.types import JACOBIAN_ROWS

#: the functionals of the pressure part of the viscous torques (the same integrand, tensors.PressureTorque)
_PRESSURE_TORQUES = ("viscous_pressure_journal", "viscous_pressure_bushing")


class FilmForms:
    """The forms, operator and functionals of one film (module docstring)."""

    def __init__(self, space: FilmSpace):
        self.space = space
        # the mass-conserving film's fraction theta weights the Couette shear (module docstring); None:
        # the full-film shear everywhere (the Reynolds film; a JFO film with cavitated_shear "full")
        self.film_fraction = None
        if space.spec.cavitation == "jfo" and space.spec.cavitated_shear == "film-fraction":
            self.film_fraction = fem.Function(space.V, name="film_fraction")
            self.film_fraction.x.array[:] = 1.0
        self._build(space)
        self.A = fem_petsc.assemble_matrix(self.a, bcs=space.bcs)  # (its layout: the operator's)
        self.A.assemble()
        self.operator = None  # serial P1: the operator and source from precomputed tensors (film.tensors)
        self.pressure_torque = None  # serial P1: PressureTorque
        if space.serial_p1:
            g = space.geometry
            names = list(self.midpoint_integrands)
            fast = None
            if space.W is None and set(names) <= set(RigidMidpointCoefficients.INTEGRALS):
                # the coefficients at the midpoints in numpy rather than by the compiled Expression
                def fast(op):
                    relief = None if space.relief is None else space.relief(op.centroid[:, 2])
                    return RigidMidpointCoefficients(op, space.params, space.roughness, names, relief=relief)

            self.operator = MidpointOperator(
                space.V,
                self.A,
                reynolds.reynolds_coefficients(g, space.roughness),
                space.bcs,
                integrals=[self.midpoint_integrands[n] for n in names],
                fast=fast,
            )
            self.operator_integral_names = names
            self.scalars = [(keys, f) for keys, f in self.scalars if not set(keys) <= set(names)]
            # the pressure part of the viscous torques (the "moment" group) from tensors (film.tensors)
            self.pressure_torque = PressureTorque(
                space.V,
                space.roughness,
                float(space.params.S.value),
                flow_floor=None if space.W is None else space.flow_floor,
                relief=space.relief,
            )
            self.scalars = [(keys, f) for keys, f in self.scalars if not set(keys) <= set(_PRESSURE_TORQUES)]

    def _build(self, space: FilmSpace) -> None:
        g, P = space.geometry, space.P
        # outputs use the true pressure (the film's unknown P is the reduced one with piezoviscosity)
        # and the Couette stresses mu(p) / mu0 (solver.film.viscosity)
        p = space.pressure
        v, dP = ufl.TestFunction(space.V), ufl.TrialFunction(space.V)
        # The coefficients (H^3, flow factors, sqrt in theta) would make UFL pick a very high
        # quadrature degree; they are smooth on an element, so degree 2k - 1 (the midpoint rule for
        # P1) keeps the discretisation error of order h^2: at the engine's hardest state the film
        # load on the default mesh is 0.1 % from converged (0.8 % with degree 2k), at 2.5 x less
        # assembly time (bench/film_mesh_convergence.py). The hydrodynamic forces and the pressure
        # part of the viscous torques take degree 2k: the film's moment balance (T_j + T_b + e x F
        # = 0) rests on an integration by parts between them that only a more accurate rule keeps
        # to 1e-5.
        k = space.V.ufl_element().degree()
        dx = ufl.dx(domain=space.mesh, metadata={"quadrature_degree": 2 * k - 1})
        dx_moment = ufl.dx(domain=space.mesh, metadata={"quadrature_degree": 2 * k})
        # functionals are evaluated per group: (measure, only on the cells where asperities touch)
        groups = {"film": (dx, False), "moment": (dx_moment, False), "contact": (dx, True)}
        residual = reynolds.reynolds_integrand(P, v, g, space.roughness)
        self.a = compile_form(ufl.derivative(residual * dx, P, dP))
        self.l = compile_form(ufl.replace(residual, {P: ufl.zero()}) * dx)
        couette_j, couette_b, pressure_part = reynolds.shear_traction_integrands(p, g, space.roughness)
        if space.piezo is not None:
            ratio = space.piezo.ratio(space.p_ref * p, mod=ufl)
            couette_j, couette_b = ratio * couette_j, ratio * couette_b
        fraction = self.film_fraction
        if fraction is not None:  # only the oil streamers shear in the cavitated zone (Elrod 1981)
            couette_j, couette_b = fraction * couette_j, fraction * couette_b
        # functional name -> (dimensionless integrand, SI scale's name, Jacobian row it adds to, group)
        self.outputs = {
            "hydro_x": (-p * g.normal[0], "force", "force_x", "moment"),
            "hydro_y": (-p * g.normal[1], "force", "force_y", "moment"),
            "viscous_couette_journal": (couette_j, "shear_torque", "torque_journal", "film"),
            "viscous_couette_bushing": (couette_b, "shear_torque", "torque_bushing", "film"),
            "viscous_pressure_journal": (pressure_part, "shear_torque", "torque_journal", "moment"),
            "viscous_pressure_bushing": (pressure_part, "shear_torque", "torque_bushing", "moment"),
        }
        extra = {}
        contact = space.contact
        if contact is not None:
            slip_reg = space.spec.slip_regularisation / space.scales.speed
            P_c, tau_c, area = reynolds.asperity_integrands(g, contact, space.p_ref, slip_reg)
            c_over_R = space.bearing.clearance / space.bearing.radius
            self.outputs.update(
                {
                    "asperity_x": (-P_c * g.normal[0], "force", "force_x", "contact"),
                    "asperity_y": (-P_c * g.normal[1], "force", "force_y", "contact"),
                    # the contact normals pass through the bushing centre, so on the journal they have
                    # the moment -e x F_asperity about its centre (the film's moment balance,
                    # T_j + T_b + e x F = 0)
                    "asperity_torque_journal": (
                        tau_c + c_over_R * P_c * (g.eps_x * g.normal[1] - g.eps_y * g.normal[0]),
                        "contact_torque",
                        "torque_journal",
                        "contact",
                    ),
                    "asperity_torque_bushing": (-tau_c, "contact_torque", "torque_bushing", "contact"),
                }
            )
            whole = float(space.mesh_spec.multiplicity)
            extra = {"contact_area": whole * area, "asperity_normal": whole * P_c}
        self.extra_names = list(extra)
        # Hydrodynamic forces are linear in P with weights independent of the kinematics: g_i . P.
        self.force_vectors = {}
        for name in ("hydro_x", "hydro_y"):
            integrand, _, _, group = self.outputs[name]
            vec = fem_petsc.assemble_vector(compile_form(ufl.derivative(integrand * groups[group][0], p, v)))
            vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self.force_vectors[name] = vec
        # All other functionals of a solve in one pass over the cells per group.
        scalars = {
            name: (e, group)
            for name, (e, _, _, group) in self.outputs.items()
            if name not in self.force_vectors
        }
        scalars.update({name: (e, "contact") for name, e in extra.items()})
        self.scalars = functionals_by_group(space.mesh, scalars, groups)
        # the midpoint-rule functionals independent of P (the Couette torques): the tensor operator
        # can integrate them in its own evaluation of the coefficients, which comes before the solve,
        # so not those weighted by the film fraction (integrated at the solved state with the others)
        self.midpoint_integrands = {
            name: e
            for name, (e, group) in scalars.items()
            if group == "film"
            and is_zero(ufl.derivative(e, p, v))
            and (fraction is None or is_zero(ufl.derivative(e, fraction, v)))
        }
        variables = list(g.variables().values())
        self.variable_names = list(g.variables())
        # Jacobian pieces: dr/dtheta at fixed P; per Jacobian row (outputs summed with their SI
        # scales) the explicit dE/dtheta that are not identically zero, and dE/dP as a vector.
        dr_integrands = [(ufl.diff(residual, var), dx) for var in variables]
        explicit: dict[tuple[int, int, str], tuple[object, str]] = {}
        gradients: list[tuple[int, object, object]] = []
        w_gradients: list[tuple[int, object, object]] = []
        f_gradients: list[tuple[int, object, object]] = []
        # each (row, group) has the outputs of one SI scale: the integrands are summed unscaled and the
        # scale, read at each Jacobian (a new viscosity changes it), multiplies their integrals
        # (the explicit derivatives and the gradients have the scale at build in their integrands, as
        # numbers, and their values are multiplied by the scale's change since: 1.0 until a new
        # viscosity, so the same values bit for bit as with the scale in the forms; a fem.Constant in
        # the explicit derivatives' Expression gave wrong values with dolfinx 0.5.2)
        self.explicit_scales: dict[tuple[int, int, str], str] = {}
        self.built_scales = self.scales()
        gradient_scales: list[str] = []
        w_gradient_scales: list[str] = []
        f_gradient_scales: list[str] = []
        for i, row in enumerate(JACOBIAN_ROWS):
            for group, (measure, _) in groups.items():
                members = [
                    (name, e, scale)
                    for name, (e, scale, r, gr) in self.outputs.items()
                    if r == row and gr == group and name not in self.force_vectors
                ]
                if not members:  # (smooth film: hydrodynamic forces only)
                    continue
                (scale,) = {scale for _, _, scale in members}
                at_build = sum(self.built_scales[scale] * e for _, e, _ in members)
                for j, var in enumerate(variables):
                    if not is_zero(ufl.diff(at_build, var)):
                        explicit[(i, j, group)] = (ufl.diff(at_build, var), group)
                        self.explicit_scales[(i, j, group)] = scale
                gradient = ufl.derivative(at_build, p, v)
                if not is_zero(gradient):  # dE/dp != 0: the pressure part of the viscous torques
                    gradients.append((i, gradient, measure))
                    gradient_scales.append(scale)
                if space.W is not None:  # dE/dW: outputs that depend on the film thickness
                    gradient_W = ufl.derivative(at_build, space.W, v)
                    if not is_zero(gradient_W):
                        w_gradients.append((i, gradient_W, measure))
                        w_gradient_scales.append(scale)
                if fraction is not None:  # dE/dtheta: the Couette torques weighted by the film fraction
                    gradient_f = ufl.derivative(at_build, fraction, v)
                    if not is_zero(gradient_f):
                        f_gradients.append((i, gradient_f, measure))
                        f_gradient_scales.append(scale)
        # the residual derivatives and the gradients in one kernel (they share H and the flow factors)
        self.n_inputs = len(variables)
        self.gradient_rows = [(i, name) for (i, _, _), name in zip(gradients, gradient_scales)]
        self.w_gradient_rows = [(i, name) for (i, _, _), name in zip(w_gradients, w_gradient_scales)]
        self.f_gradient_rows = [(i, name) for (i, _, _), name in zip(f_gradients, f_gradient_scales)]
        self.jacobian_vectors = BlockedVectors(
            space.V, v, dr_integrands + [(e, m) for _, e, m in gradients + w_gradients + f_gradients]
        )
        self.explicit = functionals_by_group(space.mesh, explicit, groups)
        # Side and supply flows: the consistent flux r(P; w) with w = 1 on the edge / supply dofs.
        edges = np.concatenate(
            [space.facet_tags.find(TAGS["edge_minus"]), space.facet_tags.find(TAGS["edge_plus"])]
        )
        self.side_flow_form = self._flux_form(fem.locate_dofs_topological(space.V, 1, edges), residual, v, dx)
        self.supply_flow_form = None
        if space.mesh_spec.supply is not None:
            supply_dofs = fem.locate_dofs_topological(space.V, 2, space.cell_tags.find(TAGS["supply"]))
            self.supply_flow_form = self._flux_form(supply_dofs, residual, v, dx)

    def scales(self) -> dict[str, float]:
        """The outputs' SI scales (per dimensionless integral over the mesh) at the space's scales."""
        s, whole = self.space.scales, float(self.space.mesh_spec.multiplicity)
        return {
            "force": whole * s.force,
            "shear_torque": whole * s.shear_torque,
            "contact_torque": whole * s.pressure * self.space.bearing.radius**3,
        }

    def set_scales(self) -> None:
        """The prescribed values anew from the space's (a new viscosity; the SI scales are read at each
        call)."""
        if self.operator is not None:
            self.operator.set_bc_values(self.space.bcs)

    def _flux_form(self, dofs: np.ndarray, residual, v, dx):
        """The compiled form of ``r(P; w)`` over the whole film, w = 1 on ``dofs`` (local) and 0 elsewhere:
        the flow that the discrete equation lets through those dofs (the sum of their residuals).

        w vanishes outside the cells that have one of the dofs, so only those cells are integrated
        (every cell with such a dof: also those that touch the dofs' boundary at a vertex only)."""
        space = self.space
        indicator = fem.Function(space.V)
        indicator.x.array[dofs] = 1.0
        cell_dofs = space.V.dofmap.list.array.reshape(-1, space.V.dofmap.dof_layout.num_dofs)
        cells = np.flatnonzero(indicator.x.array[cell_dofs].any(axis=1)).astype(np.int32)
        marker = meshtags(space.mesh, 2, cells, np.ones(len(cells), dtype=np.int32))
        dx_cells = ufl.dx(domain=space.mesh, subdomain_data=marker, subdomain_id=1, metadata=dx.metadata())
        whole = float(space.mesh_spec.multiplicity)
        return compile_form(whole * ufl.replace(residual, {v: indicator}) * dx_cells)

    # -- at a solved state ------------------------------------------------------------------------
    def contact_cells(self) -> np.ndarray:
        """Owned cells where the asperity pressure can be non-zero at a quadrature point.

        Greenwood-Tripp's pressure and contact area vanish exactly for h/sigma >= contact.support;
        a cell is kept when the film thickness at one of its vertices is below that plus the most it
        can fall toward the cell's interior (|eps| times the cell's angular extent).
        """
        space = self.space
        if space.contact is None:
            return np.zeros(0, dtype=np.int32)
        eps_x, eps_y = float(space.params.eps_x.value), float(space.params.eps_y.value)
        limit = (
            space.contact.support * space.sigma / space.bearing.clearance
            + math.hypot(eps_x, eps_y) * space.cell_extent
        )
        if space.W is not None:  # the deformation at the vertices (P1: the cells' dofs)
            H = (
                1.0
                - eps_x * space.vertex_cos
                - eps_y * space.vertex_sin
                + space.W.x.array[self.operator.dofs]
                + space.vertex_relief
            )
            return space.owned_cells[H.min(axis=1) < limit]
        if space.relief is not None:  # the rigid gap's least vertex value plus the relief's
            H = 1.0 - eps_x * space.vertex_cos - eps_y * space.vertex_sin
            return space.owned_cells[H.min(axis=1) + space.vertex_relief.min(axis=1) < limit]
        below = 1.0 - eps_x * space.node_cos - eps_y * space.node_sin < limit  # at the nodes
        a, b, c = space.cell_nodes
        return space.owned_cells[below[a] | below[b] | below[c]]

    def _integrate(self, functionals, in_contact: np.ndarray) -> np.ndarray:
        """A group of functionals at the last solved state (contact groups on its contact cells only)."""
        return functionals(in_contact if functionals.contact_only else None)

    def assemble(self, form) -> float:
        value = fem.assemble_scalar(form)
        comm = self.space.comm
        return value if comm.size == 1 else comm.allreduce(value, op=MPI.SUM)

    def values(self, in_contact: np.ndarray) -> dict[str, float]:
        """SI values of every functional, and of the Jacobian rows (in the solution frame)."""
        space = self.space
        raw = {k: vec.dot(space.pressure.vector) for k, vec in self.force_vectors.items()}
        if self.operator is not None:  # integrated with the operator's coefficients, at this state
            raw.update(zip(self.operator_integral_names, self.operator.integrals))
        if self.pressure_torque is not None:
            n = self.pressure_torque.B.shape[1]
            value = self.pressure_torque(
                space.pressure.x.array[:n],
                float(space.params.eps_x.value),
                float(space.params.eps_y.value),
                None if space.W is None else space.W.x.array[:n],
            )
            raw.update(dict.fromkeys(_PRESSURE_TORQUES, value))
        for names, functionals in self.scalars:
            raw.update(zip(names, self._integrate(functionals, in_contact)))
        scale = self.scales()
        values = {k: raw[k] * scale[s] for k, (_, s, _, _) in self.outputs.items()}
        values.update({k: raw[k] for k in self.extra_names})
        for row in JACOBIAN_ROWS:
            values[row] = sum(values[k] for k, (_, _, r, _) in self.outputs.items() if r == row)
        return values

    def set_film_fraction(self, theta: np.ndarray | None) -> None:
        """The solved film fraction (owned dofs) that weights the Couette shear; a no-op when the shear
        is not weighted (``film_fraction`` None) or the film has no fraction (None)."""
        if self.film_fraction is None or theta is None:
            return
        self.film_fraction.x.array[: len(theta)] = theta
        self.film_fraction.x.scatter_forward()

    def residual_derivatives(self) -> tuple[list, list, list, list]:
        """(dr/dtheta per input, the rows' dE/dP, the rows' dE/dW, the rows' dE/d(film fraction)) as
        PETSc vectors at the current state (reused between calls), dr zero on the prescribed dofs."""
        vectors = self.jacobian_vectors()
        n_in, n_grad, n_w = self.n_inputs, len(self.gradient_rows), len(self.w_gradient_rows)
        split = n_in + n_grad + n_w
        dr, gradients = vectors[:n_in], vectors[n_in : n_in + n_grad]
        w_gradients, f_gradients = vectors[n_in + n_grad : split], vectors[split:]
        for vec in dr:
            fem_petsc.set_bc(vec, self.space.bcs, scale=0.0)
        return dr, gradients, w_gradients, f_gradients

    def jacobian(
        self,
        dP: list,
        dW: list | None,
        gradients: list,
        w_gradients: list,
        in_contact,
        dF: list | None = None,
        f_gradients: list = (),
    ) -> np.ndarray:
        """The Jacobian rows (4) per dimensionless input (eps, deps, U_mean, U_half_diff), SI, in the
        solution frame, from the true pressure's sensitivities dP (PETSc vectors), the deformation's
        dW (arrays; None: rigid) and the film fraction's dF (arrays; None: not available, and the
        Couette torques' change through the film fraction is left out)."""
        J = np.zeros((4, self.n_inputs))
        scale = self.scales()
        for keys, functionals in self.explicit:
            for key, value in zip(keys, self._integrate(functionals, in_contact)):
                name = self.explicit_scales[key]
                J[key[0], key[1]] += value * (scale[name] / self.built_scales[name])
        for i, row in enumerate(JACOBIAN_ROWS):
            for name, (_, s, r, _) in self.outputs.items():
                if r == row and name in self.force_vectors:
                    J[i] += scale[s] * np.array([self.force_vectors[name].dot(d) for d in dP])
        for (i, name), gradient in zip(self.gradient_rows, gradients):
            J[i] += np.array([gradient.dot(d) for d in dP]) * (scale[name] / self.built_scales[name])
        for (i, name), gradient in zip(self.w_gradient_rows, w_gradients):  # through the deformation
            values = gradient.getArray(readonly=True)
            J[i] += np.array([values @ d for d in dW]) * (scale[name] / self.built_scales[name])
        if dF is not None:
            for (i, name), gradient in zip(self.f_gradient_rows, f_gradients):  # through the film fraction
                values = gradient.getArray(readonly=True)
                J[i] += np.array([values @ d for d in dF]) * (scale[name] / self.built_scales[name])
        return J

    def close(self) -> None:
        self.jacobian_vectors.close()
        for vec in self.force_vectors.values():
            vec.destroy()
        self.A.destroy()
