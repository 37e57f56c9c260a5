"""Catalogue entries of ``physics.entries_more``: each leaves the signature its docstring states.

Small models: the mini frame (Model 1) and a mini Model 3 (mini frame with six interface pads,
two box tanks, two brackets, the left one on a rubber pad; ``rig_fixtures.mini_model3_bodies``).
References are physics, not earlier output: the first-order (Rayleigh) frequency drop of a
compliant joint from the rigid joint's reaction forces, the tuned slosh frequency and
damping, the Jenkins element's dissipation ``4 F (a - F / k)``, the cubic law's odd
harmonics growing with the cube of the level, equal damping matrices by two routes.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.physics import CATALOGUE, entry

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, MODEL3_SENSORS, mini_bodies, mini_model3_bodies  # noqa: E402

TWO_PI = 2 * math.pi
RATE_HZ = 1000.0
NEW = ("joint_stiffness", "joint_friction", "bushing_stiffening", "sloshing", "modal_damping", "sensor_gain",
       "bushing_stiffness", "rear_support_compliance", "tank_wall_mode", "tuned_mass_damper")


@pytest.fixture(scope="module", autouse=True)
def _one_blas_thread():
    """Small dense matrices (n ~ 90) in long Python loops: a multithreaded BLAS on a shared 2-core
    machine made this file ~10x slower in wall time (113 s vs 10 s measured); restored afterwards."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - then only slower
        yield
        return
    with threadpool_limits(limits=1):
        yield


@pytest.fixture(scope="module")
def bodies1():
    pytest.importorskip("exudyn")
    return mini_bodies()


@pytest.fixture(scope="module")
def bodies3():
    pytest.importorskip("exudyn")
    return mini_model3_bodies()


def _model1(bodies, damping="constant-2"):
    from exudyn_study.model import build_model_from_bodies

    return build_model_from_bodies(bodies, 1, damping=damping, sensors=FRAME_SENSORS, exudyn_mesh="used")


def _model3(bodies, damping="constant-2"):
    from exudyn_study.model import build_model_from_bodies

    return build_model_from_bodies(bodies, 3, damping=damping, sensors=MODEL3_SENSORS, exudyn_mesh="used")


@pytest.fixture(scope="module")
def nominal3(bodies3):
    from exudyn_study.model import linearise

    model = _model3(bodies3)
    return model, linearise(model)


def _undamped(lin):
    """Undamped frequencies (Hz) and mass-normalised shapes in the projected coordinates."""
    import scipy.linalg as sla

    w2, phi = sla.eigh(lin.stiffness, lin.mass)
    return np.sqrt(np.maximum(w2, 0.0)) / TWO_PI, phi


def _sine(freq_hz, amplitude_m, seconds, ramp_s=0.3, smooth=False):
    t = np.arange(int(round(seconds * RATE_HZ))) / RATE_HZ
    if smooth:  # cosine ramp: excites the lightly damped modes less
        envelope = np.where(t < ramp_s, 0.5 * (1.0 - np.cos(math.pi * t / ramp_s)), 1.0)
    else:
        envelope = np.minimum(t / ramp_s, 1.0) ** 2
    return amplitude_m * np.sin(TWO_PI * freq_hz * t) * envelope


def _run(model, lin, gather, samples, laws=None, substeps=8):
    """(sensor accelerations, element displacements) of linear model + the model's local elements."""
    from exudyn_study.linear.nonlinear import simulate_local_nonlinear

    model.drive.set_signal(samples, RATE_HZ)
    laws = [el.law for el in model.local_nonlinearities] if laws is None else laws
    return simulate_local_nonlinear(lin, model.drive, gather, laws, substeps=substeps, return_deltas=True)


def _harmonic(x, freq_hz, cycles_from_end):
    """Complex amplitude of ``x`` at ``freq_hz`` over the last whole ``cycles_from_end`` cycles."""
    n = int(round(cycles_from_end * RATE_HZ / freq_hz))
    seg = x[..., -n:]
    t = np.arange(n) / RATE_HZ
    return 2.0 / n * seg @ np.exp(-1j * TWO_PI * freq_hz * t)


def _hann_harmonic(x, freq_hz, n):
    """Amplitude of ``x`` at ``freq_hz`` over its last ``n`` samples (Hann window: little leakage from the
    slowly decaying free vibration of the ~8 Hz bracket modes)."""
    w = np.hanning(n)
    t = np.arange(n) / RATE_HZ
    return 2.0 / w.sum() * (x[-n:] * w) @ np.exp(-1j * TWO_PI * freq_hz * t)


# --------------------------------------------------------------------------------------- registry, bad input
def test_new_entries_are_registered_with_physics_and_signature():
    for name in NEW:
        e = CATALOGUE[name]
        assert "Physics:" in e.doc and "Signature:" in e.doc
        assert e.locations
        for p in e.parameters:
            assert p.lower <= p.default <= p.upper and p.unit


def test_bounds_and_unknown_parameters():
    with pytest.raises(InputError, match=r"parameter gain = 3 1; expected a value in \[0.5, 2\] 1"):
        entry("sensor_gain").resolve(gain=3)
    with pytest.raises(InputError, match=r"parameter factor = 0.01 1; expected a value in \[0.1, 10\]"):
        entry("modal_damping").resolve(factor=0.01)
    with pytest.raises(InputError, match=r"parameter slosh_frequency_hz = 50 Hz"):
        entry("sloshing").resolve(slosh_frequency_hz=50)
    with pytest.raises(InputError, match=r"tank_wall_mode: parameter wall_damping_ratio = 1.5 1"):
        entry("tank_wall_mode").resolve(wall_damping_ratio=1.5)
    with pytest.raises(InputError, match=r"unknown parameter\(s\) \['k'\]"):
        entry("joint_stiffness").resolve(k=1.0)
    with pytest.raises(InputError, match=r"parameter slip_force_n = -1 N"):
        entry("joint_friction").resolve(slip_force_n=-1)


def test_wrong_variant_and_unknown_locations(bodies1, bodies3):
    m1 = _model1(bodies1)
    for name in ("joint_stiffness", "joint_friction"):
        with pytest.raises(InputError, match=rf"{name}: model 1 .* no separate bolted joints; use model 3"):
            entry(name).apply(m1, "tank_left.tank_left_front")
    with pytest.raises(InputError, match=r"no body of this model has the rubber region 'bracket_left_rubber"):
        entry("bushing_stiffening").apply(m1)  # the mini frame has no brackets
    with pytest.raises(InputError, match=r"sloshing: no body of this model carries 'tank_left'"):
        entry("sloshing").apply(m1, "tank_left")
    with pytest.raises(InputError, match=r"tank_wall_mode: no body of this model carries 'tank_left'"):
        entry("tank_wall_mode").apply(m1, "tank_left")
    with pytest.raises(InputError, match=r"sensor_gain: location 'NOPE'; expected a sensor of the model, "
                                         r"one of \['ARFMZ'"):
        entry("sensor_gain").apply(m1, "NOPE")
    with pytest.raises(InputError, match=r"modal_damping: location 'tank'; expected a flexible body .* "
                                         r"\['chassis', 'rear_foundation'\]"):
        entry("modal_damping").apply(m1, "tank")
    m3 = _model3(bodies3)
    with pytest.raises(InputError, match=r"joint_stiffness: location 'tank_left_middle'; expected a "
                                         r"component joint of model 3, one of \['bracket_left.bracket_left'"):
        entry("joint_stiffness").apply(m3, "tank_left_middle")
    with pytest.raises(InputError, match=r"location 'tank_middle'; expected one of "
                                         r"\['tank_left', 'tank_right'\]"):
        entry("sloshing").apply(m3, "tank_middle")
    with pytest.raises(InputError, match=r"tank_wall_mode: location 'tank_middle'; expected one of "
                                         r"\['tank_left', 'tank_right'\]"):
        entry("tank_wall_mode").apply(m3, "tank_middle")
    with pytest.raises(InputError, match=r"location 'bracket_right'; expected None or 'bracket_left'"):
        entry("bushing_stiffening").apply(m3, "bracket_right")
    with pytest.raises(InputError, match=r"min_frequency_hz = 50 Hz above max_frequency_hz = 10 Hz"):
        entry("modal_damping").apply(m3, "frame", min_frequency_hz=50, max_frequency_hz=10)
    assert entry("joint_stiffness").apply(m3, "bracket_left").location == "bracket_left.bracket_left"


