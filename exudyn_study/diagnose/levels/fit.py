"""Fit and prove stages: an amplitude-dependent modal model fitted on training levels, proven on held-out ones.

Every mode with a level dependence gets a law for its pole as a function of its amplitude
``a`` (the rms response of :mod:`.amplitude`); the other modes stay at the reference.

``joint_friction``, ``joint_softening``, ``joint_damping``: a Jenkins element (a spring in
series with a Coulomb slider) carrying a share ``kappa`` of the mode's stiffness, slipping
above the amplitude ``a_slip``. Its describing function at amplitude ``A`` (``x = A / a_slip``,
``cos(theta) = 1 - 2 / x`` above slip) has the in-phase stiffness
``(theta - sin(2 theta) / 2) / pi`` and the quadrature ``4 (x - 1) / (pi x^2)`` per unit spring
stiffness (Caughey 1960; the dissipated energy per cycle is ``4 F (A - a_slip)``), averaged over
the Rayleigh-distributed amplitudes of a narrow-band random response of rms ``a`` (energy
weighted). The mode then has ``w^2 = w0^2 (1 - kappa + kappa k_c)`` and
``zeta = zeta0 w0 / w + kappa w0^2 k_q / (2 w^2)``.

``joint_stiffening``, ``joint_clearance``: ``w^2 = w0^2 (1 + beta (a / a_ref)^p)``, ``zeta = zeta0 w0 / w``
(``p = 2`` is a cubic spring under a Gaussian response; a clearance closing rises faster).

The parameters are fitted by weighted least squares to the per-level frequencies and damping
of the training levels. A held-out level is predicted from its drive alone: the amplitude is
the fixed point of ``a = amplitude(pole(a), drive)``, and the FRFs are the reference model with
the modes' poles at that amplitude. The proof is the relative FRF error per channel and level,
``||H_meas - H_model|| / ||H_meas||`` over the band, before (reference model) and after.

References
----------
Caughey, T. K. (1960). Random excitation of a system with bilinear hysteresis. J. Appl. Mech. 27, 649-652.
Iwan, W. D. (1966). A distributed-element model for hysteresis. J. Appl. Mech. 33, 893-900.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from exudyn_study.diagnose.levels.amplitude import ModalTable, mode_amplitude
from exudyn_study.diagnose.levels.frf import LevelFRF
from exudyn_study.diagnose.levels.reference import ReferenceModel, synthesise
from exudyn_study.diagnose.levels.screen import ModeTrend

__all__ = ["ModeLaw", "fit_mode_laws", "predict_poles", "prove"]

_X = np.linspace(1e-3, 7.0, 281)
_W = _X**3 * np.exp(-0.5 * _X**2)
_W = _W / np.trapezoid(_W, _X)


def jenkins_df(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-phase and quadrature stiffness of a Jenkins element per unit spring stiffness at ``x = A / a_slip``."""
    x = np.asarray(x, float)
    kc = np.ones_like(x)
    kq = np.zeros_like(x)
    s = x > 1.0
    th = np.arccos(np.clip(1.0 - 2.0 / x[s], -1.0, 1.0))
    kc[s] = (th - 0.5 * np.sin(2 * th)) / np.pi
    kq[s] = 4.0 * (x[s] - 1.0) / (np.pi * x[s] ** 2)
    return kc, kq


def jenkins_random(ratio: float) -> tuple[float, float]:
    """:func:`jenkins_df` averaged over Rayleigh amplitudes of rms ``ratio`` (in slip amplitudes), energy weighted."""
    kc, kq = jenkins_df(_X * ratio)
    return float(np.trapezoid(kc * _W, _X)), float(np.trapezoid(kq * _W, _X))


@dataclass(frozen=True)
class ModeLaw:
    """Amplitude law of one mode's pole.

    Attributes
    ----------
    mode : int
        1-based.
    kind : {'jenkins', 'power'}
    params : dict
        name -> (value, std, unit).
    """

    mode: int
    kind: str
    params: dict

    def modal(self, a: float) -> tuple[float, float]:
        """(frequency in Hz, damping ratio) at amplitude ``a``."""
        p = {k: v[0] for k, v in self.params.items()}
        w0 = 2 * math.pi * p["f0_hz"]
        if self.kind == "jenkins":
            kc, kq = jenkins_random(a / p["a_slip"])
            w2 = w0**2 * (1.0 - p["kappa"] + p["kappa"] * kc)
            w = math.sqrt(max(w2, 1e-12))
            return w / (2 * math.pi), p["zeta0"] * w0 / w + p["kappa"] * w0**2 * kq / (2.0 * w2)
        w2 = w0**2 * (1.0 + p["beta"] * (a / p["a_ref"]) ** p["p"])
        w = math.sqrt(max(w2, 1e-12))
        return w / (2 * math.pi), p["zeta0"] * w0 / w

    def pole(self, a: float) -> complex:
        """Pole in rad/s at amplitude ``a``."""
        f, z = self.modal(a)
        w = 2 * math.pi * f
        return complex(-z * w, w * math.sqrt(max(1 - z * z, 1e-12)))


