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
    from exudyn_study.bodies import _to_arrays
    from exudyn_study.fe.assembly import PartMaterial, assemble, interface_from_boundary
    from exudyn_study.flexbody import ffrf_data
    from exudyn_study.reduction import ReductionSettings, craig_bampton

    mesh = mini_frame_geometry().GenerateMesh(maxh=0.09)
    fe = assemble(mesh, [PartMaterial("frame_steel", "steel", 0.0, "frame")])
    names = ("front_left_drive", "rear_left", "front_right_drive", "rear_right", "front_strut")
    itfs = [interface_from_boundary(fe, n, n) for n in names]
    body = craig_bampton(fe, itfs, ReductionSettings(max_frequency_hz=300.0, solver="scipy"), name="chassis")
    return _to_arrays(body, ffrf_data(body))


def mini_bodies():
    """{'chassis': mini frame, 'rear_foundation': the real foundation} as FlexibleBodyData."""
    from exudyn_study import cache
    from exudyn_study.bodies import BodySpec, FlexibleBodyData, _from_arrays, flexible_body

    RIG_TEST_CACHE.mkdir(parents=True, exist_ok=True)
    arrays, hit = cache.cached({"test": "mini_frame", "version": MINI_FRAME_VERSION}, _build_mini_frame,
                               RIG_TEST_CACHE)
    body, ffrf = _from_arrays(arrays)
    frame = FlexibleBodyData(body=body, ffrf=ffrf, timings_s={}, from_cache=hit)
    foundation = flexible_body(BodySpec(kind="rear_foundation"), cache_dir=os.fspath(RIG_TEST_CACHE))
    return {"chassis": frame, "rear_foundation": foundation}


#: frame sensors (the mini frame has no tanks or brackets)
FRAME_SENSORS = ("ARFMZ", "ARFVZ", "ARFHZ", "AVBFZ", "ARVBZ", "ARHBZ", "ARFVY", "ARFHX")