def test_entries_needing_mesh_nodes_refuse_the_constant_matrix_element(bodies3):
    """The constant-matrix element has no mesh nodes and no reduced damping matrix: a clear error."""
    from exudyn_study.model import build_model_from_bodies

    m3 = build_model_from_bodies(bodies3, 3, damping="constant-2", sensors=MODEL3_SENSORS,
                                 element="matrix")
    with pytest.raises(InputError, match=r"body 'tank_left' is a constant-matrix element "
                                         r"\(element='matrix'\), "
                                         r"which has no markers on mesh nodes: build the model with "
                                         r"element='superelement'"):
        entry("sloshing").apply(m3, "tank_left")
    with pytest.raises(InputError,
                       match=r"body 'frame' is a constant-matrix element .* no dampingMatrixReduced"):
        entry("modal_damping").apply(m3, "frame", factor=2.0)


# --------------------------------------------------------------------------------------- joint_stiffness
def _joint_reactions(model, lin, joint, phi):
    """Force/moment the fixed ``joint`` carries in each mass-normalised undamped mode, shape (6, n_modes).

    From the unconstrained linearised equations: ``(K - w^2 M) q = -J lambda`` for ``q = N^T phi``.
    """
    m_full, k_full, _, jac, _ = model.mbs.ComputeLinearizedSystem(
        returnConstraintJacobian=True, returnConstraintNullspace=True, autoAssemble=False)
    m_full, k_full, jac = (np.asarray(a, dtype=float) for a in (m_full, k_full, jac))
    used = np.flatnonzero(np.any(jac != 0.0, axis=0))
    cols = np.asarray(model.mbs.systemData.GetObjectLTGAE(joint), dtype=int)
    q = lin.nullspace.T @ phi
    w2 = np.einsum("im,ij,jm->m", phi, lin.stiffness, phi)
    residual = k_full @ q - m_full @ q * w2
    lam = np.linalg.lstsq(jac[:, used], -residual, rcond=None)[0]
    return lam[np.searchsorted(used, cols)]


def test_joint_stiffness_lowers_the_modes_that_load_the_joint_by_the_rayleigh_estimate(bodies3, nominal3):
    """d(w^2) = -sum lambda_j^2 / k_j (first order in 1/k), frame-only modes do not move."""
    from exudyn_study.model import linearise

    model0, lin0 = nominal3
    k_t, k_r = 2e10, 2e8  # stiff: shifts of ~0.1 %, where first order holds (at 2e9/2e7 the nearly
    # degenerate left/right tank modes at 30.7/31.1 Hz mix and only their sum follows the estimate)
    f0, phi0 = _undamped(lin0)
    w0 = (TWO_PI * f0) ** 2
    lam = _joint_reactions(model0, lin0, model0.joints["tank_left.tank_left_front"], phi0)
    d_w2 = np.sum(lam[:3] ** 2, axis=0) / k_t + np.sum(lam[3:] ** 2, axis=0) / k_r
    predicted = -d_w2 / np.maximum(w0, 1e-9)

    model = _model3(bodies3)
    applied = entry("joint_stiffness").apply(model, "tank_left_front", stiffness_n_per_m=k_t,
                                             rotational_stiffness_n_m_per_rad=k_r, damping_time_s=0.0)
    assert applied.location == "tank_left.tank_left_front"
    lin = linearise(model)
    assert lin.size == lin0.size + 6  # six released constraints
    f1 = _undamped(lin)[0][: f0.size]  # the joint's own modes lie far above
    band = (f0 > 1.0) & (f0 < 150.0)
    shift = (f1 / np.where(f0 > 0, f0, 1.0)) ** 2 - 1.0  # relative change of w^2
    assert np.all(shift[band] <= 1e-9)  # a compliant joint never stiffens
    big = band & (predicted < -2e-4)
    quiet = band & (predicted > -1e-5)  # modes that hardly load the joint (frame, other components)
    assert big.sum() >= 4 and quiet.sum() >= 5
    np.testing.assert_allclose(shift[band], predicted[band], rtol=0.1, atol=2e-6)


