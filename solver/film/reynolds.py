"""Averaged Reynolds equation on the bearing surface: UFL forms only (no PETSc, no MPI, no files).

Equation (DESIGN 3.2; Patir & Cheng 1978, 1979; contact factor of Wu & Zheng 1989), x circumferential
(R theta), y axial, U1 bushing and U2 journal surface speed, in the bushing frame::

    d/dx(phi_x h^3/(12 mu) dp/dx) + d/dy(phi_y h^3/(12 mu) dp/dy)
        = (U1+U2)/2 phi_c dh/dx + (U1-U2)/2 sigma dphi_s/dx + phi_c dh/dt

Dimensionless with ``solver.film.scaling`` (X = x/R, H = h/c, P = p/p_ref, p_ref = 12 mu omega_ref (R/c)^2)::

    div(D grad P) = U_m phi_c dH/dtheta + U_d S dphi_s/dtheta + phi_c dH/dT
    D = H^3 (phi_x t t + phi_y e_z e_z),  U_m = (U1+U2)/(2 R omega_ref),  U_d = (U1-U2)/(2 R omega_ref)

with ``S = sigma/c`` and ``t`` the unit circumferential tangent. The film surface is the unit
cylinder (``solver.film.mesh``), so a point is (cos theta, sin theta, Z) and the weak form is written with
the tangential gradient of the manifold mesh: no seam, no periodic constraint.

Film thickness of rigid aligned surfaces (DESIGN 3.1), eccentricity (eps_x, eps_y) = e'/c in the
bushing frame::

    H = 1 - eps_x cos(theta) - eps_y sin(theta),   dH/dT = -deps_x cos(theta) - deps_y sin(theta)

The weak residual is ``F(P; v) = integral(D grad P . grad v + f v) dA`` with f the right-hand side;
cavitation ``P >= P_cav`` makes it a variational inequality (solver.film.cavitation).

Roughness enters through the flow factors of a ``roughness`` object (``solver.film.flow_factors``); with
``roughness=None`` the smooth Reynolds equation is used (phi_x = phi_y = phi_c = 1, phi_s = 0).

What the caller provides: the mesh (unit radius), the pressure Function P, the test function v and a
``FilmParameters`` of ``fem.Constant``s; changing a constant does not recompile any form.
"""

from __future__ import annotations

from typing import Any, Protocol

from petsc4py import PETSc

import numpy as np
import ufl
from dolfinx import fem


class Roughness(Protocol):
    """Flow and shear-stress factors as functions of Hs = h/sigma, evaluated with ``mod=np`` or ``ufl``."""

    def pressure_flow_x(self, Hs: Any, mod: Any = np) -> Any: ...  # phi_x, circumferential
    def pressure_flow_y(self, Hs: Any, mod: Any = np) -> Any: ...  # phi_y, axial
    def shear_flow(self, Hs: Any, mod: Any = np) -> Any: ...  # phi_s (sign from sigma1^2 - sigma2^2)
    def contact_factor(self, Hs: Any, mod: Any = np) -> Any: ...  # phi_c
    def shear_stress_factors(
        self, Hs: Any, mod: Any = np
    ) -> tuple[Any, Any, Any]: ...  # Phi_f, Phi_fs, Phi_fp
    def pressure_shear_factor(self, Hs: Any, mod: Any = np) -> Any: ...  # Phi_fp alone


class FilmParameters:
    """The dimensionless kinematics of the film as ``fem.Constant``s on the mesh.

    Attributes:
        eps_x, eps_y: eccentricity / c in the bushing frame.
        deps_x, deps_y: their time derivatives / (c omega_ref) (bushing frame, frame rotation included).
        U_mean: (U1 + U2) / (2 R omega_ref), surface speeds relative to the bushing frame.
        U_half_diff: (U1 - U2) / (2 R omega_ref).
        S: sigma / c, composite roughness over clearance (used only with roughness).
    """

    names = ("eps_x", "eps_y", "deps_x", "deps_y", "U_mean", "U_half_diff", "S")

    def __init__(self, mesh):
        for name in self.names:
            setattr(self, name, fem.Constant(mesh, PETSc.ScalarType(0.0)))

    def set(self, **values: float) -> None:
        """Set constants by name, e.g. ``params.set(eps_x=0.5)``."""
        for name, value in values.items():
            if name not in self.names:
                raise KeyError(name)
            getattr(self, name).value = value

    def get(self) -> dict[str, float]:
        return {name: float(getattr(self, name).value) for name in self.names}


