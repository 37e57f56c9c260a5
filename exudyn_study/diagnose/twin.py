"""A synthetic twin of a shaker test on a jointed structure: >= 10 modes, 3 sensors, force multisine.

A chain of ``n`` lumped masses clamped at one end (a beam-like structure with ``n`` modes),
a bolted joint between masses ``joint`` and ``joint + 1`` whose stuck stiffness is in the linear
structure and a share of which acts through a Coulomb slider (Jenkins,
:class:`~exudyn_study.linear.nonlinear.JenkinsFriction`), modal damping. A shaker force drives
mass ``drive``; the sensors are the drive point ``DP`` (an accelerometer at the force gauge) and
``A``/``B`` on the two sides of the joint. The drive is a random-phase odd multisine (one in four
odd lines left out as detection lines) repeated over whole periods; the lab's imperfections:
the shaker's gain drifts from period to period, the force gauge and the accelerometers have
noise relative to their signals. :func:`truth_modes` gives the true amplitude-dependent modal
parameters of a recording: the joint's equivalent complex stiffness at each mode, from the
simulated joint motion and its friction force (the best linear approximation of the element),
put into the linear structure's eigenproblem. Imports neither exudyn nor ngsolve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.recording.types import Channel, Recording

__all__ = ["Twin", "simulate_twin", "truth_modes", "SUBSTEPS"]

#: sub-steps per sample of the twin's time simulation (the slider's force is held over each)
SUBSTEPS = 4


@dataclass(frozen=True)
class Twin:
    """The twin structure and its test (SI).

    Parameters
    ----------
    n_masses : int
        Masses in the chain (= modes).
    mass_kg, stiffness_n_per_m : float
        Every mass and every spring.
    damping_ratio : float
        Modal damping of the linear structure.
    joint : int
        The joint is the spring between masses ``joint`` and ``joint + 1`` (1-based).
    drive : int
        Mass driven by the shaker (the drive point, 1-based).
    friction_share : float
        Share of the joint stiffness through the slider (0: a linear joint).
    slip_m : float
        Relative displacement at which the slider slips.
    sample_rate_hz, period_s, band_hz
        Sampling, the multisine's period and its excited band.
    gain_drift : float
        Rms relative change of the shaker gain from period to period.
    noise : float
        Rms noise of every channel relative to its signal's rms.
    """

    n_masses: int = 12
    mass_kg: float = 0.5
    stiffness_n_per_m: float = 1.1e5
    damping_ratio: float = 0.01
    joint: int = 6
    drive: int = 3
    friction_share: float = 0.5
    slip_m: float = 2.0e-5
    sample_rate_hz: float = 400.0
    period_s: float = 20.0
    band_hz: tuple[float, float] = (5.0, 160.0)
    gain_drift: float = 0.005
    noise: float = 0.005

    def __post_init__(self) -> None:
        if not (3 <= self.drive <= self.n_masses and 1 <= self.joint < self.n_masses):
            raise InputError(
                f"Twin: drive {self.drive} and joint {self.joint} must lie on the chain of "
                f"{self.n_masses} masses"
            )


def _matrices(tw: Twin):
    n = tw.n_masses
    k = np.zeros((n, n))
    for i in range(n):  # spring i connects mass i-1 (or the clamp) and mass i
        k[i, i] += tw.stiffness_n_per_m
        if i > 0:
            k[i - 1, i - 1] += tw.stiffness_n_per_m
            k[i, i - 1] -= tw.stiffness_n_per_m
            k[i - 1, i] -= tw.stiffness_n_per_m
    m = np.eye(n) * tw.mass_kg
    w2, phi = np.linalg.eigh(k / tw.mass_kg)
    phi = phi / np.sqrt(tw.mass_kg)
    c = m @ phi @ np.diag(2 * tw.damping_ratio * np.sqrt(w2)) @ phi.T @ m
    return m, c, k


def _linear_system(tw: Twin):
    from exudyn_study.linear.system import LinearSystem

    m, c, k = _matrices(tw)
    n = tw.n_masses
    null = np.hstack([np.zeros((n, 1)), np.eye(n)])
    e = np.zeros(n)
    e[tw.drive - 1] = 1.0
    sens = [tw.drive - 1, tw.joint - 1, tw.joint]
    smap = np.zeros((3, n + 1))
    for s, i in enumerate(sens):
        smap[s, i + 1] = 1.0
    z = np.zeros(n)
    return LinearSystem(
        mass=m,
        damping=c,
        stiffness=k,
        nullspace=null,
        drive_shape=np.zeros(n + 1),
        b0=-e,
        b1=z,
        b2=z.copy(),
        sensor_map=smap,
        sensor_names=("DP", "A", "B"),
    )


def _multisine(tw: Twin, seed: int, realisation: int = 0):
    """One period of realisation ``realisation`` of the odd random-phase multisine (unit rms).

    The excited lines (and so the detection lines) depend on ``seed`` only; the phases of
    realisation 0 follow them from the same generator, the others come from ``(seed, realisation)``.
    """
    p = int(round(tw.period_s * tw.sample_rate_hz))
    f = np.fft.rfftfreq(p, 1.0 / tw.sample_rate_hz)
    rng = np.random.default_rng(seed)
    k = np.arange(f.size)
    odd = (k % 2 == 1) & (f >= tw.band_hz[0]) & (f <= tw.band_hz[1])
    idx = np.flatnonzero(odd)
    groups = idx[: idx.size // 4 * 4].reshape(-1, 4)
    drop = groups[np.arange(groups.shape[0]), rng.integers(0, 4, groups.shape[0])]
    spec = np.zeros(f.size, complex)
    keep = np.setdiff1d(idx, drop)
    if realisation:
        rng = np.random.default_rng([seed, realisation])
    spec[keep] = np.exp(2j * np.pi * rng.random(keep.size))
    x = np.fft.irfft(spec, p)
    return x / np.std(x)


def simulate_twin(
    levels_n,
    *,
    twin: Twin | None = None,
    periods: int = 9,
    realisations: int = 1,
    seed: int = 0,
    return_truth: bool = False,
):
    """Simulate the twin's shaker test at several force levels (rms N) into recordings.

    Parameters
    ----------
    levels_n : sequence of float
        Force rms per level in N.
    twin : Twin, optional
    periods : int
        Periods of the multisine per realisation (the first is the transient).
    realisations : int
        Realisations of the multisine recorded one after the other at every level (the same
        realisations at all levels, as a test uses; new phases, the same excited lines).
    seed : int
        Seed of the multisine phases, the drift and the noise (level ``i`` uses ``seed + i``).
    return_truth : bool
        Also return :func:`truth_modes` of every level.

    Returns
    -------
    list of Recording, or (list of Recording, list of (f_hz, zeta))
    """
    from exudyn_study.linear.nonlinear import CubicStiffening, JenkinsFriction, simulate_local_nonlinear
    from exudyn_study.model.rig import Drive

    tw = twin or Twin()
    lin = _linear_system(tw)
    gather = np.zeros((1, tw.n_masses + 1))
    gather[0, tw.joint], gather[0, tw.joint + 1] = -1.0, 1.0  # delta = B - A
    k_t = tw.friction_share * tw.stiffness_n_per_m
    law = JenkinsFriction(k_t, k_t * tw.slip_m) if tw.friction_share > 0 else CubicStiffening(0.0)
    bases = [_multisine(tw, seed, r) for r in range(realisations)]
    p = bases[0].size
    fs = tw.sample_rate_hz
    pos = {
        "DP": (0.1 * tw.drive, 0.0, 0.0),
        "A": (0.1 * tw.joint, 0.0, 0.0),
        "B": (0.1 * (tw.joint + 1), 0.0, 0.0),
    }
    recs, truths = [], []
    for i, level in enumerate(levels_n):
        rng = np.random.default_rng(1000 + seed + i)
        gains = 1.0 + tw.gain_drift * rng.standard_normal(periods * realisations)
        u = level * np.concatenate([g * bases[k // periods] for k, g in enumerate(gains)])
        drive = Drive()
        drive.set_signal(u, fs)
        acc, delta = simulate_local_nonlinear(
            lin, drive, gather, [law], substeps=SUBSTEPS, return_deltas=True
        )
        acc = acc + tw.noise * np.std(acc, axis=1, keepdims=True) * rng.standard_normal(acc.shape)
        u_meas = u + tw.noise * np.std(u) * rng.standard_normal(u.size)
        chans = [
            Channel(n, "acceleration", "m/s^2", "Z", pos[n], fs, row)
            for n, row in zip(("DP", "A", "B"), acc, strict=True)
        ]
        chans.append(Channel("force", "force", "N", "Z", pos["DP"], fs, u_meas, role="drive"))
        recs.append(
            Recording(
                tuple(chans), {"source": f"twin {level:g} N", "level_n": float(level), "seed": seed + i}
            )
        )
        if return_truth:
            truths.append(truth_modes(tw, delta[0], law, p, realisations=realisations, drive=u))
    return (recs, truths) if return_truth else recs


def truth_modes(
    tw: Twin,
    delta: np.ndarray,
    law,
    period: int,
    substeps: int = SUBSTEPS,
    realisations: int = 1,
    drive: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Return the true (frequency in Hz, damping ratio) per mode at one level.

    The true modal parameters of a level are those of its best linear approximation: the
    linear structure with the joint element replaced by its equivalent complex stiffness
    ``k_eq(f) = F_slider(f) / delta(f)`` at the mode (Pintelon & Schoukens 2012, Section 3.4).
    The slider is replayed on the simulated joint motion ``delta`` from rest, as the simulation
    ran it: at its ``substeps`` sub-steps per sample (the motion interpolated to them
    band-limited), its force held over each sub-step (a factor ``(1 - exp(-j w h)) / (j w h)`` per
    line, ``h`` the sub-step); the spectra are averaged over the periods after the first of every
    realisation, and the realisations pooled. The element sits in a feedback loop (its force moves
    the structure, which moves the joint), so its stochastic distortion is correlated with the
    joint motion at the same line, most at a resonance; the ratio is therefore taken against the
    shaker's force as the instrument, ``k_eq = sum F U* / sum delta U*`` over the realisations
    (the best linear approximation in a closed loop, Pintelon & Schoukens 2012, Section 3.4 and
    Chapter 12 on the indirect method): with it the structure's BLA from force to response, which
    the measured FRFs estimate, is exactly the linear structure with ``k_eq`` in the element's place.
    Without ``drive`` the joint motion is its own instrument (``sum F delta* / sum |delta|^2``).
    One realisation of a random-phase multisine gives ``k_eq`` at each line plus the slider's
    stochastic distortion, which is large
    where the joint hardly moves (a mode with a near-node at the joint), so ``k_eq`` at the mode
    is the expected one, which varies smoothly over octaves (the slider is rate independent): a
    straight line in log frequency fitted to the per-line ratios within a factor ``exp(0.3)``
    (35 %) of the mode's frequency, weighted by ``|delta|^2``, evaluated at the mode; it replaces
    the element in the linear structure's eigenproblem, and the mode's frequency is iterated
    (the window follows the mode as it moves).

    Parameters
    ----------
    tw : Twin
        The twin structure that was simulated.
    delta : ndarray, shape (n_samples,)
        The simulated joint motion, displacement of ``B`` relative to ``A`` in m, over the whole
        record (whole periods of the multisine).
    law : JenkinsFriction or CubicStiffening
        The joint's nonlinear element (:mod:`exudyn_study.linear.nonlinear`), whose force beyond
        the stuck spring is replayed on ``delta`` from its state at rest.
    period : int
        Samples per period of the multisine.
    substeps : int, optional
        Sub-steps per sample of the simulation that produced ``delta``.
    realisations : int, optional
        Realisations of the multisine in ``delta``, one after the other, each of whole periods.
    drive : ndarray, shape (n_samples,), optional
        The shaker force that produced ``delta`` in N (noise-free), the instrument of the ratio.

    Returns
    -------
    frequency_hz : ndarray, shape (n_masses,)
        Undamped natural frequency of every mode in Hz, in the order of the linear modes
        (ascending).
    damping_ratio : ndarray, shape (n_masses,)
        Damping ratio of every mode (-).

    References
    ----------
    Pintelon, R., Schoukens, J. (2012). System Identification: A Frequency Domain Approach, 2nd
    ed., Wiley-IEEE Press.
    """
    d_fine = np.fft.irfft(np.fft.rfft(delta), delta.size * substeps) * substeps
    st = law.initial_state()
    r = np.empty(d_fine.size)
    for t in range(d_fine.size):
        r[t], st = law.residual(float(d_fine[t]), 0.0, st)
    f = np.fft.rfftfreq(period, 1.0 / tw.sample_rate_hz)
    block = delta.size // realisations
    n_per = block // period
    cross = np.zeros(f.size, complex)
    auto = np.zeros(f.size, complex)
    power = np.zeros(f.size)
    for b in range(realisations):
        i0 = b * block + period  # the first period of a realisation is its transient
        i1 = b * block + n_per * period
        fd = np.fft.rfft(delta[i0:i1].reshape(-1, period), axis=1).mean(axis=0)
        fr = np.fft.rfft(r[i0 * substeps : i1 * substeps].reshape(-1, period * substeps), axis=1)
        fr = fr.mean(axis=0)[: f.size] / substeps
        inst = fd if drive is None else np.fft.rfft(drive[i0:i1].reshape(-1, period), axis=1).mean(axis=0)
        cross += fr * np.conj(inst)
        auto += fd * np.conj(inst)
        power += np.abs(inst) ** 2
    # per line: the ratio and its weight |delta|^2 (|sum delta U*|^2 / sum |U|^2 with an instrument U)
    auto_w = np.abs(auto) ** 2 / np.where(power > 0, power, 1.0)
    wh = 2 * np.pi * f / (tw.sample_rate_hz * substeps)
    cross = cross * np.where(wh > 0, (1 - np.exp(-1j * wh)) / np.where(wh > 0, 1j * wh, 1.0), 1.0)
    m, c, k = _matrices(tw)
    e = np.zeros(tw.n_masses)
    e[tw.joint - 1], e[tw.joint] = -1.0, 1.0
    w2, _ = np.linalg.eigh(k / tw.mass_kg)
    f_lin = np.sqrt(w2) / (2 * np.pi)
    out_f, out_z = np.zeros(f_lin.size), np.zeros(f_lin.size)
    minv = np.linalg.inv(m)
    moving = auto_w > 1e-12 * np.max(auto_w)
    ratio = cross / np.where(moving, auto, 1.0)
    for mode, f0 in enumerate(f_lin):
        fc = f0
        for _ in range(3):  # the window follows the mode as it moves with the element's stiffness
            sel = moving & (np.abs(np.log(np.maximum(f, f[1]) / fc)) <= 0.3)
            dk = 0.0
            if sel.any():
                w = auto_w[sel]
                a = np.stack([np.ones(sel.sum()), np.log(f[sel] / fc)], axis=1) * np.sqrt(w)[:, None]
                coef, *_ = np.linalg.lstsq(a.astype(complex), ratio[sel] * np.sqrt(w), rcond=None)
                dk = coef[0]
            kc = k + dk * np.outer(e, e)
            a = np.block([[np.zeros_like(m), np.eye(tw.n_masses)], [-minv @ kc, -minv @ c]])
            lam = np.linalg.eigvals(a)
            lam = lam[lam.imag > 0]
            j = int(np.argmin(np.abs(np.abs(lam) / (2 * np.pi) - fc)))
            fc = np.abs(lam[j]) / (2 * np.pi)
        out_f[mode] = fc
        out_z[mode] = -lam[j].real / np.abs(lam[j])
    return out_f, out_z