def _patch_motion(model, interface: str, n_q: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre, translation (3, n_q), rotation (3, n_q)) of a rigid interface patch per ODE2 coordinate: the
    least-squares rigid motion of its nodes, from the body's mode basis (not from Exudyn's connector)."""
    from exudyn_study.model.linearisation import body_displacement_map

    handle = model.interfaces[interface]
    body = model.bodies[handle.body].body
    i = body.interface_index(handle.name)
    nodes = np.asarray(body.interface_nodes[i], dtype=int)
    w = np.asarray(body.interface_weights[i], dtype=float)
    x = np.asarray(body.node_positions_m)[nodes]
    centre = (w[:, None] * x).sum(axis=0) / w.sum()
    r = x - centre
    rigid = np.zeros((nodes.size, 3, 6))  # u_i = u_c + theta x r_i = u_c - skew(r_i) theta
    rigid[:, :, :3] = np.eye(3)
    rigid[:, 0, 4], rigid[:, 0, 5] = r[:, 2], -r[:, 1]
    rigid[:, 1, 3], rigid[:, 1, 5] = -r[:, 2], r[:, 0]
    rigid[:, 2, 3], rigid[:, 2, 4] = r[:, 1], -r[:, 0]
    idx, mat = body_displacement_map(model, handle.body, nodes)
    motion = np.linalg.lstsq(rigid.reshape(-1, 6), mat, rcond=None)[0]
    out = np.zeros((6, n_q))
    out[:, idx] = motion
    return centre + np.asarray(model.bodies[handle.body].position_m), out[:3], out[3:]


def test_joint_stiffness_is_unloaded_at_the_reference_and_its_damper_adds_exactly_its_coefficient(bodies3):
    """The frame's and the component's patch centres lie apart (1 cm across the web on the chassis). The
    joint's spring is unloaded at the reference: its stiffness contribution ``K(2 k) - K(k)`` is symmetric
    positive semi-definite of rank 3 (a spring preloaded by ``k`` times the gap adds a non-symmetric
    geometric stiffness proportional to ``k``). Its translational damper ``c = t k`` adds exactly
    ``c B^T B`` to the linearised damping matrix, linear in ``t``, and its spring ``k B^T B`` to the
    stiffness; ``B`` is the relative translation of the two patch centres per admissible coordinate
    (the patches' least-squares rigid motion from the bodies' mode bases, in the constraints' null
    space)."""
    import dataclasses

    import exudyn as exu

    from exudyn_study.model import linearise

    k_t, k_r = 4e9, 5e5  # as stiff as the thesis's left tank mounts
    # the mini tank's patch touches the frame's: shift the tank 1 cm outboard as on the chassis (its
    # inertia terms are not updated: the mass matrix is not compared here)
    tank = bodies3["tank_left"]
    shift = np.array([0.0, 0.01, 0.0])
    body = dataclasses.replace(tank.body, node_positions_m=np.asarray(tank.body.node_positions_m) + shift,
                               interface_centers_m=np.asarray(tank.body.interface_centers_m) + shift)
    bodies = {**bodies3, "tank_left": dataclasses.replace(tank, body=body)}

    def matrices(k, tau):
        model = _model3(bodies)
        applied = entry("joint_stiffness").apply(model, "tank_left_front", stiffness_n_per_m=k,
                                                 rotational_stiffness_n_m_per_rad=k_r, damping_time_s=tau,
                                                 rotational_damping_factor=0.0)
        model.assemble()
        spring = applied.items["spring"]
        force = np.asarray(model.mbs.GetObjectOutput(spring, exu.OutputVariableType.ForceLocal))
        lin = linearise(model)
        return model, lin.stiffness, lin.damping, force, lin.nullspace

    model, k1, d0, force, null = matrices(k_t, 0.0)
    n_q = null.shape[1]
    p0, u0, _ = _patch_motion(model, "frame.tank_left_front", n_q)
    p1, u1, _ = _patch_motion(model, "tank_left.tank_left_front", n_q)
    gap = p1 - p0
    assert np.linalg.norm(gap) > 5e-3
    b = (u1 - u0) @ null.T  # the patch centres' relative translation
    assert np.abs(force).max() < 1e-6 * k_t * np.linalg.norm(gap)  # no preload (it would be k |gap| = 40 MN)

    spring = matrices(2.0 * k_t, 0.0)[1] - k1
    np.testing.assert_allclose(spring, k_t * b.T @ b, rtol=0, atol=1e-6 * np.abs(spring).max())

    for tau in (1e-5, 3e-5):
        damper = matrices(k_t, tau)[2] - d0
        expected = tau * k_t * b.T @ b
        np.testing.assert_allclose(damper, expected, rtol=0, atol=1e-6 * np.abs(expected).max())


def test_joint_stiffness_axis_factor_scales_only_that_axis_of_the_spring_and_its_damper(bodies3):
    """``stiffness_factor_z`` = f: the joint's spring is ``k (b_x^T b_x + b_y^T b_y + f b_z^T b_z)`` (``b_a``
    the patch centres' relative translation along global axis ``a`` per admissible coordinate), its damper
    ``t`` times that; the rotations keep theirs. So K(f) - K(1) = (f - 1) k b_z^T b_z exactly, and a soft
    vertical axis lowers the modes that load the joint vertically and leaves the ones that do not."""
    from exudyn_study.model import linearise

    k_t, k_r, tau = 2e7, 2e5, 2e-4

    def matrices(factor_z):
        model = _model3(bodies3)
        entry("joint_stiffness").apply(model, "tank_left_front", stiffness_n_per_m=k_t,
                                       rotational_stiffness_n_m_per_rad=k_r, damping_time_s=tau,
                                       stiffness_factor_z=factor_z)
        model.assemble()
        lin = linearise(model)
        return model, lin

    model, lin1 = matrices(1.0)
    n_q = lin1.nullspace.shape[1]
    _, u0, _ = _patch_motion(model, "frame.tank_left_front", n_q)
    _, u1, _ = _patch_motion(model, "tank_left.tank_left_front", n_q)
    b_z = ((u1 - u0) @ lin1.nullspace.T)[2:3]  # vertical relative translation
    _, lin_soft = matrices(0.1)
    expected = (0.1 - 1.0) * k_t * b_z.T @ b_z
    np.testing.assert_allclose(lin_soft.stiffness - lin1.stiffness, expected, rtol=0,
                               atol=1e-6 * np.abs(expected).max())
    np.testing.assert_allclose(lin_soft.damping - lin1.damping, tau * expected, rtol=0,
                               atol=1e-6 * tau * np.abs(expected).max())
    # the default factors are the isotropic joint
    default = _model3(bodies3)
    entry("joint_stiffness").apply(default, "tank_left_front", stiffness_n_per_m=k_t,
                                   rotational_stiffness_n_m_per_rad=k_r, damping_time_s=tau)
    default.assemble()
    np.testing.assert_array_equal(linearise(default).stiffness, lin1.stiffness)


def test_joint_stiffness_rotational_damping_factor_scales_the_damping_of_the_rocking_modes(bodies3):
    """C = t (K_t + f K_r): on an otherwise undamped model each mode's damping ratio is, to first order,
    ``zeta_t + f zeta_r`` (translation's and rotation's shares): f = 0, 1, 3 lie on one line per mode, and
    the default factor (1) is the joint damped alike in both."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    def zeta(factor):
        model = _model3(bodies3, damping=lambda f: np.zeros_like(np.asarray(f, dtype=float)))
        params = {"stiffness_n_per_m": 2e7, "rotational_stiffness_n_m_per_rad": 2e5, "damping_time_s": 2e-4}
        if factor is not None:
            params["rotational_damping_factor"] = factor
        entry("joint_stiffness").apply(model, "tank_left_front", **params)
        modes = system_modes(model, linearise(model), max_frequency_hz=150.0)
        return modes.frequency_hz, modes.damping_ratio

    f0, z0 = zeta(0.0)
    f1, z1 = zeta(1.0)
    f3, z3 = zeta(3.0)
    fd, zd = zeta(None)
    np.testing.assert_allclose(zd, z1, rtol=1e-12)  # the default: the joint's old behaviour
    np.testing.assert_allclose(f3, f0, rtol=2e-3)  # damping only: the frequencies stay (to O(zeta^2))
    damped = z1 > 1e-4
    assert damped.sum() >= 3
    np.testing.assert_allclose(z3[damped], z0[damped] + 3.0 * (z1 - z0)[damped], rtol=0.02)
    rocking = damped & (z1 - z0 > 0.5 * z1)  # modes damped mostly by the joint's rotation
    shearing = damped & (z1 - z0 < 0.1 * z1)  # ... and by its translation: the factor leaves them
    assert rocking.any() and shearing.any()
    assert np.all(z3[rocking] > 2.0 * z1[rocking])
    np.testing.assert_allclose(z3[shearing], z1[shearing], rtol=0.2)


# --------------------------------------------------------------------------------------- joint_friction
def test_joint_friction_is_the_stiff_joint_below_slip_and_dissipates_4f_a_above(bodies3):
    from exudyn_study.linear.nonlinear import JenkinsFriction, gather_vectors
    from exudyn_study.linear.response import frf_linear, simulate_linear
    from exudyn_study.model import linearise

    k, f_slip = 5e7, 3e3
    model = _model3(bodies3)
    entry("joint_friction").apply(model, "tank_left.tank_left_front", stuck_stiffness_n_per_m=k,
                                  slip_force_n=f_slip)
    # the web's normal is y: x and z slip, y and the rotations stay rigid
    assert [el.name.rsplit(":", 1)[1] for el in model.local_nonlinearities] == ["x", "z"]
    lin = linearise(model)
    i = list(lin.sensor_names).index("ATVBZ")
    f = np.arange(25.0, 35.0, 0.01)
    f_tank = float(f[np.argmax(np.abs(frf_linear(lin, f)[i, 0]))])  # the left tank's vertical mode, which
    assert 28.0 < f_tank < 33.0  # shears the joint on the web (z)
    gather = gather_vectors(model)

    low = _sine(f_tank, 5e-6, 1.0)  # joint force ~ 600 N < slip
    acc, deltas = _run(model, lin, gather, low)
    assert np.max(np.abs(k * deltas)) < f_slip
    model.drive.set_signal(low, RATE_HZ)
    exact = simulate_linear(lin, model.drive)
    assert np.max(np.abs(acc - exact)) < 1e-9 * np.max(np.abs(exact))

    high = 20.0 * low  # ~ 4 x the slip force if it stuck
    acc_hi, d_hi = _run(model, lin, gather, high)
    model.drive.set_signal(high, RATE_HZ)
    sticking = np.abs(_harmonic(simulate_linear(lin, model.drive)[i], f_tank, 10))
    slipping = np.abs(_harmonic(acc_hi[i], f_tank, 10))
    assert slipping < 0.8 * sticking  # friction damping flattens the resonance
    # energy per cycle of the z element over the last cycle (replay its law on the simulated slip)
    n = int(round(RATE_HZ / f_tank))
    dz = d_hi[1, -(3 * n):]
    law = JenkinsFriction(k, f_slip)
    state, force = law.initial_state(), []
    for d in dz:
        r, state = law.residual(d, 0.0, state)
        force.append(k * d + r)
    force = np.array(force)[-n - 1:]
    work = float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(dz[-n - 1:])))
    a = 0.5 * (dz[-n - 1:].max() - dz[-n - 1:].min())
    assert a > 2 * f_slip / k
    assert work == pytest.approx(4 * f_slip * (a - f_slip / k), rel=0.1)
    # below the stuck resonance the slipping joint responds relatively more: the resonance moved down
    f_below = 0.95 * f_tank
    acc_b, _ = _run(model, lin, gather, _sine(f_below, 20 * 5e-6, 1.0))
    ratio_hi = np.abs(_harmonic(acc_b[i], f_below, 10)) / slipping
    h = np.abs(frf_linear(lin, [f_below, f_tank])[i, 0])
    assert ratio_hi > 1.2 * h[0] / h[1]


