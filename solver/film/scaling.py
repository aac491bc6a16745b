"""Reference scales of the film problem: the only place where SI <-> dimensionless happens.

The film is solved in dimensionless variables (DESIGN 3.5)::

    X = x / R,  H = h / c,  T = omega_ref t,  P = p / p_ref,  p_ref = 12 mu omega_ref (R / c)^2

with which the smooth Reynolds equation ``d/dx(h^3/(12 mu) dp/dx) + ... = U_m dh/dx + dh/dt`` becomes
``div(H^3 grad P) = (U_m / (R omega_ref)) dH/dX + dH/dT``. In SI the Reynolds matrix entries are
~1e-15 and residuals ~1e-11, which breaks PETSc's LU pivoting and convergence tests; scaled, they are
O(1).
"""

from __future__ import annotations

import dataclasses

from solver.errors import out_of_range


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilmScales:
    """Reference scales of one bearing (SI inputs)."""

    radius: float  # m, nominal radius R
    clearance: float  # m, radial clearance c
    viscosity: float  # Pa s, dynamic viscosity mu
    omega_ref: float  # rad/s, reference angular speed (journal speed, crank speed or squeeze rate)

    def __post_init__(self) -> None:
        for name in ("radius", "clearance", "viscosity", "omega_ref"):
            value = getattr(self, name)
            if not value > 0:
                raise out_of_range(name, value, "> 0")

    @property
    def pressure(self) -> float:
        """p_ref = 12 mu omega_ref (R/c)^2 [Pa]."""
        return 12.0 * self.viscosity * self.omega_ref * (self.radius / self.clearance) ** 2

    @property
    def force(self) -> float:
        """Force scale p_ref R^2 [N] (the dimensionless area element is dA / R^2)."""
        return self.pressure * self.radius**2

    @property
    def shear_torque(self) -> float:
        """Torque scale of the shear stress mu R omega_ref / c acting at radius R on area R^2 [N m]."""
        return self.viscosity * self.radius**4 * self.omega_ref / self.clearance

    @property
    def flow(self) -> float:
        """Volume flow scale c R^2 omega_ref [m^3/s] (Poiseuille flow through a length R)."""
        return self.clearance * self.radius**2 * self.omega_ref

    @property
    def speed(self) -> float:
        """Surface speed scale R omega_ref [m/s]."""
        return self.radius * self.omega_ref

    @property
    def eccentricity_rate(self) -> float:
        """Scale of the eccentricity rate c omega_ref [m/s]."""
        return self.clearance * self.omega_ref
