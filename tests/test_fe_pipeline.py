"""FE -> Craig-Bampton -> Exudyn flexible body, checked against physics.

References: Euler-Bernoulli cantilever (beta_n L = 1.8751, 4.6941, 7.8548), invariants of a
correct assembly (mass, rigid-body null space), Exudyn's own FFRF terms and HCB modes,
and the damping ratios a body is given coming back from Exudyn's damped eigenvalues.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from exudyn_study.bodies.fe.assembly import PartMaterial, assemble, interface_from_boundary, load_mesh
from exudyn_study.bodies.ffrf import add_flexible_body, ffrf_data, modal_damping_matrix
from exudyn_study.bodies.materials import Material
from exudyn_study.bodies.reduction import ReductionSettings, craig_bampton
from exudyn_study.errors import InputError

BEAM_LENGTH_M, BEAM_WIDTH_M, BEAM_HEIGHT_M = 1.0, 0.02, 0.02
STEEL_E_PA, STEEL_RHO = 210.0e9, 7850.0
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])
# 3D solid vs Euler-Bernoulli: shear and rotary inertia (Timoshenko) lower mode 3 of this
# L/h = 50 beam by ~0.4 %; the acceptance bound is 1 %.
EB_RTOL = 0.01


def euler_bernoulli_cantilever_hz() -> np.ndarray:
    area = BEAM_WIDTH_M * BEAM_HEIGHT_M
    inertia = BEAM_WIDTH_M * BEAM_HEIGHT_M**3 / 12.0
    return BETA_L**2 / (2 * math.pi) * math.sqrt(STEEL_E_PA * inertia / (STEEL_RHO * area * BEAM_LENGTH_M**4))


def beam_mesh(maxh: float):
    from netgen.occ import Box, OCCGeometry, Pnt, X

    box = Box(Pnt(0, 0, 0), Pnt(BEAM_LENGTH_M, BEAM_WIDTH_M, BEAM_HEIGHT_M))
    box.faces.Min(X).name = "clamp"
    box.faces.Max(X).name = "tip"
    box.mat("beam")
    return OCCGeometry(box).GenerateMesh(maxh=maxh)


@pytest.fixture(scope="module")
def beam_models():
    """Second-order beam models on three mesh sizes (coarse to fine)."""
    return {maxh: assemble(beam_mesh(maxh), [PartMaterial("beam", "steel")]) for maxh in (0.04, 0.02, 0.01)}


@pytest.fixture(scope="module")
def beam_body(beam_models):
    model = beam_models[0.02]
    itfs = [interface_from_boundary(model, "clamp"), interface_from_boundary(model, "tip")]
    return craig_bampton(model, itfs, ReductionSettings(max_frequency_hz=1500.0), name="beam")


def cantilever_bending_hz(model) -> np.ndarray:
    """First three bending frequencies (one per pair of the square section) through the pipeline."""
    body = craig_bampton(model, [interface_from_boundary(model, "clamp")],
                         ReductionSettings(max_frequency_hz=1500.0))
    f = np.sort(body.fixed_interface_frequencies_hz)
    # square section: y and z bending pairs are degenerate; no torsion/axial mode below 1500 Hz
    assert f.size >= 6
    return f[[0, 2, 4]]


def test_assembly_mass_and_rigid_body_invariants(beam_models):
    model = beam_models[0.02]
    expected = STEEL_RHO * BEAM_LENGTH_M * BEAM_WIDTH_M * BEAM_HEIGHT_M
    assert model.total_mass_kg == pytest.approx(expected, rel=1e-9)
    # 6-node surface triangles in Exudyn's order: entry 3 is the mid node of corners 0-1
    p = model.node_positions_m
    tri = model.surface_triangles
    np.testing.assert_allclose(p[tri[:, 3]], 0.5 * (p[tri[:, 0]] + p[tri[:, 1]]), atol=1e-12)
    np.testing.assert_allclose(p[tri[:, 4]], 0.5 * (p[tri[:, 1]] + p[tri[:, 2]]), atol=1e-12)


def test_cantilever_matches_euler_bernoulli_and_converges(beam_models):
    reference = euler_bernoulli_cantilever_hz()
    freqs = {maxh: cantilever_bending_hz(m) for maxh, m in beam_models.items()}
    for maxh, f in freqs.items():
        rel = f / reference - 1.0
        assert np.all(np.abs(rel) < EB_RTOL), f"maxh={maxh}: relative errors {rel}"
    # discretisation error falls with refinement: successive differences shrink, and the
    # first mode (no Timoshenko offset to speak of) approaches Euler-Bernoulli monotonically
    f_coarse, f_mid, f_fine = freqs[0.04], freqs[0.02], freqs[0.01]
    assert np.all(np.abs(f_fine - f_mid) < np.abs(f_mid - f_coarse))
    err1 = [abs(freqs[h][0] / reference[0] - 1.0) for h in (0.04, 0.02, 0.01)]
    assert err1[0] > err1[1] > err1[2]


def full_model_with_patches_hz(model, itfs, n_modes: int) -> np.ndarray:
    """Free-free elastic frequencies of the unreduced model whose patches move rigidly (RBE2)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from exudyn_study.bodies.reduction import rbe2_mapping

    n = model.n_dof
    cols, dof_b = [], []
    for itf in itfs:
        dof_b.append((3 * itf.node_indices[:, None] + np.arange(3)).ravel())
        cols.append(rbe2_mapping(model.node_positions_m[itf.node_indices], itf.center_m))
    dof_b = np.concatenate(dof_b)
    interior = np.setdiff1d(np.arange(n), dof_b)
    rbe2 = sp.block_diag([sp.csr_matrix(c) for c in cols]).tocoo()  # (n_b, 6 n_itf)
    # full DOF = interior identity + rigid patch motion: T has shape (n, n_interior + 6 n_itf)
    rows = np.concatenate([interior, dof_b[rbe2.row]])
    cols_t = np.concatenate([np.arange(interior.size), interior.size + rbe2.col])
    data = np.concatenate([np.ones(interior.size), rbe2.data])
    t = sp.csr_matrix((data, (rows, cols_t)), shape=(n, interior.size + rbe2.shape[1]))
    k = (t.T @ model.stiffness_matrix @ t).tocsc()
    m = (t.T @ model.mass_matrix @ t).tocsc()
    # shift well below the first elastic mode (~106 Hz) but far from the six zeros: with
    # sigma = -1 the factor of K + M is nearly singular and the frequencies scatter by ~1e-4
    shift = -((2 * math.pi * 10.0) ** 2)
    lam = spla.eigsh(k, k=n_modes + 6, M=m, sigma=shift, which="LM", return_eigenvectors=False)
    lam = np.sort(lam)
    return np.sqrt(np.abs(lam[6:])) / (2 * math.pi)


