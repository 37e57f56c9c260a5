"""Flexible bodies of the study, built from geometry and cached on disk.

``flexible_body(BodySpec(...))`` runs geometry -> mesh -> second-order FE matrices ->
Craig-Bampton -> orthogonalisation -> FFRF inertia terms, or returns the cached result
when nothing in the recipe changed (geometry parameters, mesh size, materials,
reduction settings, netgen version, code version).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.bodies.ffrf import FFRF_FIELDS, FFRFData
from exudyn_study.bodies.materials import MATERIALS
from exudyn_study.bodies.reduction import ReducedBody, ReductionSettings
from exudyn_study.errors import InputError
from exudyn_study.infra import cache
from exudyn_study.infra.progress import StageProgress

__all__ = ["BodySpec", "FlexibleBodyData", "flexible_body", "fe_model_and_interfaces", "BODY_KINDS"]

log = logging.getLogger(__name__)

#: Bump when the reduction or assembly code changes its results: cached bodies are rebuilt.
REDUCTION_CODE_VERSION = 1

BODY_KINDS = ("chassis", "rear_foundation")


#: the stages of a body build, as its progress bar shows them
BUILD_STAGES = ("mesh", "assembly", "reduction", "FFRF terms")

#: Modules whose code determines a reduced body: a change in any of them changes the cache key.
_SOURCE_MODULES = (
    "fe/chassis.py", "fe/assembly.py", "fe/solvers.py", "reduction.py", "ffrf.py", "materials.py",
)


def _code_without_docs(source: str) -> str:
    """Return the syntax tree of ``source`` as text, without docstrings (comments are not in it)."""
    import ast

    tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree, include_attributes=False)


def _source_digest() -> str:
    """SHA-256 over the code of the modules that build a body (geometry to FFRF terms).

    The code is hashed as its syntax tree without docstrings, so a change of documentation,
    comments or line wrapping keeps the cached bodies, and a change of what the code does
    rebuilds them.
    """
    import hashlib
    from pathlib import Path

    root = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for rel in _SOURCE_MODULES:
        digest.update(rel.encode())
        digest.update(_code_without_docs((root / rel).read_text()).encode())
    return digest.hexdigest()


@dataclass(frozen=True)
class BodySpec:
    """What flexible body to build.

    Parameters
    ----------
    kind : {'chassis', 'rear_foundation'}
    joint_model : {'simple', 'detailed'}
        Bolted-joint representation of the chassis (Model 1 / Model 2).
    component : str or None
        None: the whole chassis assembly as one body (Models 1, 2); otherwise one
        Model-3 component ('frame', 'tank_left', 'tank_right', 'bracket_left',
        'bracket_right').
    mesh_size : str or float
        'production' (default), 'coarse' or a maximum element size in m (with the production
        refinement); see :data:`exudyn_study.bodies.fe.chassis.MESH_SIZES`.
    reduction : ReductionSettings
    water_mass_per_tank_kg : float
        Water in each fuel tank (thesis: 222 kg).
    """

    kind: str = "chassis"
    joint_model: str = "simple"
    component: str | None = None
    mesh_size: str | float = "production"
    reduction: ReductionSettings = field(default_factory=ReductionSettings)
    water_mass_per_tank_kg: float = 222.0

    def __post_init__(self) -> None:
        if self.kind not in BODY_KINDS:
            raise InputError(f"body kind {self.kind!r}: expected one of {list(BODY_KINDS)}")
        if self.joint_model not in ("simple", "detailed"):
            raise InputError(f"joint_model {self.joint_model!r}: expected 'simple' or 'detailed'")
        if isinstance(self.mesh_size, str):
            if self.mesh_size not in ("coarse", "production"):
                raise InputError(
                    f"mesh_size {self.mesh_size!r}: expected 'coarse', 'production' or a size in m"
                )
        elif not (math.isfinite(self.mesh_size) and self.mesh_size > 0):
            raise InputError(f"mesh_size {self.mesh_size!r}: expected a positive element size in m")
        if not (math.isfinite(self.water_mass_per_tank_kg) and self.water_mass_per_tank_kg >= 0):
            raise InputError(
                f"water_mass_per_tank_kg = {self.water_mass_per_tank_kg!r}; expected a mass >= 0 in kg"
            )

    @property
    def name(self) -> str:
        """Short body name, e.g. ``chassis_simple``, ``frame_simple``, ``rear_foundation``."""
        if self.kind == "rear_foundation":
            return "rear_foundation"
        return f"{self.component or 'chassis'}_{self.joint_model}"

    def maxh_m(self) -> float:
        """Maximum element size in m."""
        return self.mesh_parameters()["maxh"]

    def mesh_parameters(self) -> dict:
        """Keyword arguments of :meth:`~exudyn_study.bodies.fe.chassis.ChassisGeometry.generate_mesh`."""
        from exudyn_study.bodies.fe.chassis import mesh_parameters

        return mesh_parameters(self.mesh_size)

    def geometry(self):
        """Return the :class:`~exudyn_study.bodies.fe.chassis.ChassisGeometry` of this body."""
        from exudyn_study.bodies.fe import chassis

        if self.kind == "rear_foundation":
            return chassis.rear_foundation_geometry()
        design = chassis.ChassisDesign(
            joint_model=self.joint_model, water_mass_per_tank_kg=self.water_mass_per_tank_kg
        )
        return chassis.chassis_geometry(design, component=self.component)

    def recipe(self) -> dict:
        """Everything the cached result depends on (the cache key is its hash)."""
        from exudyn_study.bodies.fe import chassis, mesher_version

        if self.kind == "rear_foundation":
            design = dataclasses.asdict(chassis.RearFoundationDesign())
        else:
            design = dataclasses.asdict(
                chassis.ChassisDesign(
                    joint_model=self.joint_model, water_mass_per_tank_kg=self.water_mass_per_tank_kg
                )
            )
        return {
            "kind": self.kind,
            "component": self.component,
            "design": design,
            "maxh_m": self.maxh_m(),
            "mesh": self.mesh_parameters(),
            "mesh_grading": chassis.MESH_GRADING,
            "reduction": dataclasses.asdict(self.reduction),
            "materials": {k: dataclasses.asdict(v) for k, v in MATERIALS.items()},
            "netgen": mesher_version(),
            "code": REDUCTION_CODE_VERSION,
            "source": _source_digest(),
        }


@dataclass(frozen=True)
class FlexibleBodyData:
    """A reduced body with its FFRF terms, ready for :func:`exudyn_study.bodies.ffrf.add_flexible_body`.

    Attributes
    ----------
    body : ReducedBody
    ffrf : FFRFData
    timings_s : dict
        Wall times of the build steps (empty entries on a cache hit).
    from_cache : bool
    """

    body: ReducedBody
    ffrf: FFRFData
    timings_s: dict
    from_cache: bool


def fe_model_and_interfaces(spec: BodySpec, timings: dict | None = None,
                            stage: Callable[[str], None] | None = None):
    """Mesh and assemble the body of ``spec``; return ``(FEModel, interfaces)``.

    Parameters
    ----------
    spec : BodySpec
        The body (kind, component, joint model, mesh size).
    timings : dict, optional
        If given, receives the wall times (s) under 'mesh' and 'assembly'.
    stage : callable, optional
        Called with ``"mesh"`` and ``"assembly"`` as each starts (progress display).

    Returns
    -------
    fe_model : FEModel
        Mass and stiffness matrices and the mesh data.
    interfaces : list of Interface
        The body's interface patches, in the geometry's order.
    """
    from exudyn_study.bodies.fe.assembly import PartMaterial, assemble, interface_from_boundary

    timings = {} if timings is None else timings
    stage = stage or (lambda name: None)
    stage("mesh")
    t0 = time.perf_counter()
    geometry = spec.geometry()
    ngmesh = geometry.generate_mesh(**spec.mesh_parameters())
    timings["mesh"] = time.perf_counter() - t0
    stage("assembly")
    t0 = time.perf_counter()
    parts = [PartMaterial(p.region, p.material, p.added_mass_kg, p.component) for p in geometry.parts]
    fe_model = assemble(ngmesh, parts)
    interfaces = [interface_from_boundary(fe_model, s.boundary, s.name) for s in geometry.interfaces]
    timings["assembly"] = time.perf_counter() - t0
    return fe_model, interfaces


def _to_arrays(body: ReducedBody, ffrf: FFRFData) -> dict[str, np.ndarray]:
    regions = list(body.region_nodes)
    arrays = {
        "node_positions_m": body.node_positions_m,
        "mode_basis": body.mode_basis,
        "frequencies_hz": body.frequencies_hz,
        "surface_triangles": body.surface_triangles,
        "interface_names": np.array(body.interface_names),
        "interface_offsets": np.cumsum([0] + [len(n) for n in body.interface_nodes]),
        "interface_nodes": np.concatenate(body.interface_nodes),
        "interface_weights": np.concatenate(body.interface_weights),
        "interface_centers_m": body.interface_centers_m,
        "region_names": np.array(regions),
        "region_component_names": np.array([body.region_components[r] for r in regions]),
        "region_offsets": np.cumsum([0] + [len(body.region_nodes[r]) for r in regions]),
        "region_nodes": np.concatenate([body.region_nodes[r] for r in regions]),
        "fixed_interface_frequencies_hz": body.fixed_interface_frequencies_hz,
        "n_static_modes": np.array(body.n_static_modes),
        "total_mass_kg": np.array(body.total_mass_kg),
        "fixed_interface_cutoff_hz": np.array(body.fixed_interface_cutoff_hz),
        "truncation_error_estimate": np.asarray(body.truncation_error_estimate, dtype=float),
        "name": np.array(body.name),
    }
    arrays.update({f"ffrf_{k}": v for k, v in ffrf.as_arrays().items()})
    return arrays


def _from_arrays(a: dict[str, np.ndarray]) -> tuple[ReducedBody, FFRFData]:
    def split(values, offsets):
        return tuple(values[offsets[i] : offsets[i + 1]] for i in range(len(offsets) - 1))

    regions = [str(r) for r in a["region_names"]]
    region_nodes = dict(zip(regions, split(a["region_nodes"], a["region_offsets"]), strict=False))
    body = ReducedBody(
        name=str(a["name"]),
        node_positions_m=a["node_positions_m"],
        mode_basis=a["mode_basis"],
        frequencies_hz=a["frequencies_hz"],
        surface_triangles=a["surface_triangles"],
        interface_names=tuple(str(n) for n in a["interface_names"]),
        interface_nodes=split(a["interface_nodes"], a["interface_offsets"]),
        interface_weights=split(a["interface_weights"], a["interface_offsets"]),
        interface_centers_m=a["interface_centers_m"],
        region_nodes=region_nodes,
        region_components=dict(zip(regions, (str(c) for c in a["region_component_names"]), strict=False)),
        fixed_interface_frequencies_hz=a["fixed_interface_frequencies_hz"],
        n_static_modes=int(a["n_static_modes"]),
        total_mass_kg=float(a["total_mass_kg"]),
        # absent from arrays written before the convergence check (test fixtures' own caches)
        fixed_interface_cutoff_hz=float(a["fixed_interface_cutoff_hz"]) if "fixed_interface_cutoff_hz" in a
        else float("nan"),
        truncation_error_estimate=a["truncation_error_estimate"] if "truncation_error_estimate" in a
        else np.zeros(0),
    )
    ffrf = FFRFData.from_arrays({k: a[f"ffrf_{k}"] for k in FFRF_FIELDS})
    return body, ffrf


def flexible_body(spec: BodySpec = BodySpec(), cache_dir=None, use_cache: bool = True) -> FlexibleBodyData:
    """Build (or load from cache) the reduced flexible body described by ``spec``.

    Parameters
    ----------
    spec : BodySpec
    cache_dir : path, optional
        Cache directory (default: ``$EXUDYN_STUDY_CACHE`` or ``~/.cache/exudyn_study``).
    use_cache : bool
        False forces a rebuild and does not touch the cache.

    Returns
    -------
    FlexibleBodyData
    """
    from exudyn_study.bodies.ffrf import ffrf_data
    from exudyn_study.bodies.reduction import craig_bampton

    timings: dict[str, float] = {}

    def build() -> dict[str, np.ndarray]:
        with StageProgress(f"building flexible body {spec.name}", BUILD_STAGES) as progress:
            fe_model, interfaces = fe_model_and_interfaces(spec, timings, progress.stage)
            progress.stage("reduction")
            t0 = time.perf_counter()
            steps: dict[str, float] = {}
            body = craig_bampton(fe_model, interfaces, spec.reduction, name=spec.name, timings=steps)
            timings["reduction"] = time.perf_counter() - t0
            timings.update({f"reduction.{k}": v for k, v in steps.items()})
            timings["dof"] = float(fe_model.n_dof)
            progress.stage("FFRF terms")
            t0 = time.perf_counter()
            ffrf = ffrf_data(body)
            timings["ffrf_terms"] = time.perf_counter() - t0
        return _to_arrays(body, ffrf)

    t0 = time.perf_counter()
    if use_cache:
        arrays, hit = cache.cached(spec.recipe(), build, cache_dir)
    else:
        arrays, hit = build(), False
    body, ffrf = _from_arrays(arrays)
    timings["total"] = time.perf_counter() - t0
    log.info("flexible body %s: %s in %.1f s", spec.name, "cache hit" if hit else "built", timings["total"])
    return FlexibleBodyData(body=body, ffrf=ffrf, timings_s=timings, from_cache=hit)


def parse_mesh(text: str):
    """Parse a mesh size: 'coarse', 'production' or a maximum element size in m.

    Parameters
    ----------
    text : str
        'coarse', 'production' or a number (m), e.g. from ``--mesh``.

    Returns
    -------
    str or float
        The name, or the element size (m).

    Raises
    ------
    InputError
        For any other text.
    """
    from exudyn_study.errors import InputError

    if text in ("coarse", "production"):
        return text
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--mesh {text!r}: expected coarse, production or an element size in m") from None
