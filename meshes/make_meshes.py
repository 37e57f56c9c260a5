"""Build the committed meshes of the chassis assembly and its Model-3 components.

Writes Netgen ``.vol.gz`` files (first-order tetrahedra; the FE code makes them
second order) and ``manifest.json`` (design, mesh size, counts, SHA-256 of each
file) into this directory, and prints element/node counts and times.

Usage::

    python meshes/make_meshes.py [--size coarse|production] [--out DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

from exudyn_study.bodies.fe.chassis import (
    COMPONENTS,
    MESH_SIZES,
    ChassisDesign,
    chassis_geometry,
    mesh_parameters,
    rear_foundation_geometry,
)

HERE = Path(__file__).resolve().parent


def mesh_jobs(size: str):
    """(file stem, geometry factory, design) for every mesh to build."""
    jobs = []
    for jm in ("simple", "detailed"):
        design = ChassisDesign(joint_model=jm)
        jobs.append((f"assembly_{jm}_{size}", lambda d=design: chassis_geometry(d), design, None))
    design = ChassisDesign()  # Model 3 bodies follow the Model-1 procedure (thesis Sect. 4.5)
    for comp in COMPONENTS:
        jobs.append((f"{comp}_{size}", lambda c=comp: chassis_geometry(design, c), design, comp))
    jobs.append((f"rear_foundation_{size}", rear_foundation_geometry, None, "rear_foundation"))
    return jobs


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="coarse", choices=sorted(MESH_SIZES))
    ap.add_argument("--out", default=str(HERE))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    params = mesh_parameters(args.size)
    manifest_path = out / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {}
    for stem, factory, design, comp in mesh_jobs(args.size):
        t0 = time.perf_counter()
        geo = factory()
        mesh = geo.generate_mesh(**params)
        dt = time.perf_counter() - t0
        path = out / f"{stem}.vol.gz"
        fd, tmp = tempfile.mkstemp(suffix=".vol.gz", dir=out)
        os.close(fd)
        mesh.Save(tmp)
        os.replace(tmp, path)
        nv, ne = len(mesh.Points()), mesh.ne
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        manifest[path.name] = {
            "component": comp,
            "maxh_m": params["maxh"],
            "mesh": params,
            "size": args.size,
            "design": None if design is None else dataclasses.asdict(design),
            "elements": ne,
            "vertices": nv,
            "sha256": digest,
        }
        print(f"{path.name:36s} {ne:7d} tets {nv:6d} vertices  {path.stat().st_size / 1e6:5.2f} MB"
              f"  {dt:5.1f} s")
    manifest_path.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
