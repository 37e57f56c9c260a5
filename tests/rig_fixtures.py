"""Small flexible bodies for the rig tests: a mini chassis frame and the rear foundation.

The real coarse chassis takes 1-2 min to reduce; the rig, modal and simulation machinery
is tested on a mini frame (two box side members, two cross members, a front plate, the
five rig interface pads at the real positions) reduced through the same pipeline
(netgen -> ``fe.assembly.assemble`` -> ``reduction.craig_bampton`` -> ``flexbody.ffrf_data``),
and on the real rear foundation (a few seconds). Both are cached once under the system
temp directory, so repeated local runs start in a second.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

RIG_TEST_CACHE = Path(tempfile.gettempdir()) / "exudyn_study_rig_test_cache"
MINI_FRAME_VERSION = 1


def mini_frame_geometry():
    import netgen.occ as occ

    solids = []
    for s in (-1.0, 1.0):
        y0, y1 = sorted((s * 0.41, s * 0.44))
        solids.append(occ.Box(occ.Pnt(-0.52, y0, 0.03), occ.Pnt(2.55, y1, 0.30)))
        py0, py1 = sorted((s * 0.44, s * 0.455))
        pad = occ.Box(occ.Pnt(-0.375, py0, 0.11), occ.Pnt(-0.255, py1, 0.23))
        side = "left" if s < 0 else "right"
        (pad.faces.Max(occ.Y) if s > 0 else pad.faces.Min(occ.Y)).name = f"front_{side}_drive"
        solids.append(pad)
        ry0, ry1 = sorted((s * 0.44, s * 0.535))
        blk = occ.Box(occ.Pnt(2.42, ry0, 0.12), occ.Pnt(2.54, ry1, 0.26))
        (blk.faces.Max(occ.Y) if s > 0 else blk.faces.Min(occ.Y)).name = f"rear_{side}"
        solids.append(blk)
    solids.append(occ.Box(occ.Pnt(-0.535, -0.44, 0.03), occ.Pnt(-0.52, 0.44, 0.30)))
    sp = occ.Box(occ.Pnt(-0.545, -0.075, 0.115), occ.Pnt(-0.535, 0.075, 0.215))
    sp.faces.Min(occ.X).name = "front_strut"
    solids.append(sp)
    for x in (0.10, 1.50):
        solids.append(occ.Box(occ.Pnt(x, -0.41, 0.08), occ.Pnt(x + 0.06, 0.41, 0.25)))
    for sol in solids:
        sol.mat("frame_steel")
    return occ.OCCGeometry(occ.Glue(solids))


def _build_mini_frame():
    from exudyn_study.bodies.fe.assembly import PartMaterial, assemble, interface_from_boundary
    from exudyn_study.bodies.ffrf import ffrf_data
    from exudyn_study.bodies.reduction import ReductionSettings, craig_bampton
    from exudyn_study.bodies.spec import _to_arrays

    mesh = mini_frame_geometry().GenerateMesh(maxh=0.09)
    fe = assemble(mesh, [PartMaterial("frame_steel", "steel", 0.0, "frame")])
    names = ("front_left_drive", "rear_left", "front_right_drive", "rear_right", "front_strut")
    itfs = [interface_from_boundary(fe, n, n) for n in names]
    body = craig_bampton(fe, itfs, ReductionSettings(max_frequency_hz=300.0, solver="scipy"), name="chassis")
    return _to_arrays(body, ffrf_data(body))


def mini_bodies():
    """{'chassis': mini frame, 'rear_foundation': the real foundation} as FlexibleBodyData."""
    from exudyn_study.bodies import BodySpec, FlexibleBodyData, flexible_body
    from exudyn_study.bodies.spec import _from_arrays, _source_digest
    from exudyn_study.infra import cache

    RIG_TEST_CACHE.mkdir(parents=True, exist_ok=True)
    # keyed by the source of the body pipeline too: a change in fe/ or reduction rebuilds the fixture
    key = {"test": "mini_frame", "version": MINI_FRAME_VERSION, "source": _source_digest()}
    arrays, hit = cache.cached(key, _build_mini_frame, RIG_TEST_CACHE)
    body, ffrf = _from_arrays(arrays)
    frame = FlexibleBodyData(body=body, ffrf=ffrf, timings_s={}, from_cache=hit)
    foundation = flexible_body(BodySpec(kind="rear_foundation"), cache_dir=os.fspath(RIG_TEST_CACHE))
    return {"chassis": frame, "rear_foundation": foundation}


#: frame sensors (the mini frame has no tanks or brackets)
FRAME_SENSORS = ("ARFMZ", "ARFVZ", "ARFHZ", "AVBFZ", "ARVBZ", "ARHBZ", "ARFVY", "ARFHX")


# --------------------------------------------------------------------------------------- mini Model 3
#: bump when the mini Model-3 geometry or reduction changes (cache key)
MINI_MODEL3_VERSION = 1
#: (interface, side sign, x range, z range) of the component interfaces: pads on the side
#: members' outer webs (|y| = 0.44 .. 0.455), the component's plate on the pad's outer face
MINI_MODEL3_INTERFACES = (
    ("tank_left_front", -1.0, (0.30, 0.40), (0.12, 0.24)),
    ("tank_left_rear", -1.0, (0.85, 0.95), (0.12, 0.24)),
    ("tank_right_front", 1.0, (0.30, 0.40), (0.12, 0.24)),
    ("tank_right_rear", 1.0, (0.85, 0.95), (0.12, 0.24)),
    ("bracket_left", -1.0, (-0.20, -0.08), (0.12, 0.24)),
    ("bracket_right", 1.0, (-0.20, -0.08), (0.12, 0.24)),
)
_PAD_Y = (0.44, 0.455)


def _ybox(occ, x, s, y, z):
    y0, y1 = sorted((s * y[0], s * y[1]))
    return occ.Box(occ.Pnt(x[0], y0, z[0]), occ.Pnt(x[1], y1, z[1]))


def _outer_face(occ, solid, s):
    return solid.faces.Max(occ.Y) if s > 0 else solid.faces.Min(occ.Y)


def _inner_face(occ, solid, s):
    return solid.faces.Min(occ.Y) if s > 0 else solid.faces.Max(occ.Y)


def mini_model3_geometry(component: str):
    """OCC geometry of one mini Model-3 component.

    'frame': the mini frame plus six interface pads; 'tank_left'/'tank_right': a solid
    steel box (~270 kg, x 0.25..1.05, |y| 0.56..0.80, z 0.10..0.28) on two bracket plates
    with ribs; 'bracket_left'/'bracket_right': a plate and a 60 x 40 mm cantilever arm to
    |y| = 1.16; the left one through a rubber pad (region 'bracket_left_rubber', |y| 0.47..0.49)
    and a base plate, as the real left mudguard bracket.
    """
    import netgen.occ as occ

    itfs = [i for i in MINI_MODEL3_INTERFACES if component == "frame" or i[0].startswith(component)]
    if component == "frame":
        solids = [mini_frame_geometry().shape]
        for name, s, x, z in itfs:
            pad = _ybox(occ, x, s, _PAD_Y, z)
            _outer_face(occ, pad, s).name = name
            pad.mat("frame_steel")
            solids.append(pad)
        return occ.OCCGeometry(occ.Glue(solids))
    s = -1.0 if component.endswith("left") else 1.0
    solids = []
    if component.startswith("tank"):
        for name, _, x, z in itfs:
            plate = _ybox(occ, x, s, (0.455, 0.47), z)
            _inner_face(occ, plate, s).name = name
            xm = 0.5 * (x[0] + x[1])
            rib = _ybox(occ, (xm - 0.02, xm + 0.02), s, (0.47, 0.56), z)
            for p in (plate, rib):
                p.mat(f"{component}_brackets")
                solids.append(p)
        box = _ybox(occ, (0.25, 1.05), s, (0.56, 0.80), (0.10, 0.28))
        box.mat(f"{component}_shell")
        solids.append(box)
    else:
        (name, _, x, z), = itfs
        plate = _ybox(occ, x, s, (0.455, 0.47), z)
        _inner_face(occ, plate, s).name = name
        plate.mat(f"{component}_mount")
        solids.append(plate)
        y_arm = 0.47
        if s < 0:
            rub = _ybox(occ, (-0.19, -0.09), s, (0.47, 0.49), (0.13, 0.23))
            rub.mat(f"{component}_rubber")
            base = _ybox(occ, (-0.19, -0.09), s, (0.49, 0.50), (0.13, 0.23))
            base.mat(f"{component}_arm")
            solids += [rub, base]
            y_arm = 0.50
        arm = _ybox(occ, (-0.17, -0.11), s, (y_arm, 1.16), (0.13, 0.17))
        arm.mat(f"{component}_arm")
        solids.append(arm)
    return occ.OCCGeometry(occ.Glue(solids))


def _build_mini_model3_body(component: str):
    from exudyn_study.bodies.fe.assembly import PartMaterial, assemble, interface_from_boundary
    from exudyn_study.bodies.ffrf import ffrf_data
    from exudyn_study.bodies.reduction import ReductionSettings, craig_bampton
    from exudyn_study.bodies.spec import _to_arrays

    maxh = 0.09 if component in ("frame", "tank_left", "tank_right") else 0.04
    mesh = mini_model3_geometry(component).GenerateMesh(maxh=maxh)
    if component == "frame":
        parts = [PartMaterial("frame_steel", "steel", 0.0, "frame")]
        names = ("front_left_drive", "rear_left", "front_right_drive", "rear_right", "front_strut") + tuple(
            i[0] for i in MINI_MODEL3_INTERFACES)
    else:
        if component.startswith("tank"):
            regions = [f"{component}_brackets", f"{component}_shell"]
        else:
            regions = [f"{component}_mount", f"{component}_arm"]
            if component == "bracket_left":
                regions.append(f"{component}_rubber")
        parts = [PartMaterial(r, "rubber" if r.endswith("rubber") else "steel", 0.0, component)
                 for r in regions]
        names = tuple(i[0] for i in MINI_MODEL3_INTERFACES if i[0].startswith(component))
    fe = assemble(mesh, parts)
    itfs = [interface_from_boundary(fe, n, n) for n in names]
    body = craig_bampton(fe, itfs, ReductionSettings(max_frequency_hz=300.0, solver="scipy"), name=component)
    return _to_arrays(body, ffrf_data(body))


def mini_model3_bodies():
    """Mini Model 3: {'frame', 'tank_left', 'tank_right', 'bracket_left', 'bracket_right',
    'rear_foundation'} as FlexibleBodyData, each reduced once and cached in the temp directory."""
    from exudyn_study.bodies import FlexibleBodyData
    from exudyn_study.bodies.spec import _from_arrays, _source_digest
    from exudyn_study.infra import cache

    RIG_TEST_CACHE.mkdir(parents=True, exist_ok=True)
    out = {}
    for comp in ("frame", "tank_left", "tank_right", "bracket_left", "bracket_right"):
        key = {"test": "mini_model3", "component": comp, "version": MINI_MODEL3_VERSION,
               "frame_version": MINI_FRAME_VERSION, "source": _source_digest()}
        arrays, hit = cache.cached(key, lambda c=comp: _build_mini_model3_body(c), RIG_TEST_CACHE)
        body, ffrf = _from_arrays(arrays)
        out[comp] = FlexibleBodyData(body=body, ffrf=ffrf, timings_s={}, from_cache=hit)
    out["rear_foundation"] = mini_bodies()["rear_foundation"]
    return out


#: sensors of the mini Model 3: frame sensors plus those on the tanks and brackets
MODEL3_SENSORS = FRAME_SENSORS + ("ATVFX", "ATVBX", "ATVBZ", "ATHFX", "ATHBZ", "ASVX", "ASVZ", "ASHZ")
