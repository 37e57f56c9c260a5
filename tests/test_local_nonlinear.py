"""Linear model + local nonlinearity: against direct integration of a Duffing oscillator and
the friction energy of a Jenkins element (analytic)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from exudyn_study.errors import InputError
from exudyn_study.linear.nonlinear import (
    CubicStiffening,
    JenkinsFriction,
    LocalNonlinearity,
    simulate_local_nonlinear,
)
from exudyn_study.linear.response import simulate_linear
from exudyn_study.linear.system import LinearSystem
from exudyn_study.model.rig import Drive

MASS_KG = 2.0
STIFFNESS_N_PER_M = 2.0 * (2 * math.pi * 15.0) ** 2
DAMPING_N_S_PER_M = 2.0 * 0.02 * 2.0 * 2 * math.pi * 15


def _base_excited_sdof() -> LinearSystem:
    """q = (base, mass), base = drive u; z = mass - base. One acceleration sensor on the mass."""
    m, k, c = MASS_KG, STIFFNESS_N_PER_M, DAMPING_N_S_PER_M
    kf = np.array([[k, -k], [-k, k]])
    cf = np.array([[c, -c], [-c, c]])
    mf = np.diag([0.0, m])
    null = np.array([[0.0, 1.0]])
    r = np.array([1.0, 1.0])
    return LinearSystem(mass=null @ mf @ null.T, damping=null @ cf @ null.T, stiffness=null @ kf @ null.T,
                        nullspace=null, drive_shape=r, b0=null @ kf @ r, b1=null @ cf @ r, b2=null @ mf @ r,
                        sensor_map=np.array([[0.0, 1.0]]), sensor_names=("mass",))


def _drive(seconds=3.0, rate=1000.0, amplitude=2e-3, seed=3, noise_m=1e-4):
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    ramp = np.minimum(t / 0.5, 1.0) ** 2
    u = amplitude * np.sin(2 * math.pi * 13.0 * t) * ramp + noise_m * rng.standard_normal(t.size) * ramp
    d = Drive()
    d.set_signal(u, rate)
    return d, t


GATHER = np.array([[-1.0, 1.0]])  # delta = mass - base


def test_zero_residual_reproduces_the_exact_linear_solution():
    lin = _base_excited_sdof()
    drive, _ = _drive()
    exact = simulate_linear(lin, drive)
    nl = simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(0.0)], substeps=4)
    assert np.max(np.abs(nl - exact)) < 1e-9 * np.max(np.abs(exact))


@pytest.mark.parametrize("substeps", [1, 8, 16])
def test_zero_residual_is_exact_for_substeps_dividing_or_multiplying_the_drive_upsampling(substeps):
    """The drive is a cubic on each of its 8 fine intervals per sample: 1 and 8 sub-steps sum them
    through their exact maps, 16 evaluate each cubic at the sub-step starts."""
    lin = _base_excited_sdof()
    drive, _ = _drive()
    assert drive.upsampling == 8
    exact = simulate_linear(lin, drive)
    nl = simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(0.0)], substeps=substeps)
    assert np.max(np.abs(nl - exact)) < 1e-9 * np.max(np.abs(exact))


def test_duffing_against_direct_integration():
    lin = _base_excited_sdof()
    drive, t = _drive(noise_m=0.0)
    k3 = 1e9  # N/m^3: the cubic adds ~ 25 % to the linear force at the peak relative motion
    acc, deltas = simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(k3)], substeps=8,
                                           return_deltas=True)

    def rhs(tt, y):
        z, zt = y
        udd = drive.evaluate(np.array([tt]), 2)[0]
        f = STIFFNESS_N_PER_M * z + DAMPING_N_S_PER_M * zt + k3 * z**3
        return [zt, -f / MASS_KG - udd]

    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-9, atol=1e-12, max_step=1e-3)
    z_ref = sol.y[0]
    lin_only = simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(0.0)], substeps=1,
                                        return_deltas=True)[1][0]
    err = np.sqrt(np.mean((deltas[0] - z_ref) ** 2)) / np.sqrt(np.mean(z_ref**2))
    effect = np.sqrt(np.mean((lin_only - z_ref) ** 2)) / np.sqrt(np.mean(z_ref**2))
    assert effect > 0.1  # the nonlinearity matters
    assert err < 0.01, (err, effect)
    # acceleration of the mass = u'' + z''
    z, zt = sol.y
    acc_ref = -(STIFFNESS_N_PER_M * z + DAMPING_N_S_PER_M * zt + k3 * z**3) / MASS_KG  # u'' + z''
    assert np.sqrt(np.mean((acc[0] - acc_ref) ** 2)) < 0.01 * np.sqrt(np.mean(acc_ref**2))


def test_jenkins_element_dissipates_four_f_times_slip_per_cycle():
    law = JenkinsFriction(stiffness_n_per_m=1e5, slip_force_n=50.0)
    state = law.initial_state()
    a = 2e-3  # amplitude, above slip (F/k = 0.5 mm)
    phase = np.linspace(0, 4 * math.pi, 4001)
    delta = a * np.sin(phase)
    force = []
    for d in delta:
        res, state = law.residual(d, 0.0, state)
        force.append(law.stiffness_n_per_m * d + res)
    force = np.array(force)
    second = phase >= 2 * math.pi
    work = np.trapezoid(force[second], delta[second])
    assert work == pytest.approx(4 * 50.0 * (a - 50.0 / 1e5), rel=0.01)
    assert np.max(np.abs(force)) == pytest.approx(50.0, rel=1e-9)


def test_bad_element_definitions():
    with pytest.raises(InputError, match="direction"):
        LocalNonlinearity("x", 0, 1, [0, 0, 0], CubicStiffening(1.0))
    with pytest.raises(InputError, match="lacks initial_state"):
        LocalNonlinearity("x", 0, 1, [0, 0, 1], object())
    lin = _base_excited_sdof()
    drive, _ = _drive(seconds=0.1)
    with pytest.raises(InputError, match="gather vectors"):
        simulate_local_nonlinear(lin, drive, GATHER, [], substeps=2)
    with pytest.raises(InputError, match="substeps 3; expected a divisor or a multiple of the drive's"):
        simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(0.0)], substeps=3)


def test_memoryless_law_converges_at_second_order_in_the_sub_step():
    """A cubic held at the sub-step's start lags by half a sub-step (first order); evaluated at the
    predicted midpoint the error falls by ~4 per halving of the sub-step."""
    lin = _base_excited_sdof()
    drive, t = _drive(noise_m=0.0)
    k3 = 4e9  # N/m^3: a strongly hardening spring, the tangent ~2x the linear at the peaks

    def rhs(tt, y):
        z, zt = y
        udd = drive.evaluate(np.array([tt]), 2)[0]
        return [zt, -(STIFFNESS_N_PER_M * z + DAMPING_N_S_PER_M * zt + k3 * z**3) / MASS_KG - udd]

    z_ref = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-13, max_step=5e-4).y[0]
    err = {}
    for substeps in (1, 2, 4):
        d = simulate_local_nonlinear(lin, drive, GATHER, [CubicStiffening(k3)], substeps=substeps,
                                     return_deltas=True)[1][0]
        err[substeps] = np.sqrt(np.mean((d - z_ref) ** 2)) / np.sqrt(np.mean(z_ref**2))
    assert err[1] / err[2] > 3.0 and err[2] / err[4] > 3.0, err
    assert err[4] < 2e-3, err