def test_reduced_free_free_modes_match_full_model_with_patches(beam_models, beam_body):
    """Orthogonalised CB body == full FE with the same rigid patches (free-free), below 1 kHz."""
    model = beam_models[0.02]
    itfs = [interface_from_boundary(model, "clamp"), interface_from_boundary(model, "tip")]
    full = full_model_with_patches_hz(model, itfs, 10)
    reduced = beam_body.frequencies_hz
    # CB truncation error grows towards the cut-off (1500 Hz here); the chassis acceptance
    # compares below a third of its cut-off (100 of 300 Hz), so do the same
    below = full < 1500.0 / 3.0
    assert below.sum() >= 4
    np.testing.assert_allclose(reduced[: below.sum()], full[below], rtol=2e-3)


@pytest.fixture(scope="module")
def beam_patched(beam_models):
    """The 0.02 m beam with its two rigid end patches and the full model's first 8 frequencies."""
    model = beam_models[0.02]
    itfs = [interface_from_boundary(model, "clamp"), interface_from_boundary(model, "tip")]
    return model, itfs, full_model_with_patches_hz(model, itfs, 8)


def test_truncation_error_estimate_is_a_tight_lower_bound(beam_patched):
    """The residual-correction estimate recovers the true CB error (vs the full model) from below."""
    model, itfs, full = beam_patched
    # cut-off 300 Hz: the ~106 and ~292 Hz bending pairs are 0.36 % and 0.45 % stiff; no raising
    settings = ReductionSettings(max_frequency_hz=300.0, check_frequency_hz=400.0, frequency_tolerance=0.5)
    body = craig_bampton(model, itfs, settings)
    assert body.fixed_interface_cutoff_hz == 300.0
    est = body.truncation_error_estimate
    assert est.size == 4
    true = body.frequencies_hz[:4] / full[:4] - 1.0
    assert np.all(true > 1e-3)  # a real truncation error to estimate
    # lower bound (Rayleigh-Ritz in a larger subspace of the patched model) ...
    assert np.all(est <= true * (1 + 1e-6))
    # ... that misses only ~(f / f_truncated)^2 of it
    assert np.all(est >= 0.98 * true), est / true


