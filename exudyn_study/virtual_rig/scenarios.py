"""Named, seeded truth configurations of the virtual test rig.

A :class:`Scenario` says what the virtual rig's *truth* is: a nominal model variant with
its damping, the physics augmentations of the catalogue (:mod:`exudyn_study.physics`)
applied to it, and the measurement chain (servo drive and acquisition,
:mod:`exudyn_study.measurement`). The registry :data:`SCENARIOS` holds:

``none``
    truth = nominal Model 1 + measurement chain only (nothing is missing);
``thesis``
    the thesis's rig as we read it (Sections 5 and 7): Model 3 with compliant tank
    mounts, the water sloshing in both tanks and the right tank's walls breathing, the left
    mudguard bracket's stiffening rubber bushing, compliant rear supports of the frame, a
    compliant drive linkage (the ~28 Hz resonance of Section 7.1) and per-body damping; its
    EMA gives Table 1 (see :data:`THESIS_TABLE1` and :mod:`exudyn_study.virtual_rig.thesis`);
``thesis-iso``, ``thesis-dry``
    variants of the thesis truth (tank mounts equally stiff on all axes and no wall mode; the
    same without the water);
one single-effect scenario per catalogue entry
    named after the entry, nominal model + that entry at a documented place.

:func:`random_scenario` draws a blind scenario (effect, location, parameter value within
the entry's bounds, seed) for the diagnosis benchmark; its name says nothing about the
effect.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..measurement import AcquisitionParameters, ServoParameters

__all__ = [
    "Augment",
    "Scenario",
    "SCENARIOS",
    "scenario",
    "register_scenario",
    "random_scenario",
    "THESIS_TABLE1",
    "BLIND_EFFECTS",
]

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
    """One catalogue entry applied at a location with parameters (SI, the entry's units)."""

    physics: str
    location: str | None = None
    parameters: Mapping[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
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
        Damping function name (:data:`exudyn_study.damping.DAMPING_FUNCTIONS`, or 'table6').
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
        from ..physics import entry

        for a in self.augmentations:
            entry(a.physics).resolve(**dict(a.parameters))

    def with_seed(self, seed: int) -> Scenario:
        """The same truth with another seed (drive, servo and sensor noise)."""
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


_SCENARIOS: dict[str, Scenario] = {}
SCENARIOS: Mapping[str, Scenario] = _SCENARIOS


def register_scenario(s: Scenario, replace: bool = False) -> Scenario:
    """Add ``s`` to :data:`SCENARIOS` (InputError if the name is taken and not ``replace``)."""
    if s.name in _SCENARIOS and not replace:
        raise InputError(f"scenario {s.name!r} already exists; pass replace=True")
    _SCENARIOS[s.name] = s
    return s


def scenario(name: str) -> Scenario:
    """The scenario called ``name`` (InputError listing the known ones)."""
    try:
        return _SCENARIOS[name]
    except (KeyError, TypeError):
        raise InputError(f"scenario {name!r} is unknown; expected one of {sorted(_SCENARIOS)}") from None


register_scenario(
    Scenario(
        name="none",
        description="Nominal Model 1 with Adams default damping, measured through the rig's servo drive and "
        "acquisition chain; no physics is missing from the nominal model.",
        variant=1,
        damping="adams-default",
    )
)

#: single-effect scenarios: (entry, location, parameters, nominal variant, description)
_SINGLE = (
    (
        "added_mass",
        "ARFVZ",
        {"mass_kg": 15.0},
        1,
        "15 kg rigidly attached at the left frame side member's drive point (sensor ARFVZ).",
    ),
    (
        "drive_linkage_compliance",
        None,
        {"stiffness_n_per_m": 2e7, "damping_n_s_per_m": 2e3, "mass_kg": 20.0},
        1,
        "A compliant piston-linkage connection with 20 kg of linkage mass: the ~28 Hz rig resonance.",
    ),
    (
        "joint_stiffness",
        "tank_left.tank_left_front",
        {"stiffness_n_per_m": 2e6},
        3,
        "The left tank's front mount is a 2e6 N/m spring instead of a rigid joint (Model 3).",
    ),
    (
        "joint_friction",
        "bracket_right.bracket_right",
        {"stuck_stiffness_n_per_m": 2e7, "slip_force_n": 40.0},
        3,
        "Micro-slip in the right mudguard bracket's bolted joint (Model 3).",
    ),
    (
        "sloshing",
        "tank_right",
        {"slosh_mass_kg": 60.0, "slosh_frequency_hz": 2.5, "slosh_damping_ratio": 0.02},
        1,
        "60 kg of the right tank's water sloshes at 2.5 Hz.",
    ),
    (
        "tank_wall_mode",
        "tank_right",
        {"wall_frequency_hz": 17.0, "wall_damping_ratio": 0.15, "wall_mass_kg": 15.0},
        1,
        "The right tank's water-loaded side walls breathe across it at 17 Hz (15 kg, 15 % damped): a "
        "tuned-mass damper on the modes that move the tank sideways near 17 Hz.",
    ),
    (
        "bushing_stiffening",
        "bracket_left",
        {"cubic_stiffness_n_per_m3": 5e13},
        3,
        "The left mudguard bracket's rubber bushing stiffens with amplitude (Model 3): at the default level "
        "the pad's relative motion is ~0.07 mm rms against a ~3.6e6 N/m tangent, so 5e13 N/m^3 stiffens it "
        "by ~20 % at rms motion and by ~2x at the peaks.",
    ),
    (
        "bushing_stiffness",
        "bracket_left",
        {"shear_modulus_increase_pa": 2e6, "compression_modulus_increase_pa": 1e7, "damping_time_s": 1e-3},
        3,
        "The left mudguard bracket's rubber pad is stiffer and lossier than the nominal rubber (Model 3): "
        "shear modulus +2 MPa, compression modulus +10 MPa, 1 ms damping time; the bracket's z and x modes "
        "rise from 13.5/26.7 to 16.3/30.0 Hz and their damping from 0.8/1.3 to 2.2/3.0 %.",
    ),
    (
        "rear_support_compliance",
        "rear_left",
        {"vertical_stiffness_n_per_m": 1e7, "damping_time_s": 2e-4},
        1,
        "The frame's left rear attachment sits on a 1e7 N/m vertical spring instead of the rigid spherical "
        "joint on the rear foundation.",
    ),
    (
        "modal_damping",
        "chassis",
        {"factor": 2.5},
        1,
        "The chassis's modal damping is 2.5 times the Adams default.",
    ),
    ("sensor_gain", "ARHBZ", {"gain": 1.25}, 1, "Sensor ARHBZ reads 25 % high (a calibration error)."),
)

for _name, _loc, _params, _variant, _text in _SINGLE:
    register_scenario(
        Scenario(
            name=_name, description=_text, variant=_variant, augmentations=(Augment(_name, _loc, _params),)
        )
    )

from .thesis import (  # noqa: E402  (own module: tuned against Table 1)
    THESIS_DRY_SCENARIO,
    THESIS_ISO_SCENARIO,
    THESIS_SCENARIO,
)

register_scenario(THESIS_SCENARIO)
register_scenario(THESIS_ISO_SCENARIO)
register_scenario(THESIS_DRY_SCENARIO)

#: effects the blind benchmark draws from: entry -> (nominal variant, candidate locations)
BLIND_EFFECTS = {
    "added_mass": (1, ("ARFVZ", "ARFHZ", "ARFMZ", "AVBFZ", "ARHBZ", "ATHBZ", "ASVZ", "chassis.front_strut")),
    "drive_linkage_compliance": (1, (None,)),
    "modal_damping": (1, ("chassis",)),
    "sensor_gain": (1, ("ARFVZ", "ARFMZ", "ARHBZ", "ATVBZ", "ASHZ")),
    "bushing_stiffening": (3, ("bracket_left",)),
}


def random_scenario(index: int, effect: str | None = None, rng_seed: int = 2026) -> Scenario:
    """A blind scenario: effect, location, parameter values (log-uniform within bounds) and seed drawn.

    Parameters
    ----------
    index : int
        Scenario number (name ``blind-{index:02d}``; the draw is reproducible from it).
    effect : str, optional
        Force the effect ('none' for a scenario without one); default: drawn from
        :data:`BLIND_EFFECTS`.
    """
    from ..physics import entry

    rng = np.random.default_rng([rng_seed, int(index)])
    names = sorted(BLIND_EFFECTS)
    if effect is None:
        effect = names[int(rng.integers(len(names)))]
    seed = int(rng.integers(1, 10_000))
    if effect == "none":
        return Scenario(
            name=f"blind-{index:02d}", description="blind scenario", variant=1, seed=seed
        ).with_seed(seed)
    if effect not in BLIND_EFFECTS:
        raise InputError(f"blind effect {effect!r} is unknown; expected 'none' or one of {names}")
    variant, locations = BLIND_EFFECTS[effect]
    location = locations[int(rng.integers(len(locations)))]
    e = entry(effect)
    params = {}
    for p in e.parameters:
        if (effect, p.name) in _BLIND_FIXED:
            params[p.name] = _BLIND_FIXED[(effect, p.name)]
            continue
        if (effect, p.name) not in _BLIND_RANGES:
            continue  # the entry's default
        lo, hi = _BLIND_RANGES[(effect, p.name)]
        value = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
        if (effect, p.name) in _BLIND_RATIO and rng.uniform() < 0.5:
            value = 1.0 / value  # a factor below one as often as above
        params[p.name] = p.check(value, effect)
    return Scenario(
        name=f"blind-{index:02d}",
        description="blind scenario",
        variant=variant,
        seed=seed,
        augmentations=(Augment(effect, location, params),),
    ).with_seed(seed)


#: sub-ranges of the entries' bounds from which blind effects are drawn log-uniformly (large
#: enough to matter, within what a rig could hide); (entry, parameter) -> (low, high).
#: Parameters not listed keep the entry's default.
_BLIND_RANGES = {
    ("added_mass", "mass_kg"): (5.0, 40.0),
    ("drive_linkage_compliance", "stiffness_n_per_m"): (8e6, 5e7),
    ("drive_linkage_compliance", "damping_n_s_per_m"): (1e3, 4e3),
    ("drive_linkage_compliance", "mass_kg"): (10.0, 40.0),
    ("modal_damping", "factor"): (1.4, 3.0),
    ("sensor_gain", "gain"): (1.08, 1.4),
    ("bushing_stiffening", "cubic_stiffness_n_per_m3"): (2e13, 2e14),
}
#: parameters set, not drawn: modal damping scales the body modes below 200 Hz (the ones that
#: shape the response in the drive band; Adams default damping is 100 % above 1 kHz)
_BLIND_FIXED = {("modal_damping", "max_frequency_hz"): 200.0}
#: ratio parameters drawn as their value or its inverse with equal probability
_BLIND_RATIO = {("modal_damping", "factor"), ("sensor_gain", "gain")}
