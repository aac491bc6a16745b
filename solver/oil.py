"""Oil viscosity and density against temperature, from the values of a data sheet or an SAE grade.

An oil is given as a data sheet gives it: kinematic viscosity at 40 C and 100 C (mm^2/s = cSt,
ASTM D445) and density at 15 C (kg/m^3, ASTM D4052).

Kinematic viscosity, ASTM D341 (Walther's equation; ASTM D341-09 (2015) / D341-20, section on the
viscosity-temperature equations), with T the absolute temperature::

    log10(log10(Z)) = A - B log10(T),     Z = nu + 0.7,     nu in mm^2/s, T = t + 273.15 in K

A and B follow from the two data points (t1, nu1), (t2, nu2)::

    B = (log10(log10(Z1)) - log10(log10(Z2))) / (log10(T2) - log10(T1))
    A = log10(log10(Z1)) + B log10(T1)
    nu(T) = 10^(10^(A - B log10(T))) - 0.7

This is the plain form, valid for nu >= 2 mm^2/s (``MIN_KINEMATIC_VISCOSITY``). The standard adds
correction terms to Z below 2 mm^2/s (secondary sources quote Z = nu + 0.7 + exp(-1.47 - 1.84 nu
- 0.51 nu^2)); they could not be checked against the standard's own text and are not implemented.
At 2 mm^2/s that term is 3e-4 of Z, and the oils of ``GRADES`` stay above 2 mm^2/s up to 200 C,
beyond any bearing film temperature.
For multigrade oils these are low-shear viscosities: at bearing shear rates (~1e6 1/s) polymer-
thickened oils thin temporarily, which the HTHS viscosity at 150 C of their data sheets measures.

Density, linear thermal expansion from 15 C::

    rho(t) = rho15 (1 - alpha (t - 15)),    alpha = K1 / rho15,    K1 = 0.6278 kg/(m^3 K)

alpha is the thermal expansion coefficient at 15 C of the lubricating-oil commodity group of the
petroleum measurement tables (API MPMS 11.1 / ASTM D1250 / IP 200: alpha = K0 / rho^2 + K1 / rho
with K0 = 0 and K1 = 0.6278 per K on the 15 C basis, 0.34878 per F on the 60 F basis): 7.4e-4 1/K at
850 kg/m^3, 7.1e-4 1/K at 880 kg/m^3. The tables apply it as exp(-alpha dt (1 + 0.8 alpha dt));
the linear form differs from that by < 0.1% up to 100 C and < 0.3% up to 150 C.

Dynamic viscosity: mu [Pa s] = nu [mm^2/s] * 1e-6 * rho [kg/m^3].

Every function of temperature takes a float or a numpy array (t in C) and returns the same shape.
``GRADES`` holds typical data-sheet values of common SAE multigrade engine oils, each from a named
product data sheet; ``oil_from_grade`` looks one up.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from solver.errors import InputError, out_of_range

KELVIN = 273.15  # K at 0 C
WALTHER_OFFSET = 0.7  # mm^2/s, the 0.7 of Z = nu + 0.7
MIN_KINEMATIC_VISCOSITY = 2.0  # mm^2/s, lowest nu of the plain Walther form (module docstring)
EXPANSION_K1 = 0.6278  # kg/(m^3 K), lubricating oils: alpha15 = K1 / rho15 (API MPMS 11.1)
DENSITY_RANGE = (700.0, 1200.0)  # kg/m^3, plausible oils; catches a value typed in kg/l or g/ml


def _float_or_array(value: np.ndarray) -> float | np.ndarray:
    """A 0-d result as a float, any other as the array."""
    return float(value) if np.ndim(value) == 0 else value


def walther_constants(t1_C: float, nu1: float, t2_C: float, nu2: float) -> tuple[float, float]:
    """(A, B) of log10(log10(nu + 0.7)) = A - B log10(T) through two points (ASTM D341, module docstring).

    Args:
        t1_C: the first temperature [C].
        nu1: the kinematic viscosity at t1_C [mm^2/s], >= 2 mm^2/s.
        t2_C: the second temperature [C], not t1_C.
        nu2: the kinematic viscosity at t2_C [mm^2/s], >= 2 mm^2/s.
    """
    log_T1, log_T2 = np.log10(t1_C + KELVIN), np.log10(t2_C + KELVIN)
    loglog_Z1 = np.log10(np.log10(nu1 + WALTHER_OFFSET))
    loglog_Z2 = np.log10(np.log10(nu2 + WALTHER_OFFSET))
    B = (loglog_Z1 - loglog_Z2) / (log_T2 - log_T1)
    return float(loglog_Z1 + B * log_T1), float(B)


def walther_viscosity(A: float, B: float, temperature_C) -> float | np.ndarray:
    """nu(t) = 10^(10^(A - B log10(t + 273.15))) - 0.7 [mm^2/s] (ASTM D341, module docstring)."""
    log_T = np.log10(np.asarray(temperature_C, dtype=float) + KELVIN)
    return _float_or_array(10.0 ** (10.0 ** (A - B * log_T)) - WALTHER_OFFSET)


@dataclasses.dataclass(frozen=True)
class OilData:
    """An oil as its data sheet gives it; viscosity and density at any temperature (module docstring)."""

    kinematic_viscosity_40C: float  # mm^2/s (cSt)
    kinematic_viscosity_100C: float  # mm^2/s
    density_15C: float  # kg/m^3

    def __post_init__(self) -> None:
        nu40, nu100 = self.kinematic_viscosity_40C, self.kinematic_viscosity_100C
        rho15 = self.density_15C
        if not nu100 >= MIN_KINEMATIC_VISCOSITY:
            raise out_of_range(
                "kinematic_viscosity_100C",
                nu100,
                f">= {MIN_KINEMATIC_VISCOSITY:g} mm^2/s (ASTM D341's plain Walther form)",
            )
        if not nu40 > nu100:
            raise out_of_range(
                "kinematic_viscosity_40C",
                nu40,
                f"> kinematic_viscosity_100C = {nu100:g} mm^2/s (oils thin when heated)",
            )
        low, high = DENSITY_RANGE
        if not low < rho15 < high:
            raise out_of_range("density_15C", rho15, f"({low:g}, {high:g}) kg/m^3 (oils: 800-1000)")

    def walther_constants(self) -> tuple[float, float]:
        """(A, B) of ASTM D341 through the 40 C and 100 C viscosities."""
        return walther_constants(40.0, self.kinematic_viscosity_40C, 100.0, self.kinematic_viscosity_100C)

    def kinematic_viscosity(self, temperature_C) -> float | np.ndarray:
        """Kinematic viscosity [mm^2/s] at t [C], ASTM D341 (valid while it is >= 2 mm^2/s)."""
        return walther_viscosity(*self.walther_constants(), temperature_C)

    @property
    def thermal_expansion(self) -> float:
        """alpha = K1 / rho15 [1/K], the lubricating-oil coefficient of API MPMS 11.1."""
        return EXPANSION_K1 / self.density_15C

    def density(self, temperature_C) -> float | np.ndarray:
        """rho(t) = rho15 (1 - alpha (t - 15)) [kg/m^3] at t [C]."""
        t = np.asarray(temperature_C, dtype=float)
        return _float_or_array(self.density_15C * (1.0 - self.thermal_expansion * (t - 15.0)))

    def dynamic_viscosity(self, temperature_C) -> float | np.ndarray:
        """mu(t) = nu(t) [mm^2/s] * 1e-6 * rho(t) [kg/m^3], in Pa s."""
        nu = np.asarray(self.kinematic_viscosity(temperature_C))
        return _float_or_array(nu * 1e-6 * np.asarray(self.density(temperature_C)))


# Typical values of named products (ExxonMobil Asia Pacific product pages, Australia, "Properties"
# tab, mobil.com, as archived in 2015; viscosities by ASTM D445, densities by ASTM D4052). Each 100 C
# viscosity lies in the SAE J300 range of its grade (tests/film/test_oil.py). The Mobil 1 sheets give
# density at 15.6 C (60 F): 0.6 K from 15 C is 0.04%, below their 0.001 g/ml rounding (0.12%).
GRADES: dict[str, OilData] = {
    # Mobil 1 0W-20: 44.8 / 8.7 mm^2/s, 0.841 g/ml at 15.6 C (VI 173, HTHS 2.7 mPa s)
    "0W-20": OilData(44.8, 8.7, 841.0),
    # Mobil 1 0W-30: 62.9 / 10.9 mm^2/s, 0.842 g/ml at 15.6 C (VI 166, HTHS 3.0 mPa s)
    "0W-30": OilData(62.9, 10.9, 842.0),
    # Mobil Super 3000 XE 5W-30: 68 / 11.9 mm^2/s, 0.85 kg/l at 15 C
    "5W-30": OilData(68.0, 11.9, 850.0),
    # Mobil Super 3000 X2 5W-40: 83 / 14.0 mm^2/s, 0.860 kg/l at 15 C (VI 174, HTHS 3.7 mPa s)
    "5W-40": OilData(83.0, 14.0, 860.0),
    # Mobil Super 2000 X2 10W-40: 96 / 14.4 mm^2/s, 0.877 kg/l at 15 C (VI 155, HTHS 3.8 mPa s)
    "10W-40": OilData(96.0, 14.4, 877.0),
    # Mobil Super 1000 X2 15W-40: 109 / 14.5 mm^2/s, 0.880 kg/l at 15 C (VI 136, HTHS 4.1 mPa s)
    "15W-40": OilData(109.0, 14.5, 880.0),
}


def oil_from_grade(grade: str) -> OilData:
    """The typical oil of an SAE grade in ``GRADES`` (e.g. ``"5W-30"``; case and spaces ignored)."""
    key = grade.strip().upper()
    if key not in GRADES:
        raise out_of_range("oil grade", repr(grade), ", ".join(repr(g) for g in GRADES))
    return GRADES[key]


#: the inputs of ``oil_data`` as its callers name them in their messages (a case's keys by default)
CASE_NAMES = {
    "grade": "oil.grade",
    "kinematic_viscosity_40C": "oil.kinematic_viscosity_40C_cSt",
    "kinematic_viscosity_100C": "oil.kinematic_viscosity_100C_cSt",
    "density_15C": "oil.density_15C_kg_m3",
}


def oil_data(
    grade: str | None,
    kinematic_viscosity_40C: float | None,
    kinematic_viscosity_100C: float | None,
    density_15C: float | None,
    names: dict[str, str] = CASE_NAMES,
) -> OilData | None:
    """The oil of a grade, or of the three data-sheet values (one kind, the sheet complete), or None
    when neither is given. Errors name the inputs as ``names`` does (a case's keys, a command's flags)."""
    sheet = (kinematic_viscosity_40C, kinematic_viscosity_100C, density_15C)
    n40, n100, rho = names["kinematic_viscosity_40C"], names["kinematic_viscosity_100C"], names["density_15C"]
    if grade is not None and any(v is not None for v in sheet):
        raise InputError(f"give either {names['grade']} or the data sheet ({n40}, {n100}, {rho}), not both")
    if grade is None and all(v is None for v in sheet):
        return None
    if grade is None and any(v is None for v in sheet):
        raise InputError(
            f"the data sheet needs {n40}, {n100} and {rho} together (allowed: all three, or none)"
        )
    try:
        return oil_from_grade(grade) if grade is not None else OilData(*sheet)
    except InputError as err:
        message = str(err).replace("oil grade", names["grade"])
        for field in ("kinematic_viscosity_40C", "kinematic_viscosity_100C", "density_15C"):
            message = message.replace(field, names[field])
        raise InputError(message) from None