def test_cutoff_is_raised_until_the_checked_modes_converge(beam_patched):
    model, itfs, full = beam_patched
    tol = 1e-3
    fixed = craig_bampton(model, itfs, ReductionSettings(max_frequency_hz=150.0, check_frequency_hz=0.0))
    assert fixed.fixed_interface_cutoff_hz == 150.0
    err_fixed = fixed.frequencies_hz[:4] / full[:4] - 1.0
    assert err_fixed.max() > tol  # the 150 Hz cut-off alone leaves the 292 Hz pair unconverged
    settings = ReductionSettings(max_frequency_hz=150.0, check_frequency_hz=300.0, frequency_tolerance=tol)
    body = craig_bampton(model, itfs, settings)
    assert body.fixed_interface_cutoff_hz > 150.0
    assert body.fixed_interface_frequencies_hz.size > fixed.fixed_interface_frequencies_hz.size
    checked = full <= 300.0
    err = body.frequencies_hz[: checked.sum()] / full[checked] - 1.0
    assert checked.sum() == 4
    assert np.all(np.abs(err) <= tol), err


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"check_frequency_hz": -1.0}, "check_frequency_hz"),
        ({"check_frequency_hz": float("nan")}, "check_frequency_hz"),
        ({"frequency_tolerance": 0.0}, "frequency_tolerance"),
        ({"frequency_tolerance": 1.0}, "frequency_tolerance"),
        ({"cutoff_growth": 1.0}, "cutoff_growth"),
    ],
)
def test_bad_convergence_check_settings(kwargs, match):
    with pytest.raises(InputError, match=match):
        ReductionSettings(**kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("joint_model", ["simple", "detailed"])
def test_chassis_reduced_body_matches_full_model_up_to_100_hz(joint_model):
    """Issue 2 acceptance: production chassis body vs the full FE model with the same patches.

    Minutes per joint model (cached body; the full model's free-free eigenproblem of 160-263 k DOF).
    """
    from exudyn_study.bodies import BodySpec, fe_model_and_interfaces, flexible_body
    from exudyn_study.bodies.reduction import patched_full_model_frequencies

    spec = BodySpec(joint_model=joint_model, mesh_size="production")
    body = flexible_body(spec).body
    fe_model, interfaces = fe_model_and_interfaces(spec)
    n_full = int(np.sum(body.frequencies_hz <= 100.0)) + 2
    full = patched_full_model_frequencies(fe_model, interfaces, n_modes=n_full)
    below = full <= 100.0
    assert below.sum() >= 10
    rel = body.frequencies_hz[: below.sum()] / full[below] - 1.0
    assert np.all(np.abs(rel) <= 0.005), rel


def test_ffrf_terms_equal_exudyn_reference(beam_body):
    ours = ffrf_data(beam_body, "numpy").as_arrays()
    ref = ffrf_data(beam_body, "exudyn").as_arrays()
    # some coupling terms vanish for an orthogonalised basis (round-off sized); compare every
    # term against the magnitude of the largest inertia term
    scale = max(np.abs(v).max() for v in ref.values())
    for name, value in ref.items():
        assert np.abs(ours[name] - value).max() <= 1e-10 * scale, name


def test_hcb_spans_same_space_as_exudyn_feminterface(beam_models, beam_body):
    """Our single-factorisation HCB gives the same reduced frequencies as Exudyn's FEMinterface."""
    import scipy.linalg as sla
    from exudyn.FEM import FEMinterface, HCBstaticModeSelection

    model = beam_models[0.02]
    itfs = [interface_from_boundary(model, "clamp"), interface_from_boundary(model, "tip")]
    fem = FEMinterface()
    fem.nodes = {"Position": model.node_positions_m}
    fem.massMatrix, fem.stiffnessMatrix = model.mass_matrix, model.stiffness_matrix
    n_fixed = beam_body.fixed_interface_frequencies_hz.size
    fem.ComputeHurtyCraigBamptonModes(
        boundaryNodesList=[i.node_indices for i in itfs],
        boundaryNodesWeights=[i.node_weights for i in itfs],
        nEigenModes=n_fixed,
        computationMode=HCBstaticModeSelection.RBE2,
        excludeRigidBodyMotion=False,
    )
    psi = fem.modeBasis["matrix"]
    lam = sla.eigh(psi.T @ (model.stiffness_matrix @ psi), psi.T @ (model.mass_matrix @ psi),
                   eigvals_only=True)
    exudyn_hz = np.sqrt(np.abs(lam[6:])) / (2 * math.pi)
    np.testing.assert_allclose(beam_body.frequencies_hz, exudyn_hz, rtol=1e-6)


def _exudyn_damped_modes(body, zeta, fix_frame: bool):
    import exudyn as exu
    import exudyn.itemInterface as eii

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    handle = add_flexible_body(mbs, body, ffrf_data(body), zeta)
    if fix_frame:
        ground = mbs.AddObject(eii.ObjectGround())
        m_ground = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
        m_frame = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=handle.rigid_node))
        mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[m_ground, m_frame], constrainedAxes=[1] * 6))
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues(computeComplexEigenvalues=True, useAbsoluteValues=False)
    values = np.asarray(values)
    values = values[values.imag > 1e-6 * np.abs(values).max()]
    order = np.argsort(np.abs(values))
    values = values[order]
    return np.abs(values) / (2 * math.pi), -values.real / np.abs(values)


