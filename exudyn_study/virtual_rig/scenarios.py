"""Named, seeded truth configurations of the virtual test rig.

A :class:`Scenario` says what the virtual rig's *truth* is: a nominal model variant with
its damping, the physics augmentations of the catalogue (:mod:`exudyn_study.physics`)
applied to it, and the measurement chain (servo drive and acquisition,
:mod:`exudyn_study.virtual_rig.measurement`). The registry :data:`SCENARIOS` holds:

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
effect. :func:`wide_scenario` draws from a wider pool (:data:`WIDE_EFFECTS`: point effects
anywhere on the surface of the chassis's parts (:data:`SURFACE_REGIONS`), the drive linkage and
the rear supports, sensor faults including polarity and swaps, physics the diagnosis has no
candidate for), with two effects at once in :data:`WIDE_TWO_EFFECT_SHARE`
of the scenarios; :data:`HELD_BACK_SEED` draws a range kept for the final score.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig.scenario import Augment, Scenario
from exudyn_study.virtual_rig.thesis import (
    THESIS_DRY_SCENARIO,
    THESIS_ISO_SCENARIO,
    THESIS_SCENARIO,
)

__all__ = [
    "SCENARIOS",
    "scenario",
    "register_scenario",
    "random_scenario",
    "BLIND_EFFECTS",
    "wide_scenario",
    "WIDE_EFFECTS",
    "WIDE_TWO_EFFECT_SHARE",
    "DEVELOPMENT_SEED",
    "HELD_BACK_SEED",
    "SURFACE_REGIONS",
]


_SCENARIOS: dict[str, Scenario] = {}
SCENARIOS: Mapping[str, Scenario] = _SCENARIOS


def register_scenario(s: Scenario, replace: bool = False) -> Scenario:
    """Add ``s`` to :data:`SCENARIOS` (InputError if the name is taken and not ``replace``).

    Parameters
    ----------
    s : Scenario
        Scenario to add, under ``s.name``.
    replace : bool, default False
        Whether to replace a scenario already registered under the same name.

    Returns
    -------
    Scenario
        ``s``.
    """
    if s.name in _SCENARIOS and not replace:
        raise InputError(f"scenario {s.name!r} already exists; pass replace=True")
    _SCENARIOS[s.name] = s
    return s


def scenario(name: str) -> Scenario:
    """Return the scenario called ``name`` (InputError listing the known ones).

    Parameters
    ----------
    name : str
        Name of the scenario.

    Returns
    -------
    Scenario
        The registered scenario.
    """
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
    (
        "tuned_mass_damper",
        "ATHBZ",
        {"mass_kg": 6.0, "frequency_hz": 18.0, "damping_ratio": 0.08},
        1,
        "A 6 kg mass on an 18 Hz, 8 %-damped spring at the right tank's rear (sensor ATHBZ): a tuned "
        "mass-damper the nominal model lacks.",
    ),
    (
        "ground_spring_damper",
        "ARHBZ",
        {"stiffness_n_per_m": 0.0, "damping_n_s_per_m": 3000.0},
        1,
        "A 3000 N s/m dashpot from the left side member's rear (sensor ARHBZ) to ground: outside the "
        "diagnosis's candidates.",
    ),
    ("sensor_polarity", "ARFMZ", {"gain": 1.0}, 1, "Sensor ARFMZ is mounted upside down (reads -1 times)."),
    ("sensor_swap", "ARFVZ/ARHBZ", {}, 1, "The cables of channels ARFVZ and ARHBZ are swapped."),
    ("sensor_axis", "ARFVZ>ARFVY", {}, 1, "Sensor ARFVZ is mounted turned: it measures the y axis."),
    ("sensor_dead", "ARVBZ", {}, 1, "Channel ARVBZ is dead (only the acquisition's noise)."),
    (
        "sensor_clipped",
        "ARFVZ",
        {"clip_level_m_per_s2": 2.0},
        1,
        "Channel ARFVZ saturates at 2 m/s^2 (its input range set too low).",
    ),
    ("sensor_delay", "ARHBZ", {"delay_s": 0.004}, 1, "Channel ARHBZ is recorded 4 ms late."),
)

for _name, _loc, _params, _variant, _text in _SINGLE:
    register_scenario(
        Scenario(
            name=_name, description=_text, variant=_variant, augmentations=(Augment(_name, _loc, _params),)
        )
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
    """Return a blind scenario: effect, location, parameter values (log-uniform in bounds), seed drawn.

    Parameters
    ----------
    index : int
        Scenario number (name ``blind-{index:02d}``; the draw is reproducible from it).
    effect : str, optional
        Force the effect ('none' for a scenario without one); default: drawn from
        :data:`BLIND_EFFECTS`.
    rng_seed : int, default 2026
        Seed of the draw, combined with ``index``; another value gives another set of blind
        scenarios.

    Returns
    -------
    Scenario
        The drawn scenario, named ``blind-{index:02d}``, with its drawn seed.

    Raises
    ------
    InputError
        If ``effect`` is neither 'none' nor one of :data:`BLIND_EFFECTS`.
    """
    from exudyn_study.physics.catalogue import entry

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


#: Model-1 places of point effects: the outer surface of every part of the chassis body a mass, an
#: absorber or a dashpot can be fixed to (the side members' channels, the front plate, the cross
#: members, the tank shells and brackets, the mudguard brackets). Left out: the rig pads (their faces
#: are the rig's), the bolts and the rubber pad (joint hardware) and the tank baffles (inside the
#: tanks). A place is ``'chassis@region:u'``, a surface node drawn uniformly over the region
#: (:func:`exudyn_study.physics.entries.surface_node`).
SURFACE_REGIONS = (
    "side_member_left_outer", "side_member_right_outer", "side_member_left_inner",
    "side_member_right_inner", "front_plate", "cross_member_1", "cross_member_2", "cross_member_3",
    "cross_member_4", "tank_left_shell", "tank_right_shell", "tank_left_brackets", "tank_right_brackets",
    "bracket_left_mount", "bracket_left_arm", "bracket_right_arm",
)
#: marks an effect whose place is drawn on :data:`SURFACE_REGIONS`
_SURFACE = ("surface",)
_CHANNELS = ("ARFVZ", "ARFMZ", "ARHBZ", "ARVBZ", "AVBFZ", "ATVBZ", "ATHBZ", "ASVZ", "ASHZ")

#: effects of :func:`wide_scenario`: entry -> (places, {parameter: (low, high)} drawn log-uniformly
#: (a parameter not listed keeps its default), kind). Kinds: 'structure' (a catalogue candidate
#: exists), 'sensor' (an acquisition fault), 'outside' (no candidate: the generic local element)
WIDE_EFFECTS = {
    "added_mass": (_SURFACE, {"mass_kg": (5.0, 30.0)}, "structure"),
    "tuned_mass_damper": (
        _SURFACE,
        {"mass_kg": (3.0, 12.0), "frequency_hz": (8.0, 45.0), "damping_ratio": (0.03, 0.15)},
        "structure",
    ),
    "drive_linkage_compliance": (
        (None,),
        {"stiffness_n_per_m": (8e6, 5e7), "damping_n_s_per_m": (1e3, 4e3), "mass_kg": (10.0, 40.0)},
        "structure",
    ),
    "rear_support_compliance": (("rear_left", "rear_right"), {"vertical_stiffness_n_per_m": (5e6, 3e7)},
                                "structure"),
    "sensor_gain": (_CHANNELS, {"gain": (1.1, 1.4)}, "sensor"),
    "sensor_polarity": (_CHANNELS, {"gain": (0.9, 1.1)}, "sensor"),
    "sensor_swap": (tuple(f"{a}/{b}" for a, b in zip(_CHANNELS, _CHANNELS[3:] + _CHANNELS[:3], strict=True)),
                    {}, "sensor"),
    "sensor_dead": (_CHANNELS, {}, "sensor"),
    "sensor_delay": (_CHANNELS, {"delay_s": (0.002, 0.008)}, "sensor"),
    "ground_spring_damper": (_SURFACE, {"damping_n_s_per_m": (1e3, 6e3)}, "outside"),
}
#: parameters of a wide effect fixed, not drawn (a dashpot to ground: no spring)
_WIDE_FIXED = {("ground_spring_damper", "stiffness_n_per_m"): 0.0}
#: share of :func:`wide_scenario` scenarios with two effects (a structural effect with a sensor fault,
#: or two at different places): exactly this share of any run of consecutive indices
WIDE_TWO_EFFECT_SHARE = 0.4
#: seeds of the draws used while developing, and of the held-back range reported separately
DEVELOPMENT_SEED = 2026
HELD_BACK_SEED = 8128


def _wide_effect(rng, name: str, taken: set) -> Augment:
    from exudyn_study.physics.catalogue import entry

    places, ranges, _ = WIDE_EFFECTS[name]
    if places is _SURFACE:
        place = f"chassis@{SURFACE_REGIONS[int(rng.integers(len(SURFACE_REGIONS)))]}:{rng.uniform():.6f}"
    else:
        free = [p for p in places if p is None or not (set(str(p).replace(">", "/").split("/")) & taken)]
        place = free[int(rng.integers(len(free)))] if free else places[int(rng.integers(len(places)))]
    e = entry(name)
    params = {}
    for p in e.parameters:
        if (name, p.name) in _WIDE_FIXED:
            params[p.name] = _WIDE_FIXED[(name, p.name)]
        elif p.name in ranges:
            lo, hi = ranges[p.name]
            params[p.name] = p.check(float(math.exp(rng.uniform(math.log(lo), math.log(hi)))), name)
    return Augment(name, place, params)


def wide_scenario(index: int, effect: str | None = None, rng_seed: int = DEVELOPMENT_SEED) -> Scenario:
    """Return a blind scenario of the wider pool: one or two effects of :data:`WIDE_EFFECTS` on Model 1.

    Parameters
    ----------
    index : int
        Scenario number (name ``wide-{index:03d}``; the draw is reproducible from it and ``rng_seed``).
    effect : str, optional
        ``'none'`` for a scenario without an effect; default drawn.
    rng_seed : int
        :data:`DEVELOPMENT_SEED` while developing, :data:`HELD_BACK_SEED` for the held-back range.

    Returns
    -------
    Scenario
    """
    rng = np.random.default_rng([rng_seed, int(index), 7])
    seed = int(rng.integers(1, 10_000))
    name = f"wide-{index:03d}"
    if effect == "none":
        return Scenario(name=name, description="blind scenario", variant=1, seed=seed).with_seed(seed)
    if effect is not None and effect not in WIDE_EFFECTS:
        known = sorted(WIDE_EFFECTS)
        raise InputError(f"wide effect {effect!r} is unknown; expected 'none' or one of {known}")
    names = sorted(WIDE_EFFECTS)
    first = effect or names[int(rng.integers(len(names)))]
    taken: set = set()
    augs = [_wide_effect(rng, first, taken)]
    taken |= set(str(augs[0].location).replace(">", "/").split("/"))
    # two effects in exactly WIDE_TWO_EFFECT_SHARE of any run of consecutive indices, spread evenly
    two = math.floor((index + 1) * WIDE_TWO_EFFECT_SHARE) > math.floor(index * WIDE_TWO_EFFECT_SHARE)
    if effect is None and two:
        # a second effect of another kind (two sensor faults at once are left out: one channel's
        # residual would not tell them apart)
        both_sensor = first.startswith("sensor_")
        others = [n for n in names if n != first and not (both_sensor and n.startswith("sensor_"))]
        augs.append(_wide_effect(rng, others[int(rng.integers(len(others)))], taken))
    return Scenario(
        name=name, description="blind scenario", variant=1, seed=seed, augmentations=tuple(augs)
    ).with_seed(seed)
