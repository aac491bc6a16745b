"""Surface and material inputs of a mixed-lubricated bearing, validated, and the models built from them.

One dataclass gathers what an engineer specifies about the two surfaces (DESIGN 3.2-3.4): the Rq
roughness of journal (pin) and bushing, the Peklenik pattern parameter, the Greenwood-Tripp asperity
parameters (as eta*beta*sigma and sigma/beta, or as the asperity density eta and radius beta), the
elastic constants (or E' directly) and the asperity friction coefficient. ``roughness()`` and
``contact()`` build the Patir-Cheng and Greenwood-Tripp models; a surface with zero roughness on
both sides is smooth (both return None).
"""

from __future__ import annotations

import dataclasses
import math

from solver.errors import InputError, out_of_range
from solver.film.contact import GreenwoodTripp, composite_modulus
from solver.film.flow_factors import GAMMAS, PatirCheng


@dataclasses.dataclass(frozen=True, kw_only=True)
class Surface:
    """Roughness, asperity and material data of the journal/bushing pair (SI)."""

    sigma_journal: float = 0.0  # m, Rq of the journal (pin)
    sigma_bushing: float = 0.0  # m, Rq of the bushing
    peklenik_gamma: float = 1.0  # Peklenik surface pattern parameter (1: isotropic)
    eta_beta_sigma: float | None = 0.05  # asperity density x radius x sigma
    sigma_over_beta: float | None = 0.001  # sigma / asperity radius
    asperity_density: float | None = None  # 1/m^2, eta (alternative to eta_beta_sigma)
    asperity_radius: float | None = None  # m, beta (alternative to sigma_over_beta)
    E_journal: float = 210e9  # Pa
    nu_journal: float = 0.3
    E_bushing: float = 115e9  # Pa
    nu_bushing: float = 0.33
    E_composite: float | None = None  # Pa, E' given directly (overrides the four above)
    asperity_friction: float = 0.1  # asperity friction coefficient mu_f
    asperity_model: str = "exact"  # "exact" (F_5/2 by quadrature) or "fit" (the common fit)

    def __post_init__(self) -> None:
        for name in ("sigma_journal", "sigma_bushing"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise out_of_range(name, value, ">= 0 m")
        if not self.peklenik_gamma > 0:
            raise out_of_range(
                "peklenik_gamma", self.peklenik_gamma, f"> 0 (fits: [{GAMMAS[0]:.4g}, {GAMMAS[-1]:g}])"
            )
        if not GAMMAS[0] <= self.peklenik_gamma <= GAMMAS[-1]:
            raise out_of_range("peklenik_gamma", self.peklenik_gamma, f"[{GAMMAS[0]:.4g}, {GAMMAS[-1]:g}]")
        for name in ("E_journal", "E_bushing"):
            if not getattr(self, name) > 0:
                raise out_of_range(name, getattr(self, name), "> 0 Pa")
        for name in ("nu_journal", "nu_bushing"):
            if not -1 < getattr(self, name) < 0.5:
                raise out_of_range(name, getattr(self, name), "(-1, 0.5)")
        if self.E_composite is not None and not self.E_composite > 0:
            raise out_of_range("E_composite", self.E_composite, "> 0 Pa")
        if not 0 <= self.asperity_friction < 2:
            raise out_of_range("asperity_friction", self.asperity_friction, "[0, 2)")
        if self.asperity_model not in ("exact", "fit"):
            raise out_of_range("asperity_model", repr(self.asperity_model), "'exact' or 'fit'")
        for name in ("eta_beta_sigma", "sigma_over_beta", "asperity_density", "asperity_radius"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise out_of_range(name, value, "> 0")
        if self.rough and (self.asperity_density is None) == (self.eta_beta_sigma is None):
            raise InputError("give one of eta_beta_sigma and asperity_density (allowed: exactly one)")
        if self.rough and (self.asperity_radius is None) == (self.sigma_over_beta is None):
            raise InputError("give one of sigma_over_beta and asperity_radius (allowed: exactly one)")

    @property
    def rough(self) -> bool:
        return self.sigma > 0

    @property
    def sigma(self) -> float:
        """Composite roughness sqrt(sigma1^2 + sigma2^2) [m]."""
        return math.hypot(self.sigma_journal, self.sigma_bushing)

    @property
    def modulus(self) -> float:
        """Composite modulus E' [Pa]."""
        if self.E_composite is not None:
            return self.E_composite
        return composite_modulus(self.E_journal, self.nu_journal, self.E_bushing, self.nu_bushing)

    def roughness(self) -> PatirCheng | None:
        if not self.rough:
            return None
        return PatirCheng(
            sigma_bushing=self.sigma_bushing, sigma_journal=self.sigma_journal, gamma=self.peklenik_gamma
        )

    def contact(self) -> GreenwoodTripp | None:
        if not self.rough:
            return None
        sigma = self.sigma
        ebs = self.eta_beta_sigma
        if ebs is None:
            radius = (
                self.asperity_radius if self.asperity_radius is not None else sigma / self.sigma_over_beta
            )
            ebs = self.asperity_density * radius * sigma
        sob = self.sigma_over_beta if self.sigma_over_beta is not None else sigma / self.asperity_radius
        return GreenwoodTripp(
            sigma=sigma,
            eta_beta_sigma=ebs,
            sigma_over_beta=sob,
            modulus=self.modulus,
            friction=self.asperity_friction,
            method=self.asperity_model,
        )
