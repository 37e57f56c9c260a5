"""Physics the nominal models leave out, as a catalogue of augmentations (DESIGN: physics hypotheses).

Each entry is a :class:`PhysicsEntry`: a name, a docstring saying which physics it
represents and what signature it leaves in the recordings, :class:`Parameter` s with units
and bounds, and ``apply(model, location, **params)`` that adds its Exudyn items to a
not-yet-assembled :class:`~exudyn_study.model.Model`. The virtual test rig (truth models)
and the diagnosis (hypotheses) use the same catalogue; users can :func:`register` their own.

>>> from exudyn_study.physics import entry, CATALOGUE
>>> sorted(CATALOGUE)
['added_mass', 'drive_linkage_compliance']
>>> entry("added_mass").parameter("mass_kg").unit
'kg'
"""

from .catalogue import (
    CATALOGUE,
    Applied,
    Augmentation,
    Parameter,
    PhysicsEntry,
    entry,
    register,
    unregister,
)
from .entries import ADDED_MASS, DRIVE_LINKAGE_COMPLIANCE

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
]