class FilmGeometry:
    """UFL expressions of the film on the unit-cylinder mesh (theta, thickness, tangent, normal).

    The eccentricity and its rate are wrapped in ``ufl.variable`` so that derivatives of any form
    with respect to them (for the film's Jacobian) come from ``ufl.diff``. With ``deformation`` (a
    Function W = w / c, the bushing's radial deformation, positive opening the gap) the thickness is
    ``H = H_rigid + W`` (DESIGN 7), and with ``previous_deformation`` W_n and ``inverse_step`` 1 / (T -
    T_n) (a Constant; 0: quasi-static) the squeeze term has the deformation's rate (W - W_n) / (T - T_n).
    The flow and the shear stresses then use ``H_flow``, H floored smoothly below ``flow_floor`` (the
    nominal gap may close locally where the pin presses into the bushing); without deformation
    ``H_flow`` is H. ``relief``, a function ``(z, mod) -> H_r`` of the axial coordinate (the bore's edge
    relief, solver.film.relief), adds a fixed profile to H_rigid.
    """

    def __init__(
        self,
        mesh,
        params: FilmParameters,
        deformation=None,
        previous_deformation=None,
        inverse_step=None,
        flow_floor: float = 0.0,
        relief=None,
    ):
        x = ufl.SpatialCoordinate(mesh)
        r = ufl.sqrt(x[0] ** 2 + x[1] ** 2)
        self.cos, self.sin = x[0] / r, x[1] / r  # exact on the circle through each point
        self.z = x[2]
        self.normal = ufl.as_vector((self.cos, self.sin, 0.0))  # outward from the journal centre
        self.tangent = ufl.as_vector((-self.sin, self.cos, 0.0))  # direction of increasing theta
        self.axial = ufl.as_vector((0.0, 0.0, 1.0))
        self.eps_x, self.eps_y = ufl.variable(params.eps_x), ufl.variable(params.eps_y)
        self.deps_x, self.deps_y = ufl.variable(params.deps_x), ufl.variable(params.deps_y)
        self.U_mean, self.U_half_diff = ufl.variable(params.U_mean), ufl.variable(params.U_half_diff)
        self.params = params
        self.H = 1.0 - self.eps_x * self.cos - self.eps_y * self.sin
        if relief is not None:  # the bore's edge relief H_r(z), fixed: no rate, no theta slope
            self.H = self.H + relief(self.z, mod=ufl)
        self.dH_dtheta = self.eps_x * self.sin - self.eps_y * self.cos
        self.dH_dT = -self.deps_x * self.cos - self.deps_y * self.sin
        self.W = self.dW_dtheta = None
        self.H_flow = self.H  # the thickness in the Poiseuille flow and the shear stresses
        if deformation is not None:
            # elastic bushing (DESIGN 7): H = H_rigid + W with W = w / c the radial deformation (a
            # Function); W and its circumferential slope are variables so that the film's coupled
            # Jacobian takes their derivatives with ufl.diff (solver.film.ehd)
            self.W = ufl.variable(deformation)
            self.dW_dtheta = ufl.variable(ufl.dot(ufl.grad(deformation), self.tangent))
            self.H = self.H + self.W
            self.dH_dtheta = self.dH_dtheta + self.dW_dtheta
            if previous_deformation is not None:
                # its rate by implicit Euler from the last accepted state: (W - W_n) / (T - T_n)
                self.dH_dT = self.dH_dT + (self.W - previous_deformation) * inverse_step
            # a pin pressed into the bushing can close the nominal gap locally (the asperities carry the
            # load there): below flow_floor the flow and shear see h0 exp(H/h0 - 1), positive, C1 at h0
            h0 = flow_floor
            self.H_flow = ufl.conditional(ufl.lt(self.H, h0), h0 * ufl.exp(self.H / h0 - 1.0), self.H)

    def variables(self) -> dict[str, Any]:
        """The UFL variables the film's Jacobian is taken with respect to."""
        return {
            "eps_x": self.eps_x,
            "eps_y": self.eps_y,
            "deps_x": self.deps_x,
            "deps_y": self.deps_y,
            "U_mean": self.U_mean,
            "U_half_diff": self.U_half_diff,
        }


def flow_factors(geometry: FilmGeometry, roughness: Roughness | None):
    """(phi_x, phi_y, phi_s, phi_c) as UFL expressions; smooth values when roughness is None."""
    if roughness is None:
        return 1.0, 1.0, 0.0, 1.0
    Hs = geometry.H / geometry.params.S
    return (
        roughness.pressure_flow_x(Hs, mod=ufl),
        roughness.pressure_flow_y(Hs, mod=ufl),
        roughness.shear_flow(Hs, mod=ufl),
        roughness.contact_factor(Hs, mod=ufl),
    )


