"""Clamped eigenmodes of the chassis assembly for the simple and the detailed joint model.

Pure NGsolve + scipy (independent of the package's FE/reduction modules): assemble M
and K with second-order H1 vector elements, a material per region (the tank water
smeared over the tank shell by raising its density), clamp the five rig interface
faces, solve the first modes with scipy ``eigsh`` in shift-invert mode, and print
the frequencies of both joint models, their differences in percent, and the
component that carries most of each mode's kinetic energy.

Usage::

    python meshes/check_modes.py [--size coarse|production|<maxh in m>] [--modes 12]
"""

from __future__ import annotations

import argparse
import time

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, eigsh

from exudyn_study.bodies.fe.chassis import MESH_SIZES, ChassisDesign, chassis_geometry, mesh_parameters
from exudyn_study.bodies.materials import MATERIALS


def clamped_modes(design: ChassisDesign, mesh_size, n_modes: int):
    """Return frequencies (Hz), energy shares per component, ndof, timings."""
    t0 = time.perf_counter()
    geo = chassis_geometry(design)
    ngmesh = geo.generate_mesh(**mesh_parameters(mesh_size))
    t_mesh = time.perf_counter() - t0
    mesh = ngs.Mesh(ngmesh)
    t0 = time.perf_counter()
    regions = [p.region for p in geo.parts]
    # smear added mass with the mesh volume of the region (exact mass on this mesh)
    rho, young, poisson = {}, {}, {}
    for p in geo.parts:
        mat = MATERIALS[p.material]
        vol = ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Materials(p.region))
        rho[p.region] = mat.density_kg_m3 + p.added_mass_kg / vol
        young[p.region], poisson[p.region] = mat.youngs_modulus_pa, mat.poisson_ratio
    e_cf = mesh.MaterialCF(young, default=0)
    nu_cf = mesh.MaterialCF(poisson, default=0)
    rho_cf = mesh.MaterialCF(rho, default=0)
    mu = e_cf / (2 * (1 + nu_cf))
    lam = e_cf * nu_cf / ((1 + nu_cf) * (1 - 2 * nu_cf))
    clamp = "|".join(i.boundary for i in geo.interfaces if i.kind == "rig")
    fes = ngs.VectorH1(mesh, order=2, dirichlet=clamp)
    u, v = fes.TnT()

    def eps(w):
        return ngs.Sym(ngs.Grad(w))

    a = ngs.BilinearForm(fes)
    a += (2 * mu * ngs.InnerProduct(eps(u), eps(v)) + lam * ngs.Trace(eps(u)) * ngs.Trace(eps(v))) * ngs.dx
    m = ngs.BilinearForm(fes)
    m += rho_cf * u * v * ngs.dx
    with ngs.TaskManager():
        a.Assemble()
        m.Assemble()
    free = np.flatnonzero(np.array(fes.FreeDofs(), dtype=bool))

    def to_scipy(mat):
        r, c, vals = mat.COO()
        return sp.csr_matrix((vals, (r, c)), shape=(fes.ndof, fes.ndof))[free][:, free]

    K, M = to_scipy(a.mat), to_scipy(m.mat)
    t_asm = time.perf_counter() - t0
    t0 = time.perf_counter()
    # shift-invert about 0 (clamped: K is positive definite) with NGsolve's sparse
    # Cholesky factor as the inverse operator (much faster than scipy's splu)
    with ngs.TaskManager():
        kinv = a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky")
    rhs, sol = a.mat.CreateColVector(), a.mat.CreateColVector()
    full = np.zeros(fes.ndof)

    def apply_kinv(x):
        full[:] = 0.0
        full[free] = np.ravel(x)
        rhs.FV().NumPy()[:] = full
        with ngs.TaskManager():
            sol.data = kinv * rhs
        return sol.FV().NumPy()[free].copy()

    op = LinearOperator(K.shape, matvec=apply_kinv, dtype=float)
    lam_, phi = eigsh(K, k=n_modes, M=M, sigma=0.0, which="LM", OPinv=op)
    order = np.argsort(lam_)
    lam_, phi = lam_[order], phi[:, order]
    t_eig = time.perf_counter() - t0
    freqs = np.sqrt(np.maximum(lam_, 0.0)) / (2 * np.pi)
    # kinetic-energy share per component
    comps = sorted({p.component for p in geo.parts})
    shares = np.zeros((len(comps), n_modes))
    for ic, comp in enumerate(comps):
        rho_c = mesh.MaterialCF({p.region: rho[p.region] for p in geo.parts if p.component == comp},
                                default=0)
        mc = ngs.BilinearForm(fes)
        mc += rho_c * u * v * ngs.dx
        with ngs.TaskManager():
            mc.Assemble()
        Mc = to_scipy(mc.mat)
        shares[ic] = np.einsum("im,im->m", phi, Mc @ phi)
    shares /= shares.sum(axis=0, keepdims=True)
    mass = sum(ngs.Integrate(rho_cf, mesh, definedon=mesh.Materials(r)) for r in regions)
    return dict(freqs=freqs, comps=comps, shares=shares, ndof=fes.ndof, nfree=len(free),
                t_mesh=t_mesh, t_asm=t_asm, t_eig=t_eig, mass=mass)


def _describe(res, k):
    i = np.argsort(res["shares"][:, k])[::-1]
    top = [(res["comps"][j], res["shares"][j, k]) for j in i[:2]]
    return ", ".join(f"{c} {100 * s:.0f}%" for c, s in top if s > 0.1)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="coarse", help="coarse | production | maxh in m")
    ap.add_argument("--modes", type=int, default=12)
    args = ap.parse_args(argv)
    size = args.size if args.size in MESH_SIZES else float(args.size)
    params = mesh_parameters(size)
    res = {}
    for jm in ("simple", "detailed"):
        res[jm] = r = clamped_modes(ChassisDesign(joint_model=jm), size, args.modes)
        print(f"{jm:9s}: {r['ndof']} DOF ({r['nfree']} free), mass {r['mass']:.1f} kg, mesh "
              f"{r['t_mesh']:.1f} s, assembly {r['t_asm']:.1f} s, eigsh {r['t_eig']:.1f} s")
    s, d = res["simple"], res["detailed"]
    print(f"\nclamped at the five rig interfaces, mesh {args.size}: {params}")
    print(f"{'mode':>4} {'simple Hz':>10} {'detailed Hz':>12} {'diff %':>7}  dominant (simple) | (detailed)")
    for k in range(args.modes):
        fs, fd = s["freqs"][k], d["freqs"][k]
        print(f"{k + 1:4d} {fs:10.2f} {fd:12.2f} {100 * (fd - fs) / fs:7.2f}  "
              f"{_describe(s, k)} | {_describe(d, k)}")


if __name__ == "__main__":
    main()
