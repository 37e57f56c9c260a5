"""Material table of the chassis assembly, in SI units.

Linear elastic isotropic materials. Values are nominal handbook values for the
materials named in the thesis (Section 3.1): sheet steel for side members, front
cross members, tanks and the right mudguard bracket; cast iron for the two rear
cross members; rubber for the bushing of the left mudguard bracket.

The water in the fuel tanks is not a material: it is non-structural mass smeared
over the tank shell by raising its density (thesis Section 4.3), see
:attr:`exudyn_study.bodies.fe.chassis.Part.added_mass_kg`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

from exudyn_study.errors import InputError

__all__ = ["Material", "MATERIALS", "material"]


@dataclass(frozen=True)
class Material:
    """A linear elastic isotropic material.

    Parameters
    ----------
    name : str
        Key of the material, e.g. ``"steel"``.
    youngs_modulus_pa : float
        Young's modulus E in Pa; must be positive.
    poisson_ratio : float
        Poisson's ratio nu; must lie in (-1, 0.5).
    density_kg_m3 : float
        Mass density in kg/m^3; must be positive.
    """

    name: str
    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float

    def __post_init__(self) -> None:
        for field, value in (
            ("youngs_modulus_pa", self.youngs_modulus_pa),
            ("density_kg_m3", self.density_kg_m3),
        ):
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(
                    f"material {self.name!r}: {field} = {value!r}; expected a positive finite number"
                )
        if not (math.isfinite(self.poisson_ratio) and -1.0 < self.poisson_ratio < 0.5):
            raise InputError(
                f"material {self.name!r}: poisson_ratio = {self.poisson_ratio!r}; "
                "expected a value in (-1, 0.5)"
            )

    @property
    def lame_parameters(self) -> tuple[float, float]:
        """Lame parameters (mu, lambda) in Pa."""
        e, nu = self.youngs_modulus_pa, self.poisson_ratio
        mu = e / (2.0 * (1.0 + nu))
        lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        return mu, lam


#: The materials of the chassis assembly. Rubber: a filled natural rubber of a
#: mudguard bushing (shear modulus ~1.7 MPa); nu = 0.47 keeps second-order tets
#: free of volumetric locking while staying nearly incompressible.
MATERIALS = MappingProxyType(
    {
        "steel": Material("steel", 210.0e9, 0.30, 7850.0),
        "cast_iron": Material("cast_iron", 165.0e9, 0.27, 7200.0),
        "rubber": Material("rubber", 5.0e6, 0.47, 1150.0),
    }
)


def material(name: str) -> Material:
    """Return the material called ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`MATERIALS` (e.g. 'steel').

    Returns
    -------
    Material
        Young's modulus (Pa), Poisson's ratio and density (kg/m^3).

    Raises
    ------
    InputError
        If ``name`` is not in :data:`MATERIALS`.
    """
    try:
        return MATERIALS[name]
    except KeyError:
        raise InputError(
            f"material {name!r} is unknown; expected one of {sorted(MATERIALS)}"
        ) from None