def reynolds_coefficients(geometry: FilmGeometry, roughness: Roughness | None = None):
    """(k_theta, k_z, f): the residual's integrand is ``k_theta (t.grad P)(t.grad v) + k_z (e_z.grad P)
    (e_z.grad v) + f v`` with k_theta = H^3 phi_x, k_z = H^3 phi_y and f the right-hand side."""
    g, prm = geometry, geometry.params
    phi_x, phi_y, phi_s, phi_c = flow_factors(g, roughness)
    source = g.U_mean * phi_c * g.dH_dtheta + phi_c * g.dH_dT
    if roughness is not None:
        # U_d S dphi_s/dtheta, with dphi_s/dtheta = dphi_s/dHs * dH/dtheta / S
        Hs = ufl.variable(g.H / prm.S)
        dphi_s = ufl.diff(roughness.shear_flow(Hs, mod=ufl), Hs)
        source += g.U_half_diff * dphi_s * g.dH_dtheta
    return g.H_flow**3 * phi_x, g.H_flow**3 * phi_y, source


def reynolds_integrand(P, v, geometry: FilmGeometry, roughness: Roughness | None = None):
    """Integrand of the weak residual F(P; v) of the averaged Reynolds equation (module docstring)."""
    g = geometry
    k_theta, k_z, source = reynolds_coefficients(g, roughness)
    D = k_theta * ufl.outer(g.tangent, g.tangent) + k_z * ufl.outer(g.axial, g.axial)
    return ufl.inner(D * ufl.grad(P), ufl.grad(v)) + source * v


def shear_traction_integrands(P, geometry: FilmGeometry, roughness: Roughness | None = None):
    """Circumferential shear traction of the fluid on the journal and on the bushing.

    Couette-Poiseuille profile across the film (n from the journal, speed U2, to the bushing, U1):
    ``tau_journal = mu (U1 - U2)/h - h/2 dp/dx`` and ``tau_bushing = -mu (U1 - U2)/h - h/2 dp/dx``
    (positive along +theta), with Patir & Cheng's shear-stress factors on rough surfaces::

        tau = mu (U1 - U2)/h (Phi_f -/+ Phi_fs) -/+ Phi_fp h/2 dp/dx.

    Returned in units of ``mu R omega_ref / c``; with the scaling ``h/2 dp/dx = 6 H dP/dtheta``, as
    the parts ``(couette_journal, couette_bushing, pressure)`` with ``tau_journal = couette_journal +
    pressure`` and ``tau_bushing = couette_bushing + pressure`` (the pressure part is linear in P).
    """
    g, prm = geometry, geometry.params
    dP_dtheta = ufl.dot(ufl.grad(P), g.tangent)
    relative_speed = 2.0 * g.U_half_diff  # (U1 - U2) / (R omega_ref)
    if roughness is None:
        Phi_f, Phi_fs, Phi_fp = 1.0, 0.0, 1.0
    else:
        Phi_f, Phi_fs, Phi_fp = roughness.shear_stress_factors(g.H / prm.S, mod=ufl)
    couette = relative_speed / g.H_flow
    poiseuille = 6.0 * g.H_flow * dP_dtheta
    return couette * (Phi_f - Phi_fs), -couette * (Phi_f + Phi_fs), -Phi_fp * poiseuille


def asperity_integrands(geometry: FilmGeometry, contact, pressure_ref: float, slip_regularisation: float):
    """Greenwood-Tripp asperity pressure, its friction traction on the journal, and the contact area ratio.

    Returns ``(P_c, tau_c_journal, area_ratio)`` with P_c = p_c / p_ref and tau_c in units of p_ref.
    The asperity friction ``mu_f p_c`` acts on the journal along the bushing's velocity relative to
    it, ``sign(U1 - U2)``, regularised as ``x / sqrt(x^2 + x_reg^2)`` so that the torque is smooth
    when the sliding reverses (as it does twice per revolution in an engine's small end).
    """
    Hs = geometry.H / geometry.params.S
    P_c = contact.pressure(Hs, mod=ufl) / pressure_ref
    slip = 2.0 * geometry.U_half_diff  # (U1 - U2) / (R omega_ref)
    direction = slip / ufl.sqrt(slip**2 + slip_regularisation**2)
    return P_c, contact.friction * P_c * direction, contact.area_ratio(Hs, mod=ufl)
