"""The left mudguard bracket's rubber pad: its faces, quadrants and linear spring matrix.

The bushing entries (:data:`~exudyn_study.physics.BUSHING_STIFFNESS`,
:data:`~exudyn_study.physics.BUSHING_STIFFENING`) and the diagnosis's bushing candidates
act on the pad through these functions.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.physics.mesh import _spread

# --------------------------------------------------------------------------------------- bushing_stiffening
RUBBER_REGION = "bracket_left_rubber"


def rubber_body(model) -> str | None:
    """Return the name of the body that holds the rubber pad's region (None without one).

    Parameters
    ----------
    model : object
        Rig model with a ``bodies`` mapping (name -> body handle).

    Returns
    -------
    str or None
        Name of the body whose mesh has the rubber region, or None.
    """
    for name, handle in model.bodies.items():
        if RUBBER_REGION in handle.body.region_nodes:
            return name
    return None


def rubber_pad_location_check(entry_name: str):
    """Return the ``check_location`` of an entry acting on the left bracket's rubber pad (the only one).

    Parameters
    ----------
    entry_name : str
        Name of the entry, used in the error messages.

    Returns
    -------
    callable
        ``check(model, location)`` that returns ``'bracket_left'`` for ``location`` None or
        ``'bracket_left'``, and raises InputError for any other location or a model without the
        rubber region.
    """

    def check(model, location):
        if location not in (None, "bracket_left"):
            raise InputError(f"{entry_name}: location {location!r}; expected None or 'bracket_left' "
                             "(the left mudguard bracket carries the only rubber bushing)")
        if rubber_body(model) is None:
            raise InputError(f"{entry_name}: no body of this model has the rubber region "
                             f"{RUBBER_REGION!r}; bodies {sorted(model.bodies)}")
        return "bracket_left"

    return check


def _rubber_face_nodes(body) -> tuple[np.ndarray, np.ndarray, int]:
    """All nodes of the rubber pad's frame-side and bracket-side faces, and the pad normal's axis (``y``).

    The faces of :func:`~exudyn_study.physics.entries_structure.rubber_pad` (one definition of the
    pad's geometry for its linear spring and its hardening).
    """
    from exudyn_study.physics.rubber import rubber_pad

    pad = rubber_pad(body, RUBBER_REGION)
    return pad["inner"], pad["outer"], pad["normal"]


def _rubber_faces(body, count: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Well-spread nodes of the rubber pad's frame-side and bracket-side faces (pad normal: ``y``)."""
    inner, outer, _ = _rubber_face_nodes(body)
    pick = [f[_spread(np.asarray(body.node_positions_m)[f], count)] for f in (inner, outer)]
    return pick[0], pick[1]


def _pad_quadrants(body, face: np.ndarray, normal: int, count: int) -> list[np.ndarray]:
    """Split a pad face's nodes into its four quadrants (about the face centre, in the face plane).

    ``normal``: the axis of the pad's normal. Returns ``count`` well-spread nodes of each
    quadrant, in the order (-,-), (-,+), (+,-), (+,+) of the two in-plane axes.
    """
    x = np.asarray(body.node_positions_m)[face]
    a, b = [k for k in range(3) if k != normal]
    centre = x.mean(axis=0)
    out = []
    for sa in (False, True):
        for sb in (False, True):
            sel = face[((x[:, a] > centre[a]) == sa) & ((x[:, b] > centre[b]) == sb)]
            if sel.size == 0:
                raise InputError(f"bushing_stiffening: the rubber pad's face has no nodes in one quadrant "
                                 f"({face.size} face nodes); the pad mesh is too coarse for the compression "
                                 "term")
            out.append(sel[_spread(np.asarray(body.node_positions_m)[sel], count)])
    return out


def rubber_pad(body, region: str = RUBBER_REGION) -> dict:
    """Geometry of a flat bonded rubber pad (a mesh region of a reduced body).

    Parameters
    ----------
    body : exudyn_study.bodies.reduction.ReducedBody
    region : str
        Mesh region of the pad (its thinnest extent is the pad's thickness).

    Returns
    -------
    dict
        ``normal`` (axis 0/1/2 of the thickness), ``thickness_m``, ``extent_m`` (ndarray (3,),
        the pad's bounding box, m), ``area_m2`` (bonded area, the in-plane extents' product),
        ``centre_m`` (ndarray (3,), body coordinates), ``inner`` and ``outer`` (mesh nodes of the
        face nearer to and farther from the body's ``y = 0`` plane along the normal).
    """
    nodes = np.asarray(body.region_nodes[region], dtype=int)
    x = np.asarray(body.node_positions_m)[nodes]
    extent = np.ptp(x, axis=0)
    normal = int(np.argmin(extent))
    depth = np.abs(x[:, normal])
    tol = 1e-3 * float(extent.max()) + 1e-9
    inner = nodes[depth <= depth.min() + tol]
    outer = nodes[depth >= depth.max() - tol]
    plane = [a for a in range(3) if a != normal]
    return {"normal": normal, "thickness_m": float(extent[normal]), "extent_m": extent,
            "area_m2": float(extent[plane[0]] * extent[plane[1]]),
            "centre_m": 0.5 * (x.min(axis=0) + x.max(axis=0)), "inner": inner, "outer": outer}


def pad_spring_matrix(pad: dict, shear_modulus_pa: float, compression_modulus_pa: float,
                      rocking_factors=(1.0, 1.0, 1.0), torsion_modulus_change_pa: float = 0.0) -> np.ndarray:
    """6 x 6 stiffness (N/m, N m/rad; translations then rotations about x, y, z) of a bonded pad.

    A thin block of thickness ``t`` and in-plane sides ``a``, ``b`` bonded between two rigid
    plates (Gent 2012, Ch. 9): shear ``G A / t`` along both in-plane axes, compression
    ``E_c A / t`` along the normal, torsion about the normal ``G J / t`` with
    ``J = A (a^2 + b^2) / 12`` and rocking about an in-plane axis ``E_c I / t`` with ``I`` the
    area's second moment about that axis (``A s^2 / 12``, ``s`` the side across it), times
    ``rocking_factors[axis]`` (the rocking modulus over the compression modulus about global
    x, y, z; the normal's entry is unused). The torsion uses ``shear_modulus_pa +
    torsion_modulus_change_pa`` (default: the shear modulus).

    Parameters
    ----------
    pad : dict
        Pad geometry: ``normal`` (axis index 0, 1 or 2 of the normal), ``thickness_m`` (m),
        ``area_m2`` (m^2) and ``extent_m`` (side lengths along x, y, z in m).
    shear_modulus_pa : float
        Shear modulus ``G`` of the rubber in Pa.
    compression_modulus_pa : float
        Effective compression modulus ``E_c`` of the bonded block in Pa.
    rocking_factors : sequence of float, default (1.0, 1.0, 1.0)
        Rocking modulus over compression modulus about global x, y, z (dimensionless).
    torsion_modulus_change_pa : float, default 0.0
        Change in Pa added to the shear modulus for the torsion about the normal.

    Returns
    -------
    numpy.ndarray
        Diagonal stiffness matrix of shape ``(6, 6)``.
    """
    n, t, area = pad["normal"], pad["thickness_m"], pad["area_m2"]
    ext = np.asarray(pad["extent_m"], dtype=float)
    k = np.zeros(6)
    for axis in range(3):
        if axis == n:
            k[axis] = compression_modulus_pa * area / t
            torsion = shear_modulus_pa + torsion_modulus_change_pa
            k[3 + axis] = torsion * area * (np.sum(ext**2) - ext[n] ** 2) / 12.0 / t
        else:
            across = 3 - n - axis  # the in-plane side perpendicular to this rocking axis
            k[axis] = shear_modulus_pa * area / t
            k[3 + axis] = rocking_factors[axis] * compression_modulus_pa * area * ext[across] ** 2 / 12.0 / t
    return np.diag(k)
