"""Catalogue entries for structural properties the nominal bodies get wrong.

- ``bushing_stiffness``: the left mudguard bracket's rubber pad is stiffer (or damps more)
  than the nominal body's rubber: a linear spring-damper across the pad, sized from the
  pad's bonded area and thickness.

References
----------
Gent, A. N. (2012). Engineering with rubber, 3rd ed., Chapter 9 (shear and compression of
bonded rubber blocks). Carl Hanser.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.bodies.materials import MATERIALS
from exudyn_study.errors import InputError
from exudyn_study.physics.catalogue import Parameter, PhysicsEntry, register
from exudyn_study.physics.mesh import exudyn_mesh_nodes
from exudyn_study.physics.rubber import (
    pad_spring_matrix,
    rubber_body,
    rubber_pad,
    rubber_pad_location_check,
)

__all__ = ["BUSHING_STIFFNESS", "rubber_pad", "pad_spring_matrix"]


def _face_marker(model, body_name: str, nodes, centre_m) -> int:
    """Rigid marker averaging ``nodes`` (equal weights), shifted to ``centre_m`` (body coordinates)."""
    import exudyn.itemInterface as eii

    handle = model.bodies[body_name]
    nodes = np.asarray(nodes, dtype=int)
    local = exudyn_mesh_nodes(model, body_name, nodes)
    mean = np.asarray(handle.body.node_positions_m)[nodes].mean(axis=0)
    offset = np.asarray(centre_m, dtype=float) - mean
    return int(model.mbs.AddMarker(eii.MarkerSuperElementRigid(
        bodyNumber=handle.object_number, meshNodeNumbers=[int(i) for i in local],
        weightingFactors=[1.0 / nodes.size] * nodes.size, offset=[float(v) for v in offset],
        visualization=eii.VMarkerSuperElementRigid(show=False))))


def _add_bushing_stiffness(model, location, params: dict) -> dict:
    import exudyn.itemInterface as eii

    body_name = rubber_body(model)
    pad = rubber_pad(model.bodies[body_name].body)
    m_frame = _face_marker(model, body_name, pad["inner"], pad["centre_m"])
    m_bracket = _face_marker(model, body_name, pad["outer"], pad["centre_m"])
    g_rubber = MATERIALS["rubber"].lame_parameters[0]
    g_torsion = g_rubber + params["shear_modulus_increase_pa"] + params["torsion_modulus_change_pa"]
    if g_torsion <= 0.01 * g_rubber:
        change = params["torsion_modulus_change_pa"]
        raise InputError(f"bushing_stiffness: torsion_modulus_change_pa = {change:g} Pa leaves the pad a "
                         f"torsion modulus of {g_torsion:g} Pa; expected above "
                         f"{0.01 * g_rubber:g} Pa (1 % of the nominal rubber's {g_rubber:g} Pa)")
    k = pad_spring_matrix(pad, params["shear_modulus_increase_pa"], params["compression_modulus_increase_pa"],
                          (params["rocking_factor_about_x"], 1.0, params["rocking_factor_about_z"]),
                          params["torsion_modulus_change_pa"])
    d = params["damping_time_s"] * np.maximum(k, 0.0)  # a softer torsion takes no damping off the rubber
    spring = model.mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
        name="bushing_stiffness:bracket_left", markerNumbers=[m_frame, m_bracket], stiffness=k.tolist(),
        damping=d.tolist(), visualization=eii.VObjectConnectorRigidBodySpringDamper(show=False)))
    return {"frame_side_marker": m_frame, "bracket_side_marker": m_bracket, "spring": int(spring)}


BUSHING_STIFFNESS = register(PhysicsEntry(
    name="bushing_stiffness",
    doc="""The left mudguard bracket's rubber pad is stiffer and more damped than the nominal rubber.

Physics: the nominal bodies carry the pad as linear elastic rubber with a handbook modulus
(``materials.MATERIALS['rubber']``: E = 5 MPa, nu = 0.47, shear modulus G = 1.7 MPa); a
harder compound (G of filled rubbers spans about 0.3-3 MPa) and the near-incompressibility
of a thin bonded pad (its compression modulus ``E_c`` grows with the square of the shape
factor, Gent 2012) make the real pad stiffer. The increase acts in parallel with the pad: a
6-DOF spring-damper between the pad's two bonded faces (rigid markers averaging all mesh
nodes of each face of the region ``'bracket_left_rubber'``, both at the pad's centre) with
the stiffness of a bonded block (:func:`pad_spring_matrix`): shear
``shear_modulus_increase_pa * A / t`` along the two in-plane axes, compression
``compression_modulus_increase_pa * A / t`` along the normal, torsion and rocking from the
bonded area's polar and axial second moments. The rocking stiffness about x and about z
is the bonded-block value times ``rocking_factor_about_x`` / ``rocking_factor_about_z``
(default 1): a block tilted about an axis bulges less than one compressed evenly, so its
apparent modulus in rocking is not its compression modulus, and it differs between the long
(0.20 m along x) and the short (0.08 m along z) side (Gent 2012, Ch. 9: the shape-factor
term of the tilting modulus is a third of the compression one's for a long strip); the
pad's rocking about x carries the bracket's vertical (z) mode, about z its x mode. The
factors are unused for the pad's normal (y, torsion). The torsion about the normal (the
bracket turning in the pad's plane, about y) takes the shear increase plus
``torsion_modulus_change_pa`` (default 0), which may be negative down to a total torsion
modulus of 1 % of the nominal rubber's: torsion strains the pad's rim most, and a pad
clamped rather than bonded at its rim, or softer there (cure, ageing), is softer in torsion
than the bonded block while its shear and compression are set by the whole area; the
negative part is a spring in parallel with the body's own rubber, which stays positive in
total (it gets no damper: the rubber's own loss is the body's modal damping). The damping is
stiffness-proportional,
``damping_time_s * K`` (the rubber's loss: a mode carried by the pad gets
``zeta ~ damping_time_s * omega / 2`` of that spring's share of its strain energy).

Signature: the left bracket's modes (``ASV*`` sensors) rise in frequency, by
``omega^2 -> omega^2 + phi^T K_pad phi`` to first order (phi mass-normalised); modes without
relative motion across the pad (the other bodies' modes) keep their frequencies; with
``damping_time_s > 0`` the left bracket's modes are more damped, more so at higher
frequency. The response is level-independent (linear).
""",
    parameters=(
        Parameter("shear_modulus_increase_pa", "Pa", 0.0, 1e7, 1e6,
                  "added shear modulus of the pad (in-plane shear and torsion)"),
        Parameter("compression_modulus_increase_pa", "Pa", 0.0, 1e9, 0.0,
                  "added compression modulus of the pad (normal and rocking)"),
        Parameter("damping_time_s", "s", 0.0, 1e-2, 0.0, "stiffness-proportional damping time of the spring"),
        # up to 1e4: an added spring whose compression increase is small may still add rocking
        Parameter("rocking_factor_about_x", "1", 0.0, 1e4, 1.0,
                  "rocking modulus / compression modulus of the added spring about x"),
        Parameter("rocking_factor_about_z", "1", 0.0, 1e4, 1.0,
                  "rocking modulus / compression modulus of the added spring about z"),
        Parameter("torsion_modulus_change_pa", "Pa", -1e7, 1e7, 0.0,
                  "torsion modulus of the added spring minus its shear modulus (negative: softer)"),
    ),
    add_items=_add_bushing_stiffness,
    locations="None or 'bracket_left' (the left mudguard bracket's rubber bushing)",
    check_location=rubber_pad_location_check("bushing_stiffness"),
))
