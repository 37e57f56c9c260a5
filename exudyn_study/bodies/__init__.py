"""Flexible bodies: FE model, reduction, damping and the Exudyn bodies built from them.

FE meshes and matrices (``fe``, the only package that imports ngsolve),
Craig-Bampton reduction (``reduction``), modal damping functions (``damping``), the Exudyn
FFRF body (``ffrf``) and the constant-matrix body (``linear_body``), and the cached body
build (``spec``: :class:`BodySpec` -> :func:`flexible_body`).
"""

from exudyn_study.bodies.spec import (
    BODY_KINDS,
    BodySpec,
    FlexibleBodyData,
    fe_model_and_interfaces,
    flexible_body,
    parse_mesh,
)

__all__ = [
    "BodySpec", "FlexibleBodyData", "flexible_body", "fe_model_and_interfaces", "BODY_KINDS", "parse_mesh",
]