# --------------------------------------------------------------------------------------- bushing_stiffening
def test_bushing_stiffening_adds_odd_harmonics_growing_with_the_cube_of_the_level(bodies3):
    from exudyn_study.linear.nonlinear import CubicStiffening, gather_vectors
    from exudyn_study.model import linearise

    k3 = 5e12  # N/m^3: 3/4 k3 a^2 ~ 2 % of the pad's shear stiffness at the higher level (weakly nonlinear)
    model = _model3(bodies3)
    applied = entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=k3)
    assert applied.location == "bracket_left"
    assert [el.direction.tolist() for el in model.local_nonlinearities] == [[0, 0, 1], [1, 0, 0]]
    lin = linearise(model)
    gather = gather_vectors(model)
    i = list(lin.sensor_names).index("ASVZ")
    f0, seconds, ramp = 5.0, 3.0, 1.0  # below the left bracket's modes (~8 Hz, damping ~0.1 %)
    n = int(round((seconds - ramp) * RATE_HZ))
    out = {}
    for level in (1e-3, 2e-3):
        drive = _sine(f0, level, seconds, ramp, smooth=True)
        acc, d = _run(model, lin, gather, drive, substeps=4)
        acc_lin, d_lin = _run(model, lin, gather, drive, [CubicStiffening(0.0)] * 2, substeps=1)  # exact
        nl = acc[i] - acc_lin[i]  # what the cubic adds (the linear transients cancel)
        out[level] = {h: np.abs(_hann_harmonic(nl, h * f0, n)) for h in (1, 2, 3)}
        out[level]["fund"] = np.abs(_hann_harmonic(acc[i], f0, n))
        out[level]["delta"] = (np.abs(_hann_harmonic(d[0], f0, n)), np.abs(_hann_harmonic(d_lin[0], f0, n)))
    lo, hi = out[1e-3], out[2e-3]
    assert hi[3] > 2e-3 * hi["fund"]  # a visible third harmonic at the bracket
    # cubic: the third harmonic grows as the cube of the pad's motion (2^3 = 8 for twice the level, a little
    # less because the hardening pad moves less: measured 7.32 for a motion ratio 1.963, 1.963^3 = 7.57)
    motion = hi["delta"][0] / lo["delta"][0]
    assert 1.9 < motion < 2.0
    assert hi[3] / lo[3] == pytest.approx(motion**3, rel=0.06)
    assert hi[2] < 0.05 * hi[3] and lo[2] < 0.05 * lo[3]  # no even harmonics
    # hardening below resonance: less relative motion across the pad than with the linear rubber
    d_nl, d_lin = hi["delta"]
    assert d_nl < d_lin * (1 - 2e-3)
    assert lo["delta"][0] / lo["delta"][1] > d_nl / d_lin  # and the more so at the higher level


def _pad_normal(model) -> np.ndarray:
    from exudyn_study.physics.rubber import rubber_body

    body = model.bodies[rubber_body(model)].body
    x = np.asarray(body.node_positions_m)[np.asarray(body.region_nodes["bracket_left_rubber"])]
    return np.eye(3)[int(np.argmin(np.ptp(x, axis=0)))]


def test_bushing_compression_term_is_off_by_default_and_adds_four_normal_elements(bodies3):
    """The compression term: four cubic elements along the pad's normal, one per quadrant of the pad."""
    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=1e12)
    assert [el.name for el in model.local_nonlinearities] == ["bushing_stiffening:z", "bushing_stiffening:x"]
    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=1e12)
    elements = model.local_nonlinearities
    assert [el.name for el in elements] == [f"bushing_stiffening:compression{q}" for q in range(4)]
    normal = _pad_normal(model)
    for el in elements:
        assert np.allclose(el.direction, normal) and el.law.cubic_stiffness_n_per_m3 == 1e12
    assert len({el.marker_a for el in elements}) == 4 and len({el.marker_b for el in elements}) == 4


def test_bushing_compression_a_tilt_of_the_bracket_compresses_two_quadrants_and_opens_two(bodies3):
    """The bracket's mode that tilts the pad most: its quadrant deltas have both signs and are much larger
    than their mean (the pad's normal translation), so the compression term hardens the rocking; the mode
    that compresses the pad most (the bracket moving along the normal) has all four of one sign."""
    import scipy.linalg as sla

    from exudyn_study.linear.nonlinear import gather_vectors
    from exudyn_study.model import linearise

    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=1e12)
    lin = linearise(model)
    g = gather_vectors(model) @ lin.nullspace.T  # (4, n): quadrant compression per z
    f, phi = _undamped(lin)
    w2 = (TWO_PI * f) ** 2
    band = np.flatnonzero((f > 1.0) & (f < 200.0))
    d_modes = g @ phi[:, band]  # (4, n_band)
    squeeze = band[int(np.argmax(np.abs(d_modes.mean(axis=0))))]
    d = g @ phi[:, squeeze]
    assert np.all(d > 0) or np.all(d < 0), d
    k = band[int(np.argmax(np.linalg.norm(d_modes - d_modes.mean(axis=0), axis=0)))]
    d = g @ phi[:, k]
    assert k != squeeze and d.min() < 0.0 < d.max(), d
    assert abs(d.mean()) < 0.5 * np.abs(d).max(), d
    # first-order energy: a linear spring kt on each quadrant raises omega^2 by kt |G phi|^2
    kt = 1e-3 * w2[k] / np.sum(d**2)
    w2_spring = sla.eigh(lin.stiffness + kt * g.T @ g, lin.mass, eigvals_only=True)
    assert w2_spring[k] - w2[k] == pytest.approx(kt * np.sum(d**2), rel=0.02)


def test_bushing_compression_hardening_gives_odd_harmonics_growing_with_the_cube(bodies3):
    from exudyn_study.linear.nonlinear import CubicStiffening, gather_vectors
    from exudyn_study.model import linearise

    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=2e13)
    lin = linearise(model)
    gather = gather_vectors(model)
    i = list(lin.sensor_names).index("ASVZ")
    f0, seconds, ramp = 5.0, 3.0, 1.0
    n = int(round((seconds - ramp) * RATE_HZ))
    out = {}
    for level in (1e-3, 2e-3):
        drive = _sine(f0, level, seconds, ramp, smooth=True)
        acc, d = _run(model, lin, gather, drive)
        acc_lin, _ = _run(model, lin, gather, drive, [CubicStiffening(0.0)] * 4)
        nl = acc[i] - acc_lin[i]
        out[level] = {h: np.abs(_hann_harmonic(nl, h * f0, n)) for h in (1, 2, 3)}
        out[level]["compression"] = max(np.abs(_hann_harmonic(dq, f0, n)) for dq in d)
        out[level]["fund"] = np.abs(_hann_harmonic(acc[i], f0, n))
    lo, hi = out[1e-3], out[2e-3]
    assert hi[3] > 1e-3 * hi["fund"], hi  # a visible third harmonic at the bracket
    motion = hi["compression"] / lo["compression"]
    assert 1.8 < motion < 2.05
    assert hi[3] / lo[3] == pytest.approx(motion**3, rel=0.1)
    assert hi[2] < 0.05 * hi[3] and lo[2] < 0.05 * lo[3]  # no even harmonics


# --------------------------------------------------------------------------------------- sloshing
def _tank_resonator_mass_kept(bodies3, lin0, name, **params):
    """(model, linearised system) with entry ``name`` in the left tank; checks the total mass is kept (the
    rigid drive motion carries exactly the nominal mass: the resonator's mass is taken off the tank)."""
    from exudyn_study.model import linearise

    model = _model3(bodies3)
    entry(name).apply(model, "tank_left", **params)
    lin = linearise(model)
    r0, r = lin0.drive_shape, lin.drive_shape
    assert r @ lin.full_mass @ r == pytest.approx(r0 @ lin0.full_mass @ r0, rel=1e-9)
    return model, lin


