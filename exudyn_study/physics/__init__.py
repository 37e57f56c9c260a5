"""Physics the nominal models leave out, as a catalogue of augmentations (DESIGN: physics hypotheses).

Each entry is a :class:`PhysicsEntry`: a name, a docstring saying which physics it
represents and what signature it leaves in the recordings, :class:`Parameter` s with units
and bounds, and ``apply(model, location, **params)`` that adds its Exudyn items to a
not-yet-assembled :class:`~exudyn_study.model.Model`. The virtual test rig (truth models)
and the diagnosis (hypotheses) use the same catalogue; users can :func:`register` their own.

>>> from exudyn_study.physics import entry, CATALOGUE
>>> sorted(CATALOGUE)  # doctest: +NORMALIZE_WHITESPACE
['added_mass', 'bushing_stiffening', 'bushing_stiffness', 'drive_linkage_compliance',
 'ground_spring_damper', 'joint_friction', 'joint_stiffness', 'modal_damping', 'rear_support_compliance',
 'sensor_axis', 'sensor_clipped', 'sensor_dead', 'sensor_delay', 'sensor_gain', 'sensor_polarity',
 'sensor_swap', 'sloshing', 'tank_wall_mode', 'tuned_mass_damper']
>>> entry("added_mass").parameter("mass_kg").unit
'kg'
"""

from exudyn_study.physics.catalogue import (
    CATALOGUE,
    Applied,
    Augmentation,
    Parameter,
    PhysicsEntry,
    entry,
    register,
    unregister,
)
from exudyn_study.physics.entries import (
    ADDED_MASS,
    DRIVE_LINKAGE_COMPLIANCE,
    GROUND_SPRING_DAMPER,
    REAR_SUPPORT_COMPLIANCE,
    TUNED_MASS_DAMPER,
)
from exudyn_study.physics.entries_more import (
    BUSHING_STIFFENING,
    JOINT_FRICTION,
    JOINT_STIFFNESS,
    MODAL_DAMPING,
    SENSOR_GAIN,
    SLOSHING,
)
from exudyn_study.physics.entries_structure import BUSHING_STIFFNESS
from exudyn_study.physics.sensor_faults import (
    SENSOR_AXIS,
    SENSOR_CLIPPED,
    SENSOR_DEAD,
    SENSOR_DELAY,
    SENSOR_POLARITY,
    SENSOR_SWAP,
    SensorFault,
)

__all__ = [
    "CATALOGUE",
    "Applied",
    "Augmentation",
    "Parameter",
    "PhysicsEntry",
    "entry",
    "register",
    "unregister",
    "ADDED_MASS",
    "DRIVE_LINKAGE_COMPLIANCE",
    "REAR_SUPPORT_COMPLIANCE",
    "TUNED_MASS_DAMPER",
    "GROUND_SPRING_DAMPER",
    "JOINT_STIFFNESS",
    "JOINT_FRICTION",
    "BUSHING_STIFFENING",
    "SLOSHING",
    "MODAL_DAMPING",
    "SENSOR_GAIN",
    "BUSHING_STIFFNESS",
    "SENSOR_POLARITY",
    "SENSOR_SWAP",
    "SENSOR_AXIS",
    "SENSOR_DEAD",
    "SENSOR_CLIPPED",
    "SENSOR_DELAY",
    "SensorFault",
]