@pytest.mark.parametrize("fix_frame", [True, False], ids=["frame-fixed", "free-floating"])
def test_set_damping_ratios_come_back_from_exudyn_eigenvalues(beam_body, fix_frame):
    zeta = np.full(beam_body.n_modes, 0.02)
    zeta[0], zeta[2], zeta[4] = 0.005, 0.05, 0.0
    freq, ratio = _exudyn_damped_modes(beam_body, zeta, fix_frame)
    assert freq.size >= beam_body.n_modes
    for i, z in enumerate(zeta):
        # the undamped frequency |lambda| of each mode is the body's mode frequency
        j = int(np.argmin(np.abs(freq - beam_body.frequencies_hz[i]) + np.abs(ratio - z)))
        assert freq[j] == pytest.approx(beam_body.frequencies_hz[i], rel=1e-6)
        assert abs(ratio[j] - z) < 1e-4, f"mode {i + 1}: set {z:.4f}, got {ratio[j]:.6f}"


# ---------------------------------------------------------------- bad input


def test_missing_and_unreadable_mesh_files(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        load_mesh(tmp_path / "nope.vol.gz")
    bad = tmp_path / "bad.vol"
    bad.write_text("this is not a netgen mesh\n")
    with pytest.raises(InputError, match="could not be read|holds no volume elements"):
        load_mesh(bad)
    other = tmp_path / "mesh.stl"
    other.write_text("solid x\nendsolid x\n")
    with pytest.raises(InputError, match="expected a Netgen"):
        load_mesh(other)


def test_interface_selecting_no_nodes(beam_models):
    with pytest.raises(InputError, match="selects no nodes"):
        interface_from_boundary(beam_models[0.04], "no_such_face")


def test_overlapping_interfaces_rejected(beam_models):
    model = beam_models[0.04]
    clamp = interface_from_boundary(model, "clamp")
    again = interface_from_boundary(model, "clamp", name="clamp_again")
    with pytest.raises(InputError, match="overlap"):
        craig_bampton(model, [clamp, again])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"youngs_modulus_pa": 0.0}, "youngs_modulus_pa"),
        ({"youngs_modulus_pa": -1.0}, "youngs_modulus_pa"),
        ({"density_kg_m3": 0.0}, "density_kg_m3"),
        ({"poisson_ratio": 0.5}, "poisson_ratio"),
        ({"density_kg_m3": float("nan")}, "density_kg_m3"),
    ],
)
def test_non_positive_material_constants(kwargs, match):
    values = {"name": "x", "youngs_modulus_pa": 1e9, "poisson_ratio": 0.3, "density_kg_m3": 1000.0}
    values.update(kwargs)
    with pytest.raises(InputError, match=match):
        Material(**values)


def test_unknown_material_and_negative_added_mass():
    with pytest.raises(InputError, match="unknown"):
        PartMaterial("r", "unobtainium")
    with pytest.raises(InputError, match="added_mass_kg"):
        PartMaterial("r", "steel", added_mass_kg=-1.0)


@pytest.mark.parametrize("bad", [-0.01, 1.0, 1.5, float("nan")])
def test_damping_ratio_outside_unit_interval(bad):
    with pytest.raises(InputError, match=r"\[0, 1\)"):
        modal_damping_matrix(np.array([10.0, 20.0]), [0.02, bad])


def test_damping_ratio_count_mismatch():
    with pytest.raises(InputError, match="one ratio per mode"):
        modal_damping_matrix(np.array([10.0, 20.0, 30.0]), [0.02, 0.02])
