"""The rig, the sensors and the thesis's model variants 1-3 in Exudyn.

>>> from exudyn_study.model import build_model            # doctest: +SKIP
>>> model = build_model(1, damping="adams-default")       # doctest: +SKIP
>>> model.assemble()                                       # doctest: +SKIP
"""

from exudyn_study.model.linearisation import body_displacement_map, linearise, system_modes
from exudyn_study.model.rig import Drive, RigHandles, RigParameters
from exudyn_study.model.variants import (
    FORMULATIONS,
    VARIANTS,
    BushingParameters,
    InterfaceHandle,
    Model,
    SensorAttachment,
    build_model,
    build_model_from_bodies,
    model_bodies,
)

__all__ = [
    "linearise",
    "system_modes",
    "body_displacement_map",
    "Drive",
    "RigHandles",
    "RigParameters",
    "FORMULATIONS",
    "VARIANTS",
    "BushingParameters",
    "InterfaceHandle",
    "Model",
    "SensorAttachment",
    "build_model",
    "build_model_from_bodies",
    "model_bodies",
]