def test_sloshing_adds_the_tuned_horizontal_modes_and_keeps_mass_and_vertical_response(bodies3, nominal3):
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.model.linearisation import system_modes

    model0, lin0 = nominal3
    f_s, zeta_s, m_s = 3.0, 0.05, 80.0
    model, lin = _tank_resonator_mass_kept(bodies3, lin0, "sloshing", slosh_frequency_hz=f_s,
                                           slosh_damping_ratio=zeta_s, slosh_mass_kg=m_s)
    modes = system_modes(model, lin, max_frequency_hz=6.0)
    f_u0, phi_u0 = _undamped(lin0)
    assert not np.any((f_u0 > 0.5) & (f_u0 < 6.0))
    # two new modes (x and y) at the tuned frequency and damping (the tank is far stiffer)
    assert modes.frequency_hz.size == 2
    np.testing.assert_allclose(modes.frequency_hz, f_s, rtol=0.01)
    np.testing.assert_allclose(modes.damping_ratio, zeta_s, rtol=0.03)
    f = np.arange(2.0, 60.0, 0.25)
    h0, h1 = np.abs(frf_linear(lin0, f)[:, 0]), np.abs(frf_linear(lin, f)[:, 0])
    names = list(lin.sensor_names)
    # the slosh modes move the left tank horizontally, one along x and one along y (the vertical drive
    # hardly excites them: they show in the shapes, not in the drive FRFs)
    assert sorted(d["tank_left"] for d in modes.direction) == ["X", "Y"]
    jx = [d["tank_left"] for d in modes.direction].index("X")
    shape = np.abs(modes.shapes[:, jx])
    for s in ("ATVBX", "ATVFX"):  # the left tank's x sensors see it, its z sensor hardly
        assert shape[names.index(s)] > 5 * shape[names.index("ATVBZ")]
    for s in ("ATVBZ", "ATHBZ", "ARFVZ"):  # vertical response unchanged, up to the coupling with the
        # horizontal modes the slosh mass leaves (measured at most 4.9 %, near 41 Hz)
        np.testing.assert_allclose(h1[names.index(s)], h0[names.index(s)], rtol=0.08)
    # vertical tank modes (the left tank's z sensor dominates its x sensors) do not move
    shape0 = np.abs(lin0.sensor_output @ phi_u0)
    vertical = (shape0[names.index("ATVBZ")] > 5 * np.maximum(shape0[names.index("ATVBX")],
                                                                shape0[names.index("ATVFX")])) & (f_u0 > 6.0)
    f_u1 = _undamped(lin)[0]
    assert vertical.sum() >= 2
    for fz in f_u0[vertical & (f_u0 < 120.0)]:
        assert np.min(np.abs(f_u1 - fz) / fz) < 2e-3


# --------------------------------------------------------------------------------------- tank_wall_mode
def test_tank_wall_mode_adds_one_tuned_lateral_mode_and_keeps_mass_and_the_tanks_x_and_z(bodies3, nominal3):
    """Tuned below the structure (5 Hz, 1 kg; the mini Model 3's lowest mode is at 8 Hz) the wall mode is the
    wall mass's own SDOF: one new mode at the tuning with its damping ratio, moving the tank across (y). The
    drive carries the nominal mass; modes that move the left tank along x or z keep their frequency, those
    across rise or stay (above the tuning the tank is lighter across by the wall mass)."""
    from exudyn_study.model.linearisation import system_modes

    model0, lin0 = nominal3
    f_w, zeta_w, m_w = 5.0, 0.05, 1.0
    model, lin = _tank_resonator_mass_kept(bodies3, lin0, "tank_wall_mode", wall_frequency_hz=f_w,
                                           wall_damping_ratio=zeta_w, wall_mass_kg=m_w)
    nominal = system_modes(model0, lin0, max_frequency_hz=45.0)
    modes = system_modes(model, lin, max_frequency_hz=45.0)
    assert modes.frequency_hz.size == nominal.frequency_hz.size + 1
    low = modes.frequency_hz < 6.0
    assert low.sum() == 1 and not np.any(nominal.frequency_hz < 6.0)
    j = int(np.flatnonzero(low)[0])
    assert modes.frequency_hz[j] == pytest.approx(f_w, rel=0.01)
    assert modes.damping_ratio[j] == pytest.approx(zeta_w, rel=0.03)
    assert modes.direction[j]["tank_left"] == "Y"
    f1 = _undamped(lin)[0]
    across = 0
    for f0, d in zip(nominal.frequency_hz, nominal.direction, strict=True):
        if d["tank_left"] in ("X", "Z"):
            assert np.min(np.abs(f1 - f0) / f0) < 1e-4, f"{f0:.2f} Hz ({d['tank_left']}) moved"
        else:
            k = np.argmin(np.abs(f1 - f0))
            assert f1[k] >= f0 * (1.0 - 1e-6)
            across += f1[k] > f0 * (1.0 + 1e-4)
    assert across >= 1


def test_tank_wall_mode_tuned_to_a_lateral_mode_damps_it_and_leaves_the_others(bodies3, nominal3):
    """Tuned to the mini Model 3's 21.9 Hz mode (frame and tanks across) the wall mode is a tuned-mass
    damper: that mode gains damping and the wall's own heavily damped mode appears beside it; the modes that
    move the left tank along x or z keep their frequency and damping."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    model0, lin0 = nominal3
    nominal = system_modes(model0, lin0, max_frequency_hz=45.0)
    lateral = [i for i, (f, d) in enumerate(zip(nominal.frequency_hz, nominal.direction, strict=True))
               if 15.0 < f < 30.0 and d["tank_left"] == "Y"]
    assert len(lateral) == 1
    f_t, zeta_t = nominal.frequency_hz[lateral[0]], nominal.damping_ratio[lateral[0]]
    model = _model3(bodies3)
    entry("tank_wall_mode").apply(model, "tank_left", wall_frequency_hz=f_t, wall_damping_ratio=0.1,
                                  wall_mass_kg=5.0)
    modes = system_modes(model, linearise(model), max_frequency_hz=45.0)
    near = np.abs(modes.frequency_hz - f_t) < 0.05 * f_t
    assert near.sum() == 2  # the mode and the wall's own
    zetas = np.sort(modes.damping_ratio[near])
    assert zetas[0] > 1.3 * zeta_t  # the lateral mode damped (0.79 -> 1.13 % measured)
    assert zetas[1] > 0.05  # the wall's own mode, heavily damped (9.6 % measured)
    for f0, z0, d in zip(nominal.frequency_hz, nominal.damping_ratio, nominal.direction, strict=True):
        if d["tank_left"] in ("X", "Z"):
            k = np.argmin(np.abs(modes.frequency_hz - f0))
            assert modes.frequency_hz[k] == pytest.approx(f0, rel=1e-4)
            # (their tank's small lateral share: at most 0.7 % of their damping measured, 0.095 -> 0.096 %)
            assert modes.damping_ratio[k] == pytest.approx(z0, rel=0.02)


# --------------------------------------------------------------------------------------- modal_damping
def test_modal_damping_equals_the_scaled_damping_choice(bodies1):
    """factor x constant-2 on the chassis is constant-(2 x factor): identical linearised systems."""
    from exudyn_study.model import linearise

    model = _model1(bodies1)
    entry("modal_damping").apply(model, "chassis", factor=0.5)
    lin = linearise(model)
    ref = linearise(_model1(bodies1, damping={"chassis": "constant-1"}))
    assert np.max(np.abs(lin.damping - ref.damping)) < 1e-10 * np.max(np.abs(ref.damping))
    np.testing.assert_array_equal(lin.stiffness, ref.stiffness)
    np.testing.assert_array_equal(lin.mass, ref.mass)

    f_cut = 150.0  # a band: only chassis modes up to 150 Hz are scaled
    model = _model1(bodies1)
    entry("modal_damping").apply(model, "chassis", factor=3.0, max_frequency_hz=f_cut)
    ref = linearise(_model1(bodies1, damping={"chassis": lambda f: np.where(f <= f_cut, 0.06, 0.02)}))
    lin = linearise(model)
    assert np.max(np.abs(lin.damping - ref.damping)) < 1e-10 * np.max(np.abs(ref.damping))
    model = _model1(bodies1)  # applications compose
    entry("modal_damping").apply(model, "chassis", factor=3.0, max_frequency_hz=f_cut)
    entry("modal_damping").apply(model, "chassis", factor=1.5, min_frequency_hz=f_cut)
    ref = linearise(_model1(bodies1, damping={"chassis": lambda f: np.where(f <= f_cut, 0.06, 0.03)}))
    lin = linearise(model)
    assert np.max(np.abs(lin.damping - ref.damping)) < 1e-10 * np.max(np.abs(ref.damping))


def test_modal_damping_scales_the_damping_that_body_dissipates(bodies3, nominal3):
    """zeta_j -> zeta_j + (factor - 1) zeta_j,body (first order, light damping), frequencies kept."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    model0, lin0 = nominal3
    factor, body = 3.0, "bracket_right"
    f0, phi0 = _undamped(lin0)
    _, _, d_full, _, _ = model0.mbs.ComputeLinearizedSystem(
        returnConstraintJacobian=True, returnConstraintNullspace=True, autoAssemble=False)
    d_full = np.asarray(d_full, dtype=float)
    idx = np.asarray(model0.mbs.systemData.GetNodeLTGODE2(model0.bodies[body].modal_node), dtype=int)
    q = lin0.nullspace.T @ phi0
    w = TWO_PI * np.maximum(f0, 1e-9)
    zeta0 = np.einsum("im,ij,jm->m", q, d_full, q) / (2 * w)
    zeta_body = np.einsum("im,ij,jm->m", q[idx], d_full[np.ix_(idx, idx)], q[idx]) / (2 * w)
    predicted = zeta0 + (factor - 1.0) * zeta_body

    model = _model3(bodies3)
    entry("modal_damping").apply(model, body, factor=factor)
    lin = linearise(model)
    np.testing.assert_array_equal(_undamped(lin)[0], f0)  # stiffness and mass untouched
    modes = system_modes(model, lin, max_frequency_hz=120.0)
    band = (f0 > 1.0) & (f0 <= 120.0)
    assert modes.frequency_hz.size == band.sum()
    np.testing.assert_allclose(modes.frequency_hz, f0[band], rtol=2e-3)
    own = zeta_body[band] > 0.5 * zeta0[band]  # modes whose damping is mostly that body's
    other = zeta_body[band] < 1e-3 * zeta0[band]
    assert own.sum() >= 1 and other.sum() >= 3
    np.testing.assert_allclose(modes.damping_ratio, predicted[band], rtol=0.05)
    np.testing.assert_allclose(modes.damping_ratio[other], zeta0[band][other], rtol=0.01)


