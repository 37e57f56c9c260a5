"""What a virtual-rig scenario is: a truth model (:class:`Scenario`) and its augmentations (:class:`Augment`).

Also the thesis's Table 1 (:data:`THESIS_TABLE1`), which the thesis scenarios are tuned against.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig.measurement import AcquisitionParameters, ServoParameters

#: thesis Table 1: (undamped natural frequency Hz, damping ratio, description)
THESIS_TABLE1 = (
    (12.05, 0.0181, "right fuel tank z"),
    (13.21, 0.0146, "both fuel tanks z"),
    (14.15, 0.0178, "left fuel tank z"),
    (15.00, 0.0218, "left mudguard bracket z"),
    (21.21, 0.0119, "frame bending about z"),
    (32.69, 0.0547, "left mudguard bracket x and z"),
    (36.64, 0.0346, "left mudguard bracket x and z"),
    (41.37, 0.0119, "frame bending about y"),
    (43.84, 0.0209, "frame bending about y"),
    (47.60, 0.0053, "right mudguard bracket z"),
)


@dataclass(frozen=True)
class Augment:
    """One catalogue entry applied at a location with parameters (SI, the entry's units).

    Parameters
    ----------
    physics : str
        Name of the catalogue entry (:func:`exudyn_study.physics.catalogue.entry`), e.g.
        'joint_stiffness'.
    location : str, optional
        Where the entry applies (an interface, body or side the entry accepts); None for entries
        with one place.
    parameters : mapping str -> float
        The entry's parameters by name, in its units (SI); missing ones take the entry's defaults.
    """

    physics: str
    location: str | None = None
    parameters: Mapping[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
        """Return the augmentation as a JSON-able dict.

        Returns
        -------
        dict
            ``{"physics": str, "location": str or None, "parameters": {name: float}}``, the parameters in
            the catalogue entry's units (SI).
        """
        return {
            "physics": self.physics,
            "location": self.location,
            "parameters": {k: float(v) for k, v in self.parameters.items()},
        }


@dataclass(frozen=True)
class Scenario:
    """A truth configuration of the virtual rig.

    Parameters
    ----------
    name : str
    description : str
        What the truth contains and why (one paragraph).
    variant : {1, 2, 3}
        Nominal model the truth starts from.
    damping : str
        Damping function name (:data:`exudyn_study.bodies.damping.DAMPING_FUNCTIONS`, or 'table6').
    augmentations : tuple of Augment
    servo : ServoParameters
    acquisition : AcquisitionParameters
    seed : int
        Seeds the drive signal, the servo tracking error and the sensor noise.
    rms_m : float
        Drive rms at level 1 (m).
    bushing : bool
        Model 3: 6-DOF bushings instead of fixed joints in the nominal model.
    """

    name: str
    description: str
    variant: int = 1
    damping: str = "adams-default"
    augmentations: tuple = ()
    servo: ServoParameters = ServoParameters()
    acquisition: AcquisitionParameters = AcquisitionParameters()
    seed: int = 0
    rms_m: float = 0.25e-3
    bushing: bool = False

    def __post_init__(self) -> None:
        if self.variant not in (1, 2, 3):
            raise InputError(f"scenario {self.name!r}: variant {self.variant!r}; expected 1, 2 or 3")
        if not (math.isfinite(self.rms_m) and 0 < self.rms_m <= 5e-3):
            raise InputError(f"scenario {self.name!r}: rms_m {self.rms_m!r}; expected (0, 5e-3] m")
        object.__setattr__(
            self,
            "augmentations",
            tuple(a if isinstance(a, Augment) else Augment(**a) for a in self.augmentations),
        )

    def validate(self) -> None:
        """Check every augmentation's entry, parameters and bounds (InputError naming the first bad one)."""
        from exudyn_study.physics.catalogue import entry

        for a in self.augmentations:
            entry(a.physics).resolve(**dict(a.parameters))

    def with_seed(self, seed: int) -> Scenario:
        """Return the same truth with another seed (drive, servo and sensor noise).

        Parameters
        ----------
        seed : int
            Seed of the drive signal, the servo tracking error and the sensor noise.

        Returns
        -------
        Scenario
            A copy whose ``seed``, ``servo.seed`` and ``acquisition.seed`` are all ``seed``.
        """
        return dataclasses.replace(
            self,
            seed=int(seed),
            servo=dataclasses.replace(self.servo, seed=int(seed)),
            acquisition=dataclasses.replace(self.acquisition, seed=int(seed)),
        )

    def truth(self) -> dict:
        """JSON-able description of the truth (the file the rest of the tool never reads)."""
        return {
            "scenario": self.name,
            "description": self.description,
            "variant": self.variant,
            "damping": self.damping,
            "bushing": self.bushing,
            "seed": self.seed,
            "rms_m": self.rms_m,
            "augmentations": [a.as_dict() for a in self.augmentations],
            "servo": dataclasses.asdict(self.servo),
            "acquisition": dataclasses.asdict(self.acquisition),
        }