def _fit_one(table: ModalTable, r: int, idx: list[int], kind: str) -> ModeLaw:
    f, fs = table.frequency_hz[idx, r], table.frequency_std_hz[idx, r]
    z, zs = table.damping_ratio[idx, r], table.damping_std[idx, r]
    a = table.amplitude[idx, r]
    i0 = int(np.argmin(a))
    unit = table.amplitude_unit
    if kind == "jenkins":
        names = ("f0_hz", "zeta0", "kappa", "a_slip")
        units = ("Hz", "-", "-", unit)
        x0 = np.array([np.log(f[i0]), np.log(z[i0]), 0.0, np.log(a[i0])])

        def law(x):
            kap = 1.0 / (1.0 + np.exp(-x[2]))
            return ModeLaw(r + 1, kind, {"f0_hz": (math.exp(x[0]), 0, ""), "zeta0": (math.exp(x[1]), 0, ""),
                                         "kappa": (kap, 0, ""), "a_slip": (math.exp(x[3]), 0, "")})
    else:
        names = ("f0_hz", "zeta0", "beta", "p")
        units = ("Hz", "-", "-", "-")
        a_ref = float(np.max(a))
        x0 = np.array([np.log(f[i0]), np.log(z[i0]), 0.0, np.log(2.0)])

        def law(x):
            return ModeLaw(r + 1, kind, {"f0_hz": (math.exp(x[0]), 0, ""), "zeta0": (math.exp(x[1]), 0, ""),
                                         "beta": (x[2] * 1e-2, 0, ""), "p": (math.exp(x[3]), 0, ""),
                                         "a_ref": (a_ref, 0, unit)})

    def res(x):
        m = law(x)
        pred = np.array([m.modal(ai) for ai in a])
        return np.concatenate([(pred[:, 0] - f) / fs, (pred[:, 1] - z) / zs])

    best = None
    starts = [x0] + [x0 + np.array([0, 0, d, s]) for d in (-2.0, 2.0) for s in (-1.0, 1.0)]
    for s0 in starts:
        sol = scipy.optimize.least_squares(res, s0, method="trf")
        if best is None or sol.cost < best.cost:
            best = sol
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * max(2 * best.cost / max(best.fun.size - 4, 1), 1.0)
        sx = np.sqrt(np.maximum(np.diag(cov), 0))
    except np.linalg.LinAlgError:
        sx = np.full(4, np.inf)
    m = law(best.x)
    params = {}
    for k, (name, u) in enumerate(zip(names, units, strict=True)):
        v = m.params[name][0]
        # the fit works in transformed coordinates: the standard deviation by the chain rule
        if kind == "jenkins" and name == "kappa":
            sd = v * (1 - v) * sx[k]
        elif name == "beta":
            sd = 1e-2 * sx[k]
        else:
            sd = v * sx[k]
        params[name] = (float(v), float(sd), u)
    if "a_ref" in m.params:
        params["a_ref"] = m.params["a_ref"]
    return ModeLaw(r + 1, kind, params)


def fit_mode_laws(table: ModalTable, trends: list[ModeTrend], train: list[int]) -> list[ModeLaw]:
    """Fit each level-dependent mode's law on the training levels (indices into the table)."""
    laws = []
    for t in trends:
        if t.outcome in ("joint_friction", "joint_softening", "joint_damping"):
            laws.append(_fit_one(table, t.mode - 1, train, "jenkins"))
        elif t.outcome in ("joint_stiffening", "joint_clearance"):
            laws.append(_fit_one(table, t.mode - 1, train, "power"))
    return laws


def predict_poles(model: ReferenceModel, laws: list[ModeLaw], frf: LevelFRF, channel_of_mode) -> tuple:
    """Poles of the model at a level predicted from its drive alone; also the amplitudes used."""
    poles = model.poles.copy()
    amps = {}
    for law in laws:
        r = law.mode - 1
        c = channel_of_mode[r]
        a = mode_amplitude(model.residues[c, r], poles[r], frf.freq_hz, frf.U)
        for _ in range(30):
            a_new = mode_amplitude(model.residues[c, r], law.pole(a), frf.freq_hz, frf.U)
            if abs(a_new - a) <= 1e-6 * a:
                break
            a = 0.5 * (a + a_new)
        poles[r] = law.pole(a)
        amps[law.mode] = a
    return poles, amps


def prove(model: ReferenceModel, laws: list[ModeLaw], frfs: list[LevelFRF], channel_of_mode) -> dict:
    """Relative FRF error per level and channel before (reference model) and after (amplitude laws).

    Returns
    -------
    dict
        label -> {'before': {ch: e}, 'after': {ch: e}, 'mean_before', 'mean_after', 'amplitude': {mode: a},
        'H_nominal', 'H_fitted' (arrays for the report)}.
    """
    out = {}
    for frf in frfs:
        m = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
        f = frf.freq_hz[m]
        h = frf.H[:, m]
        h0 = synthesise(model, f)
        poles, amps = predict_poles(model, laws, frf, channel_of_mode)
        h1 = synthesise(model, f, poles)
        nh = np.linalg.norm(h, axis=1)
        e0 = np.linalg.norm(h - h0, axis=1) / nh
        e1 = np.linalg.norm(h - h1, axis=1) / nh
        out[frf.label] = {
            "before": dict(zip(frf.channels, e0.tolist(), strict=True)),
            "after": dict(zip(frf.channels, e1.tolist(), strict=True)),
            "mean_before": float(e0.mean()),
            "mean_after": float(e1.mean()),
            "amplitude": {str(k): float(v) for k, v in amps.items()},
            "freq_hz": f,
            "H_measured": h,
            "H_nominal": h0,
            "H_fitted": h1,
        }
    return out
