"""Benchmark: geometry -> mesh -> FE matrices -> Craig-Bampton -> FFRF terms, and cache hits.

One command: ``python benchmarks/bench_reduction.py [--meshes coarse production] [--exudyn-hcb]``.
Prints, per mesh size, the DOF count and the wall time of each step with a fresh cache,
then the time of a cache hit. ``--exudyn-hcb`` also times Exudyn's out-of-the-box
``FEMinterface.ComputeHurtyCraigBamptonModes`` (RBE2, scipy) on the same model with the
same number of fixed-interface modes, as a ratio in the same run.

Target (issue 2): the production assembly (~150 k DOF) from geometry to reduced body in
under 60 s on this 2-core machine. Times on a shared machine are noisy: compare ratios.
"""

from __future__ import annotations

import argparse
import tempfile
import time

from exudyn_study.bodies import BodySpec, fe_model_and_interfaces, flexible_body


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["coarse", "production"])
    parser.add_argument("--joints", default="simple", choices=["simple", "detailed"])
    parser.add_argument("--exudyn-hcb", action="store_true", help="also time Exudyn's own HCB")
    args = parser.parse_args()
    rows = []
    for mesh in args.meshes:
        spec = BodySpec(joint_model=args.joints, mesh_size=mesh)
        with tempfile.TemporaryDirectory() as cache_dir:
            t0 = time.perf_counter()
            data = flexible_body(spec, cache_dir=cache_dir)
            total = time.perf_counter() - t0
            t0 = time.perf_counter()
            hit = flexible_body(spec, cache_dir=cache_dir)
            t_hit = time.perf_counter() - t0
            assert hit.from_cache
        t = data.timings_s
        rows.append((mesh, int(t["dof"]), t["mesh"], t["assembly"], t["reduction"], t["ffrf_terms"], total, t_hit))
        print(f"\n{spec.name} / {mesh}: {int(t['dof'])} DOF, {data.body.n_modes} flexible modes "
              f"({data.body.n_static_modes} static + {data.body.fixed_interface_frequencies_hz.size} "
              f"fixed-interface <= {spec.reduction.max_frequency_hz:.0f} Hz)")
        for key in ("mesh", "assembly", "reduction", "reduction.factorisation", "reduction.static_modes",
                    "reduction.fixed_interface_modes", "reduction.orthogonalisation", "ffrf_terms"):
            print(f"  {key:34s} {t[key]:8.2f} s")
        print(f"  {'geometry -> reduced body (total)':34s} {total:8.2f} s")
        print(f"  {'cache hit':34s} {t_hit:8.3f} s")
        if args.exudyn_hcb:
            from exudyn.FEM import FEMinterface, HCBstaticModeSelection

            fe_model, interfaces = fe_model_and_interfaces(spec)
            fem = FEMinterface()
            fem.nodes = {"Position": fe_model.node_positions_m}
            fem.massMatrix, fem.stiffnessMatrix = fe_model.mass_matrix, fe_model.stiffness_matrix
            t0 = time.perf_counter()
            fem.ComputeHurtyCraigBamptonModes(
                boundaryNodesList=[i.node_indices for i in interfaces],
                boundaryNodesWeights=[i.node_weights for i in interfaces],
                nEigenModes=int(data.body.fixed_interface_frequencies_hz.size),
                computationMode=HCBstaticModeSelection.RBE2, excludeRigidBodyMotion=False)
            t_exu = time.perf_counter() - t0
            print(f"  Exudyn ComputeHurtyCraigBamptonModes: {t_exu:.1f} s "
                  f"(ours: {t['reduction']:.1f} s incl. orthogonalisation; ratio {t_exu / t['reduction']:.1f}x)")
    print("\n| mesh | DOF | mesh [s] | assembly [s] | reduction [s] | FFRF terms [s] | total [s] | cache hit [s] |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.1f} | {r[3]:.1f} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.1f} | {r[7]:.3f} |")


if __name__ == "__main__":
    main()
