"""Benchmark: geometry -> mesh -> FE matrices -> Craig-Bampton -> FFRF terms, and cache hits.

One command: ``python benchmarks/bench_reduction.py [--meshes coarse production]
[--joints simple detailed] [--exudyn-hcb] [--no-results]``. Prints, per mesh size and joint model, the DOF
count and the wall time of each step with a fresh cache, then the time of a cache hit. A mesh
size whose mesh parameters equal one already timed is reported as that one, not rebuilt (see
:data:`exudyn_study.bodies.fe.chassis.MESH_SIZES`: coarse 0.2 m with less local refinement, production
0.12 m).
``--exudyn-hcb`` also times Exudyn's out-of-the-box
``FEMinterface.ComputeHurtyCraigBamptonModes`` (RBE2, scipy) on the same model with the
same number of fixed-interface modes, as a ratio in the same run.

Target (issue 2): the production assembly (~150 k DOF, simple joints) from geometry to
reduced body in under 60 s on this 2-core machine. Times on a shared machine are noisy:
the load average is printed with the results; compare ratios within one run. The table's
figures go with date, commit and load to ``benchmarks/results/bench_reduction.json``
(``--no-results``: not written).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from exudyn_study.bodies import BodySpec, fe_model_and_interfaces, flexible_body

STEPS = ("mesh", "assembly", "reduction", "reduction.factorisation", "reduction.static_modes",
         "reduction.fixed_interface_modes", "reduction.orthogonalisation", "reduction.convergence_check",
         "ffrf_terms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["coarse", "production"])
    parser.add_argument("--joints", nargs="+", default=["simple", "detailed"], choices=["simple", "detailed"])
    parser.add_argument("--exudyn-hcb", action="store_true", help="also time Exudyn's own HCB")
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = parser.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    hcb = {}
    rows = []
    timed: dict[tuple[str, str], str] = {}
    print(f"load average at start: {os.getloadavg()[0]:.2f} (1 min), {os.getloadavg()[1]:.2f} (5 min)")
    for joints in args.joints:
        for mesh in args.meshes:
            spec = BodySpec(joint_model=joints, mesh_size=mesh)
            key = (joints, repr(sorted(spec.mesh_parameters().items())))
            same = timed.get(key)
            if same is not None:
                print(f"\n{spec.name} / {mesh}: {spec.mesh_parameters()}, the same mesh as '{same}' "
                      "(not rebuilt)")
                earlier = next(r[2:] for r in rows if r[:2] == (joints, same))
                rows.append((joints, f"{mesh} (= {same})", *earlier))
                continue
            timed[key] = mesh
            with tempfile.TemporaryDirectory() as cache_dir:
                t0 = time.perf_counter()
                data = flexible_body(spec, cache_dir=cache_dir)
                total = time.perf_counter() - t0
                t0 = time.perf_counter()
                hit = flexible_body(spec, cache_dir=cache_dir)
                t_hit = time.perf_counter() - t0
                assert hit.from_cache
            t = data.timings_s
            body = data.body
            rows.append((joints, mesh, int(t["dof"]), t["mesh"], t["assembly"], t["reduction"],
                         t["ffrf_terms"], total, t_hit, os.getloadavg()[0]))
            print(f"\n{spec.name} / {mesh}: {int(t['dof'])} DOF, {body.n_modes} flexible modes "
                  f"({body.n_static_modes} static + {body.fixed_interface_frequencies_hz.size} "
                  f"fixed-interface <= {body.fixed_interface_cutoff_hz:.0f} Hz; cut-off asked "
                  f"{spec.reduction.max_frequency_hz:.0f} Hz), worst estimated error up to "
                  f"{spec.reduction.check_frequency_hz:.0f} Hz: "
                  f"{100 * max(body.truncation_error_estimate, default=0.0):.3f} %")
            for key in STEPS:
                print(f"  {key:34s} {t.get(key, float('nan')):8.2f} s")
            print(f"  {'geometry -> reduced body (total)':34s} {total:8.2f} s")
            print(f"  {'cache hit':34s} {t_hit:8.3f} s")
            print(f"  load average (1 min) now: {os.getloadavg()[0]:.2f}")
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
                    nEigenModes=int(body.fixed_interface_frequencies_hz.size),
                    computationMode=HCBstaticModeSelection.RBE2, excludeRigidBodyMotion=False)
                t_exu = time.perf_counter() - t0
                hcb[f"{joints}/{mesh}"] = {"exudyn_s": t_exu, "ours_s": t["reduction"],
                                           "ratio": t_exu / t["reduction"]}
                print(f"  Exudyn ComputeHurtyCraigBamptonModes: {t_exu:.1f} s (ours: {t['reduction']:.1f} s "
                      f"incl. orthogonalisation; ratio {t_exu / t['reduction']:.1f}x)")
    print("\n| joints | mesh | DOF | mesh [s] | assembly [s] | reduction [s] | FFRF terms [s] | total [s] "
          "| cache hit [s] | load (1 min) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.1f} | {r[4]:.1f} | {r[5]:.1f} | {r[6]:.1f} | {r[7]:.1f} "
              f"| {r[8]:.3f} | {r[9]:.2f} |")
    if not args.no_results:
        names = ("joints", "mesh", "dof", "mesh_s", "assembly_s", "reduction_s", "ffrf_terms_s", "total_s",
                 "cache_hit_s", "load_1min")
        figures = {"rows": [dict(zip(names, r, strict=True)) for r in rows], "exudyn_hcb": hcb or None}
        print(f"key figures {write_results('bench_reduction', figures, args=args, start=run)}")


if __name__ == "__main__":
    main()