# --------------------------------------------------------------------------------------- sensor_gain
def test_sensor_gain_scales_one_channel_only(bodies1):
    from exudyn_study.model import linearise
    from exudyn_study.simulate import simulate

    model0 = _model1(bodies1)
    model = _model1(bodies1)
    applied = entry("sensor_gain").apply(model, "ARFVZ", gain=1.25)
    assert applied.items == {} and model.output_gains == {"ARFVZ": 1.25}
    entry("sensor_gain").apply(model, "ARFVZ", gain=0.8)  # a second error multiplies
    assert model.output_gains["ARFVZ"] == pytest.approx(1.0)
    entry("sensor_gain").apply(model, "ARFVZ", gain=1.25)
    rec0 = simulate(model0, duration_s=1.0, method="linear", rms_m=1e-4)
    rec = simulate(model, duration_s=1.0, method="linear", rms_m=1e-4)
    for ch0, ch in zip(rec0.channels, rec.channels, strict=True):
        gain = 1.25 if ch.name == "ARFVZ" else 1.0
        scale = np.max(np.abs(ch0.data))
        np.testing.assert_allclose(ch.data, gain * ch0.data, rtol=1e-12, atol=1e-12 * scale)
    lin0, lin = linearise(model0), linearise(model)
    np.testing.assert_array_equal(lin.stiffness, lin0.stiffness)
    np.testing.assert_array_equal(lin.sensor_map, lin0.sensor_map)


# --------------------------------------------------------------------------------------- bushing_stiffness
def _face_motion(model, lin, body, nodes, centre, phi):
    """Least-squares rigid motion (translation at ``centre``, rotation), shape (6, n_modes), of mesh ``nodes``
    in the modes ``phi``: ``u_i = t + theta x (x_i - centre)`` fitted to the nodes' displacements."""
    from exudyn_study.model.linearisation import body_displacement_map

    idx, mat = body_displacement_map(model, body, np.asarray(nodes))
    u = (mat @ (lin.nullspace.T @ phi)[idx]).reshape(len(nodes), 3, -1)
    r = np.asarray(model.bodies[body].body.node_positions_m)[nodes] - centre
    rows = []
    for ri in r:  # u_i = [I, -skew(r_i)] [t; theta]
        skew = np.array([[0.0, -ri[2], ri[1]], [ri[2], 0.0, -ri[0]], [-ri[1], ri[0], 0.0]])
        rows.append(np.hstack([np.eye(3), -skew]))
    a = np.vstack(rows)
    return np.linalg.lstsq(a, u.reshape(-1, phi.shape[1]), rcond=None)[0]


def test_bushing_stiffness_raises_the_bracket_modes_by_the_pad_springs_energy(bodies3, nominal3):
    """d(w^2) = delta^T K_pad delta (first order; delta the rigid-fit motion of the pad's outer face relative
    to its inner face in the mass-normalised mode), d(zeta) = tau delta^T K_pad delta / (2 w), other modes
    stay; ``K_pad`` from the bonded-block formulas: shear G A / t, compression E_c A / t."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes
    from exudyn_study.physics.rubber import pad_spring_matrix, rubber_pad

    model0, lin0 = nominal3
    pad = rubber_pad(model0.bodies["bracket_left"].body)
    # the mini pad: 0.10 x 0.02 x 0.10 m (x, y, z), normal y
    assert pad["normal"] == 1 and pad["thickness_m"] == pytest.approx(0.02, rel=1e-6)
    assert pad["area_m2"] == pytest.approx(0.01, rel=1e-6)
    g, e_c, tau = 2e4, 1e5, 1e-4  # small against the pad's own stiffness: first order holds
    k_pad = pad_spring_matrix(pad, g, e_c)
    assert k_pad[0, 0] == pytest.approx(g * 0.01 / 0.02) and k_pad[1, 1] == pytest.approx(e_c * 0.01 / 0.02)
    assert k_pad[3, 3] == pytest.approx(e_c * 0.01 * 0.1**2 / 12 / 0.02)  # rocking about x
    assert k_pad[4, 4] == pytest.approx(g * 0.01 * (0.1**2 + 0.1**2) / 12 / 0.02)  # torsion about y

    f0, phi0 = _undamped(lin0)
    rel = (_face_motion(model0, lin0, "bracket_left", pad["outer"], pad["centre_m"], phi0)
           - _face_motion(model0, lin0, "bracket_left", pad["inner"], pad["centre_m"], phi0))
    energy = np.einsum("im,ij,jm->m", rel, k_pad, rel)  # delta^T K delta per mass-normalised mode
    w0 = TWO_PI * np.maximum(f0, 1e-9)

    model = _model3(bodies3)
    applied = entry("bushing_stiffness").apply(model, shear_modulus_increase_pa=g,
                                               compression_modulus_increase_pa=e_c, damping_time_s=tau)
    assert applied.location == "bracket_left"
    lin = linearise(model)
    assert lin.size == lin0.size  # a spring: no coordinate added or removed
    f1 = _undamped(lin)[0]
    band = (f0 > 1.0) & (f0 < 150.0)
    shift = (f1 / np.where(f0 > 0, f0, 1.0)) ** 2 - 1.0
    predicted = energy / w0**2
    assert np.all(shift[band] >= -1e-9)  # a parallel spring never softens
    big = band & (predicted > 1e-3)
    quiet = band & (predicted < 1e-6)
    assert big.sum() >= 2 and quiet.sum() >= 5
    np.testing.assert_allclose(shift[big], predicted[big], rtol=0.1)
    np.testing.assert_allclose(shift[quiet], 0.0, atol=1e-5)

    # damping: on a model without any other damping, zeta = tau delta^T K delta / (2 w) in the modes that
    # strain the pad (the spring's share of the stiffness is small, so the modes are those of lin0)
    undamped3 = _model3(bodies3, damping=lambda f: np.zeros_like(np.asarray(f, dtype=float)))
    entry("bushing_stiffness").apply(undamped3, shear_modulus_increase_pa=g,
                                     compression_modulus_increase_pa=e_c, damping_time_s=1e-3)
    modes = system_modes(undamped3, linearise(undamped3), max_frequency_hz=150.0)
    for k in np.flatnonzero(big):
        j = int(np.argmin(np.abs(modes.frequency_hz - f1[k])))
        assert modes.damping_ratio[j] == pytest.approx(1e-3 * energy[k] / (2 * w0[k]), rel=0.15), f0[k]


def test_bushing_stiffness_rocking_factors_scale_the_rocking_springs_only(bodies3, nominal3):
    """The rocking factors multiply the bonded block's rocking stiffness about x and z (K[3, 3], K[5, 5]) and
    nothing else; the bracket modes then move by the energy of that spring (first order, as above)."""
    from exudyn_study.model import linearise
    from exudyn_study.physics.rubber import pad_spring_matrix, rubber_pad

    model0, lin0 = nominal3
    pad = rubber_pad(model0.bodies["bracket_left"].body)
    g, e_c, fx, fz = 5e3, 2.5e4, 0.3, 3.0  # small: first order holds with the larger z rocking
    k1 = pad_spring_matrix(pad, g, e_c)
    k = pad_spring_matrix(pad, g, e_c, (fx, 1.0, fz))
    np.testing.assert_allclose(np.diag(k), np.diag(k1) * [1, 1, 1, fx, 1, fz])
    f0, phi0 = _undamped(lin0)
    rel = (_face_motion(model0, lin0, "bracket_left", pad["outer"], pad["centre_m"], phi0)
           - _face_motion(model0, lin0, "bracket_left", pad["inner"], pad["centre_m"], phi0))
    predicted = np.einsum("im,ij,jm->m", rel, k, rel) / (TWO_PI * np.maximum(f0, 1e-9)) ** 2
    model = _model3(bodies3)
    entry("bushing_stiffness").apply(model, shear_modulus_increase_pa=g, compression_modulus_increase_pa=e_c,
                                     rocking_factor_about_x=fx, rocking_factor_about_z=fz)
    f1 = _undamped(linearise(model))[0]
    big = (f0 > 1.0) & (f0 < 150.0) & (predicted > 2.5e-4)
    assert big.sum() >= 2
    # 0.3: the face rotation fitted here and the rigid marker's (averaged nodes) differ for the deforming
    # face; that shows in the one mode that rocks the pad about z most (+28 % there, the others within 6 %)
    np.testing.assert_allclose((f1[big] / f0[big]) ** 2 - 1.0, predicted[big], rtol=0.3)
    assert np.median(np.abs(((f1[big] / f0[big]) ** 2 - 1.0) / predicted[big] - 1.0)) < 0.06


def test_bushing_stiffness_torsion_change_softens_the_pad_in_torsion_and_stays_positive(bodies3, nominal3):
    """``torsion_modulus_change_pa`` changes only the torsion about the pad's normal (K[4, 4] by
    change J / t); negative, the mode that twists the pad softens by that spring's energy (first order)
    and the negative spring gets no damper (a negative damper would drive it); a change that leaves the
    pad's torsion modulus (nominal rubber + increase + change) below 1 % of the nominal rubber's is
    refused."""
    from exudyn_study.bodies.materials import MATERIALS
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes
    from exudyn_study.physics.rubber import pad_spring_matrix, rubber_pad

    model0, lin0 = nominal3
    pad = rubber_pad(model0.bodies["bracket_left"].body)
    g, e_c, change, tau = 5e3, 2.5e4, -2e4, 1e-3
    k1 = pad_spring_matrix(pad, g, e_c)
    k = pad_spring_matrix(pad, g, e_c, torsion_modulus_change_pa=change)
    j_over_t = 0.01 * (0.1**2 + 0.1**2) / 12 / 0.02  # the mini pad's J / t (m^3)
    np.testing.assert_allclose(np.diag(k) - np.diag(k1), [0, 0, 0, 0, change * j_over_t, 0], atol=1e-9)
    assert k[4, 4] < 0
    f0, phi0 = _undamped(lin0)
    rel = (_face_motion(model0, lin0, "bracket_left", pad["outer"], pad["centre_m"], phi0)
           - _face_motion(model0, lin0, "bracket_left", pad["inner"], pad["centre_m"], phi0))
    predicted = np.einsum("im,ij,jm->m", rel, k, rel) / (TWO_PI * np.maximum(f0, 1e-9)) ** 2
    model = _model3(bodies3)
    applied = entry("bushing_stiffness").apply(model, shear_modulus_increase_pa=g,
                                               compression_modulus_increase_pa=e_c,
                                               torsion_modulus_change_pa=change, damping_time_s=tau)
    d = np.asarray(model.mbs.GetObject(applied.items["spring"])["damping"])
    np.testing.assert_allclose(np.diag(d), tau * np.maximum(np.diag(k), 0.0))
    f1 = _undamped(linearise(model))[0]
    # the mode that twists the pad (-0.54 % in w^2); a second one loses 0.04-0.05 %, where the face
    # rotation fitted here and the rigid marker's (averaged nodes) differ as in the rocking test above
    twist = (f0 > 1.0) & (f0 < 150.0) & (predicted < -1e-3)
    assert twist.sum() == 1
    np.testing.assert_allclose((f1[twist] / f0[twist]) ** 2 - 1.0, predicted[twist], rtol=0.1)
    modes = system_modes(model, linearise(model), max_frequency_hz=150.0)
    assert modes.damping_ratio.min() > 0

    g_rubber = MATERIALS["rubber"].lame_parameters[0]
    with pytest.raises(InputError, match=r"bushing_stiffness: torsion_modulus_change_pa = -4e\+06 Pa leaves "
                                         r"the pad a torsion modulus of .* expected above"):
        entry("bushing_stiffness").apply(_model3(bodies3), shear_modulus_increase_pa=0.0,
                                         torsion_modulus_change_pa=-4e6)
    entry("bushing_stiffness").apply(_model3(bodies3), shear_modulus_increase_pa=0.0,
                                     torsion_modulus_change_pa=-0.98 * g_rubber)  # 2 % left: accepted


def test_bushing_stiffness_needs_the_rubber_pad(bodies1, bodies3):
    with pytest.raises(InputError, match=r"bushing_stiffness: no body of this model has the rubber region"):
        entry("bushing_stiffness").apply(_model1(bodies1))
    with pytest.raises(InputError, match=r"bushing_stiffness: location 'bracket_right'; expected None or "
                                         r"'bracket_left'"):
        entry("bushing_stiffness").apply(_model3(bodies3), "bracket_right")
    with pytest.raises(InputError, match=r"parameter compression_modulus_increase_pa = -1 Pa"):
        entry("bushing_stiffness").resolve(compression_modulus_increase_pa=-1)


# ------------------------------------------------------------------------------- rear_support_compliance
def _with_rear(bodies1, damping, k_z, c_y, tau):
    model = _model1(bodies1, damping=damping)
    applied = entry("rear_support_compliance").apply(model, "rear_left", vertical_stiffness_n_per_m=k_z,
                                                     lateral_compliance_m_per_n=c_y, damping_time_s=tau)
    assert applied.location == "rear_left" and set(applied.items) == {"joint", "spring"}
    return model


def test_rear_support_compliance_lowers_the_modes_that_load_the_support_by_the_rayleigh_estimate(bodies1):
    """d(w^2) = -(lambda_z^2 / k_z + lambda_y^2 c_y) (first order; lambda the force of the rigid rear support
    in the mass-normalised mode, c_y the lateral compliance); modes that do not load it stay;
    zeta = t (lambda_z^2 / k_z + lambda_y^2 c_y) / (2 w) on an otherwise undamped model."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    undamped = lambda f: np.zeros_like(np.asarray(f, dtype=float))  # noqa: E731
    model0 = _model1(bodies1, damping=undamped)
    lin0 = linearise(model0)
    f0, phi0 = _undamped(lin0)
    w0 = TWO_PI * np.maximum(f0, 1e-9)
    lam = _joint_reactions(model0, lin0, model0.rig.joints["foundation_rear_left"], phi0)
    k_z, k_y, tau = 5e9, 2e10, 1e-4  # stiff: shifts below 0.1 %, where first order holds; tau omega << 1
    energy = lam[2] ** 2 / k_z + lam[1] ** 2 / k_y  # the springs' strain energy (x 2) per mode
    lin_x = linearise(_with_rear(bodies1, undamped, k_z, 0.0, tau))
    assert lin_x.size == lin0.size + 1  # zero lateral compliance: y stays a constraint
    predicted = -energy / w0**2

    model = _with_rear(bodies1, undamped, k_z, 1.0 / k_y, tau)
    lin = linearise(model)
    assert lin.size == lin0.size + 2  # two released constraints (y, z)
    f1 = _undamped(lin)[0][: f0.size]
    band = (f0 > 1.0) & (f0 < 150.0)
    shift = (f1 / np.where(f0 > 0, f0, 1.0)) ** 2 - 1.0
    assert np.all(shift[band] <= 1e-9)  # a compliant support never stiffens
    big = band & (predicted < -1e-4)  # vertical bending (52, 72, 127, 133 Hz) and a lateral mode (86 Hz)
    quiet = band & (predicted > -2e-6)
    assert big.sum() >= 3 and quiet.sum() >= 2
    assert np.any(big & (lam[1] ** 2 / k_y > 0.5 * energy))  # a mode swinging the frame's rear sideways
    np.testing.assert_allclose(shift[big], predicted[big], rtol=0.05)
    np.testing.assert_allclose(shift[quiet], 0.0, atol=5e-6)
    modes = system_modes(model, lin, max_frequency_hz=150.0)
    for j in np.flatnonzero(big):
        i = int(np.argmin(np.abs(modes.frequency_hz - f1[j])))
        assert modes.damping_ratio[i] == pytest.approx(tau * energy[j] / (2 * w0[j]), rel=0.1), f0[j]


def test_rear_support_compliance_locations():
    with pytest.raises(InputError, match=r"rear_support_compliance: location 'rear'; expected one of "
                                         r"\['rear_left', 'rear_right'\]"):
        entry("rear_support_compliance").apply(type("M", (), {"assembled": False})(), "rear")
    with pytest.raises(InputError, match=r"parameter vertical_stiffness_n_per_m = 10 N/m"):
        entry("rear_support_compliance").resolve(vertical_stiffness_n_per_m=10)


def test_model3_bushing_joints_are_unloaded_at_the_reference(bodies3):
    """Model 3's ``bushing=`` variant joins each component to the frame with a 6-DOF spring between the two
    patch centres, which lie apart (1 cm on the chassis; here the tank is shifted 1 cm). At the reference
    configuration the spring carries no force (before: ``k`` times the gap, 2e5 N at 2e7 N/m), and its
    translational stiffness ``K(2 k) - K(k)`` is symmetric (a preload adds a non-symmetric geometric
    stiffness)."""
    import dataclasses

    import exudyn as exu

    from exudyn_study.model import BushingParameters, build_model_from_bodies, linearise

    tank = bodies3["tank_left"]
    shift = np.array([0.0, 0.01, 0.0])
    body = dataclasses.replace(tank.body, node_positions_m=np.asarray(tank.body.node_positions_m) + shift,
                               interface_centers_m=np.asarray(tank.body.interface_centers_m) + shift)
    bodies = {**bodies3, "tank_left": dataclasses.replace(tank, body=body)}
    k_t = 2e7

    def build(k):
        model = build_model_from_bodies(bodies, 3, damping="constant-2", sensors=MODEL3_SENSORS,
                                        exudyn_mesh="used",
                                        bushing=BushingParameters(stiffness=(k, k, k, 2e5, 2e5, 2e5)))
        model.assemble()
        return model

    model = build(k_t)
    gap = (model.interfaces["tank_left.tank_left_front"].position_m
           - model.interfaces["frame.tank_left_front"].position_m)
    assert np.linalg.norm(gap) > 5e-3
    force = np.asarray(model.mbs.GetObjectOutput(model.joints["tank_left.tank_left_front"],
                                                 exu.OutputVariableType.ForceLocal))
    assert np.abs(force).max() < 1e-6 * k_t * np.linalg.norm(gap)
    spring = linearise(build(2.0 * k_t)).stiffness - linearise(model).stiffness
    np.testing.assert_allclose(spring, spring.T, rtol=0, atol=1e-9 * np.abs(spring).max())
    assert np.abs(spring).max() > 0.1 * k_t


def test_sloshing_damps_across_the_tank_by_its_lateral_factor(bodies3):
    """``lateral_damping_factor`` 3: the slosh mode along y has three times the damping ratio of the one
    along x (the tank is far stiffer than the slosh spring, so each slosh mode is the slosh mass's own)."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    f_s, zeta_s, m_s = 3.0, 0.04, 80.0
    model = _model3(bodies3)
    entry("sloshing").apply(model, "tank_left", slosh_frequency_hz=f_s, slosh_damping_ratio=zeta_s,
                            slosh_mass_kg=m_s, lateral_damping_factor=3.0)
    modes = system_modes(model, linearise(model), max_frequency_hz=6.0)
    by_direction = {d["tank_left"]: z for d, z in zip(modes.direction, modes.damping_ratio, strict=True)}
    assert sorted(by_direction) == ["X", "Y"]
    assert by_direction["X"] == pytest.approx(zeta_s, rel=0.03)
    assert by_direction["Y"] == pytest.approx(3.0 * zeta_s, rel=0.03)


# --------------------------------------------------------------------------------------- tuned_mass_damper
def test_tuned_mass_damper_splits_the_mode_it_is_tuned_to_and_adds_exactly_its_mass(bodies1):
    """Den Hartog: an undamped absorber of mass ratio ``mu = m |phi|^2`` tuned to an isolated mode ``f``
    splits it into ``f_1,2^2 = f^2 (1 + mu / 2 -+ sqrt(mu + mu^2 / 4))`` (so ``f_1 f_2 = f^2``); the drive
    then moves the nominal mass plus ``m`` times the location's squared drive motion."""
    from exudyn_study.linear.nonlinear import marker_displacement_map
    from exudyn_study.model import linearise
    from exudyn_study.physics.entries import location_point

    model0 = _model1(bodies1)
    markers = {s: location_point(model0, s)[0] for s in FRAME_SENSORS}
    lin0 = linearise(model0)
    f0, phi0 = _undamped(lin0)
    # the best-isolated mode in 8-60 Hz that the location moves most
    best = None
    for s, marker in markers.items():
        d = marker_displacement_map(model0, marker)
        motion = d @ (lin0.nullspace.T @ phi0)
        for k in np.flatnonzero((f0 > 8.0) & (f0 < 60.0)):
            gap = min(abs(f0[j] - f0[k]) / f0[k] for j in range(f0.size) if j != k)
            mu_per_kg = float(np.sum(motion[:, k] ** 2))
            if gap > 0.2 and (best is None or mu_per_kg > best[0]):
                best = (mu_per_kg, s, k, d)
    assert best is not None
    mu_per_kg, loc, k, d = best
    mu = 0.01
    mass = mu / mu_per_kg
    assert 0.1 < mass < 200.0
    model = _model1(bodies1)
    entry("tuned_mass_damper").apply(model, loc, mass_kg=mass, frequency_hz=float(f0[k]), damping_ratio=0.0)
    lin = linearise(model)
    f1 = _undamped(lin)[0]
    near = np.sort(f1[np.abs(f1 - f0[k]) < 0.12 * f0[k]])
    # the absorber moves in three directions: along the mode's motion at the location it splits the mode,
    # across it its two modes stay at the tuning frequency (the structure hardly moves in them)
    assert near.size == 4, (f0[k], near)
    lo, hi = near[0], near[-1]
    np.testing.assert_allclose(near[1:3], f0[k], rtol=0.01)
    root = math.sqrt(mu + mu**2 / 4)
    assert lo < f0[k] < hi
    # the two-mode formula leaves out the other modes (>= 20 % away): they shift both by about 1 %
    assert lo * hi == pytest.approx(f0[k] ** 2, rel=0.015)
    assert (hi**2 - lo**2) / f0[k] ** 2 == pytest.approx(2 * root, rel=0.05)
    assert lo**2 == pytest.approx(f0[k] ** 2 * (1 + mu / 2 - root), rel=0.015)
    # mass: the drive moves the absorber with the location (its spring carries no static load)
    r0, r = lin0.drive_shape, lin.drive_shape
    added = mass * float(np.sum((d @ r0) ** 2))
    # (the location's motion map comes from central differences: 1e-6)
    assert r @ lin.full_mass @ r == pytest.approx(r0 @ lin0.full_mass @ r0 + added, rel=1e-6)
    assert added > 1e-3 * (r0 @ lin0.full_mass @ r0)
