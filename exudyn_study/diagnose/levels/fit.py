"""Fit and prove stages: one joint law across the located pair, fitted on training levels, proven on others.

A joint is one element whose state depends on the relative motion across it, which every mode
contributes to: its amplitude is ``sigma``, the rms relative displacement of the located pair
(the measured relative acceleration per line, ``(H_b - H_a) U``, divided by ``w^2``). Its
equivalent complex stiffness change ``k D(sigma)`` enters every mode ``r`` through the mode's
coupling ``c_r`` (first-order eigenvalue sensitivity: ``c_r = k (phi_b,r - phi_a,r)^2`` with
mass-normalised shapes)::

    Omega_r^2 = w0_r^2 (1 + 2 j zeta0_r) + c_r D(sigma),   w_r^2 = Re(Omega_r^2),
    zeta_r = Im(Omega_r^2) / (2 w_r^2)

``D`` per law:

``jenkins`` (``joint_friction``, ``joint_softening``, ``joint_damping``)
    A spring in series with a Coulomb slider slipping at ``a_slip``: at amplitude ``A``
    (``x = A / a_slip``, ``cos(theta) = 1 - 2 / x`` above slip) the in-phase stiffness
    ``(theta - sin(2 theta) / 2) / pi`` and the quadrature ``4 (x - 1) / (pi x^2)`` per unit
    spring stiffness (Caughey 1960; the energy dissipated per cycle is ``4 F (A - a_slip)``),
    averaged over the Rayleigh-distributed amplitudes of a narrow-band random motion of rms
    ``sigma`` (energy weighted); ``D = (k_c - 1) + j k_q``.
``power`` (``joint_stiffening``, ``joint_clearance``)
    ``D = beta (sigma / sigma_ref)^p`` (a cubic spring under a Gaussian motion has ``p = 2``; a
    clearance closing rises faster).

Under a broadband drive the joint's motion is a sum of modes, and a mode sees the slider through
the whole motion, not through a narrow-band one of its own: the averaged describing function
holds per mode with its own effective slip amplitude, and a joint of many contact points (an Iwan
element: sliders of distributed strength) dissipates more or less per unit softening than one
slider does, and its dissipation peaks at another amplitude relative to its softening. So every
mode ``r`` of the law has its own ``w0_r``, ``zeta0_r``, softening weight ``c_r``, dissipation
weight ``d_r`` (``Omega_r^2 = ... + c_r Re D + j d_r Im D``), ``a_slip,r`` for the softening
``k_c`` and one for the dissipation ``k_q`` (within a factor ``e`` of it; ``p_r`` for a power law,
without dissipation), fitted by weighted
least squares to the training levels' frequencies and damping (:mod:`.amplitude`) against
the common ``sigma`` (:func:`level_sigma`). With a force drive and a drive-point accelerometer the shapes are
mass-normalised and ``k_r = c_r / g_r`` (N/m, ``g_r = (phi_b,r - phi_a,r)^2`` from the reference
model) is the joint stiffness that mode sees slip; the JSON reports its median over the modes,
weighted by ``g_r``.

A held-out level is predicted from its drive alone: ``sigma`` is the fixed point of
``sigma = rms relative displacement of the model at the poles of sigma``; the FRFs are the
reference model with those poles and with the law modes' residues moved with them: a stiffness
change across the joint moves every mode's shape in proportion to it (first-order eigenvector
sensitivity), so ``R_r = R_r,ref + v_r (Omega_r^2 / Omega_r,ref^2 - 1)``, ``v_r`` per channel
fitted on the training levels (:func:`fit_residue_slope`). The proof is the relative FRF error
per channel and level, ``||H_meas - H_model|| / ||H_meas||`` over the band, before (reference
model) and after, beside the floor no linear model can go below: the noise and nonlinear
distortion, ``||sigma|| / ||H_meas||``.

References
----------
Caughey, T. K. (1960). Random excitation of a system with bilinear hysteresis. J. Appl. Mech. 27, 649-652.
Iwan, W. D. (1966). A distributed-element model for hysteresis. J. Appl. Mech. 33, 893-900.
Fox, R. L., Kapoor, M. P. (1968). Rates of change of eigenvalues and eigenvectors. AIAA J. 6, 2426-2429.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.frf import LevelFRF
from exudyn_study.diagnose.levels.reference import ReferenceModel, synthesise
from exudyn_study.diagnose.levels.screen import ModeTrend

__all__ = [
    "JointLaw",
    "jenkins_df",
    "jenkins_random",
    "relative_displacement",
    "scaled_coupling",
    "fit_joint_law",
    "level_sigma",
    "predict_poles",
    "law_poles_at",
    "law_model",
    "fit_residue_slope",
    "prove",
]

_X = np.linspace(1e-3, 7.0, 281)
_W = _X**3 * np.exp(-0.5 * _X**2)
_W = _W / np.trapezoid(_W, _X)
#: laws per screened outcome
LAW_OF = {
    "joint_friction": "jenkins",
    "joint_softening": "jenkins",
    "joint_damping": "jenkins",
    "joint_stiffening": "power",
    "joint_clearance": "power",
}


def jenkins_df(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-phase and quadrature stiffness of a Jenkins element per unit spring stiffness.

    ``x = A / a_slip`` is the harmonic amplitude in slip amplitudes.

    Parameters
    ----------
    x : array_like
        Amplitudes of the harmonic relative motion over the slip amplitude (-), any shape; at
        or below 1 the slider sticks.

    Returns
    -------
    kc, kq : ndarray
        In-phase (1 while stuck) and quadrature (0 while stuck) stiffness per unit spring
        stiffness (-), the shape of ``x``.
    """
    x = np.asarray(x, float)
    kc = np.ones_like(x)
    kq = np.zeros_like(x)
    s = x > 1.0
    th = np.arccos(np.clip(1.0 - 2.0 / x[s], -1.0, 1.0))
    kc[s] = (th - 0.5 * np.sin(2 * th)) / np.pi
    kq[s] = 4.0 * (x[s] - 1.0) / (np.pi * x[s] ** 2)
    return kc, kq


def jenkins_random(ratio: float) -> tuple[float, float]:
    """Average :func:`jenkins_df` over Rayleigh amplitudes of rms ``ratio`` (in slip amplitudes).

    Energy-weighted: the amplitudes that carry the response count most.

    Parameters
    ----------
    ratio : float
        Rms ``sigma`` of the narrow-band random relative motion over the slip amplitude
        ``a_slip`` (-); the amplitudes are Rayleigh distributed with that scale.

    Returns
    -------
    kc, kq : float
        Averaged in-phase and quadrature stiffness per unit spring stiffness (-).
    """
    kc, kq = jenkins_df(_X * ratio)
    return float(np.trapezoid(kc * _W, _X)), float(np.trapezoid(kq * _W, _X))


@dataclass(frozen=True)
class JointLaw:
    """A joint law across a sensor pair and the modes it moves.

    Attributes
    ----------
    kind : {'jenkins', 'power'}
    pair : (str, str)
    modes : tuple of int
        0-based indices of the reference modes in the law.
    f0_hz, zeta0 : ndarray, shape (n_law_modes,)
        Small-amplitude frequency and damping of those modes.
    coupling : ndarray, shape (n_law_modes,)
        ``c_r`` in (rad/s)^2 per unit ``Re D`` (the softening).
    dissipation : ndarray, shape (n_law_modes,)
        ``d_r`` in (rad/s)^2 per unit ``Im D`` (the dissipation); ``d_r = c_r`` for one Jenkins element.
    shape : dict
        'jenkins': ``{'a_slip': ndarray (m) per mode, 'a_slip_q': ndarray (m) per mode}`` (the
        softening's and the dissipation's slip amplitudes; without 'a_slip_q' both are 'a_slip');
        'power': ``{'p': ndarray per mode, 'sigma_ref': m}``.
    stiffness_n_per_m : float or None
        The joint's slipping (or hardening) stiffness ``k`` when the shapes are mass-normalised.
    parameters : dict
        name -> {'value', 'unit', 'std'} for the JSON.
    residue_slope : ndarray of complex, shape (n_out, n_law_modes), or None
        Change of each law mode's residues per unit relative change of its ``Omega_r^2``
        (:func:`fit_residue_slope`); None: the residues stay the reference model's.
    """

    kind: str
    pair: tuple[str, str]
    modes: tuple[int, ...]
    f0_hz: np.ndarray
    zeta0: np.ndarray
    coupling: np.ndarray
    dissipation: np.ndarray
    shape: dict
    stiffness_n_per_m: float | None
    parameters: dict
    residue_slope: np.ndarray | None = None

    def d(self, sigma: float) -> np.ndarray:
        """Equivalent stiffness change per unit coupling of each mode at relative displacement ``sigma``.

        Parameters
        ----------
        sigma : float
            Rms relative displacement of the law's sensor pair in m.

        Returns
        -------
        ndarray of complex, shape (n_law_modes,)
            ``D`` per mode of the law (-): ``(k_c - 1) + j k_q`` of :func:`jenkins_random` at
            ``sigma / a_slip`` for 'jenkins', ``(sigma / sigma_ref)^p`` (real) for 'power'.
        """
        if self.kind == "jenkins":
            a_c = np.atleast_1d(self.shape["a_slip"])
            a_q = np.atleast_1d(self.shape.get("a_slip_q", a_c))
            kc = np.array([jenkins_random(sigma / a)[0] for a in a_c])
            kq = np.array([jenkins_random(sigma / a)[1] for a in a_q])
            return (kc - 1.0) + 1j * kq
        return (sigma / self.shape["sigma_ref"]) ** np.atleast_1d(self.shape["p"]) + 0j

    def modal(self, sigma: float) -> tuple[np.ndarray, np.ndarray]:
        """(frequency in Hz, damping ratio) of the law's modes at ``sigma``.

        ``Omega_r^2 = w0_r^2 (1 + 2 j zeta0_r) + c_r Re D + j d_r Im D`` (module docstring).

        Parameters
        ----------
        sigma : float
            Rms relative displacement of the law's sensor pair in m.

        Returns
        -------
        frequency_hz : ndarray, shape (n_law_modes,)
            Undamped natural frequency of each of the law's modes in Hz.
        damping_ratio : ndarray, shape (n_law_modes,)
            Damping ratio of each of the law's modes (-).
        """
        w0 = 2 * np.pi * self.f0_hz
        dd = self.d(sigma)
        om2 = w0**2 * (1 + 2j * self.zeta0) + self.coupling * dd.real + 1j * self.dissipation * dd.imag
        w2 = np.maximum(om2.real, 1e-12)
        return np.sqrt(w2) / (2 * np.pi), om2.imag / (2 * w2)

    def poles(self, sigma: float) -> np.ndarray:
        """Poles (rad/s) of the law's modes at ``sigma``.

        Parameters
        ----------
        sigma : float
            Rms relative displacement of the law's sensor pair in m.

        Returns
        -------
        ndarray of complex, shape (n_law_modes,)
            Poles in rad/s (upper half plane) of the modes in ``modes``, in that order, from
            :meth:`modal`.
        """
        f, z = self.modal(sigma)
        w = 2 * np.pi * f
        return -z * w + 1j * w * np.sqrt(np.maximum(1 - z * z, 1e-12))


def relative_displacement(h: np.ndarray, freq_hz: np.ndarray, u: np.ndarray, i: int, j: int) -> float:
    """Rms relative displacement (m) of channels ``i``, ``j``.

    From acceleration FRFs ``h[n_out, n_freq]`` and the drive's line amplitudes ``u``:
    ``sqrt(sum_k |(h_j - h_i) u / w_k^2|^2 / 2)``.

    Parameters
    ----------
    h : ndarray of complex, shape (n_out, n_freq)
        Accelerance FRFs, (m/s^2) per drive unit.
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz (positive: the acceleration is divided by ``w^2``).
    u : ndarray of complex, shape (n_freq,)
        The drive's peak amplitude per line (drive unit).
    i, j : int
        Rows of ``h`` of the two sensors; the motion is that of ``j`` relative to ``i``.

    Returns
    -------
    float
        The rms relative displacement in m.
    """
    w2 = (2 * np.pi * np.asarray(freq_hz)) ** 2
    dx = (h[j] - h[i]) * u / w2
    return float(np.sqrt(0.5 * np.sum(np.abs(dx) ** 2)))


def scaled_coupling(model: ReferenceModel, pair, drive_point: str) -> np.ndarray:
    """``g_r = (phi_b,r - phi_a,r)^2`` (1/kg) from the drive-point-scaled reference shapes (NaN: no mass).

    Divides a mode's fitted coupling ``c_r`` into the joint stiffness ``k_r = c_r / g_r`` in N/m.

    Parameters
    ----------
    model : ReferenceModel
        Reference model of a force drive (FRFs in (m/s^2)/N), whose drive-point residues scale
        the shapes to unit modal mass.
    pair : (str, str)
        The sensors ``a``, ``b`` across the joint.
    drive_point : str
        The accelerometer at the force gauge.

    Returns
    -------
    ndarray, shape (n_modes,)
        ``g_r`` per reference mode in 1/kg; NaN for a mode whose modal mass is degenerate.
    """
    ch = list(model.channels)
    dp, a, b = ch.index(drive_point), ch.index(pair[0]), ch.index(pair[1])
    lam = model.poles
    pp = model.residues / lam**2 * 2j * lam.imag  # phi_c phi_dp per mode
    phi_dp = np.sqrt(pp[dp].astype(complex))
    phi = pp / phi_dp
    g = np.abs((phi[b] - phi[a]) ** 2)
    if model.modal_mass_kg is not None:
        g = np.where(np.isfinite(model.modal_mass_kg), g, np.nan)
    return g


def level_sigma(frfs: list[LevelFRF], model: ReferenceModel, table: ModalTable, pair) -> np.ndarray:
    """Rms relative displacement of ``pair`` per level, of the reference model at that level's fitted poles.

    The same measure :func:`predict_poles` solves for at a held-out level, so that the law is fitted
    and used on one scale (the measured relative motion also holds the shape change with level,
    which the reference residues do not).

    Parameters
    ----------
    frfs : list of LevelFRF
        One per level, in the order of the rows of ``table``; their drive amplitudes ``U`` in
        ``model.band_hz`` drive the synthesised FRFs.
    model : ReferenceModel
        The reference model (its residues and residual terms).
    table : ModalTable
        The fitted frequency and damping of every mode at every level, which give the poles.
    pair : (str, str)
        The two sensors across the joint.

    Returns
    -------
    ndarray, shape (n_levels,)
        Rms relative displacement of the pair per level in m.
    """
    ch = list(model.channels)
    i, j = ch.index(pair[0]), ch.index(pair[1])
    out = []
    for k, frf in enumerate(frfs):
        m = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
        w = 2 * np.pi * table.frequency_hz[k]
        z = table.damping_ratio[k]
        poles = -z * w + 1j * w * np.sqrt(np.maximum(1 - z * z, 1e-12))
        out.append(
            relative_displacement(synthesise(model, frf.freq_hz[m], poles), frf.freq_hz[m], frf.U[m], i, j)
        )
    return np.array(out)


def _fit_mode(kind, f, fs, z, zs, sig, s_ref):
    """Fit one mode's (f0, zeta0, c / w_lo^2, log a_slip or p, d / w_lo^2) to its levels against ``sig``."""
    i0 = int(np.argmin(sig))
    w_lo2 = (2 * np.pi * f[i0]) ** 2
    span = math.log(s_ref / float(np.min(sig))) + 3.0

    def law(x):
        shape = (
            {
                "a_slip": np.array([s_ref * math.exp(x[3])]),
                "a_slip_q": np.array([s_ref * math.exp(x[3] + x[5])]),
            }
            if kind == "jenkins"
            else {"p": np.array([x[3]]), "sigma_ref": s_ref}
        )
        return JointLaw(
            kind,
            ("", ""),
            (0,),
            np.array([x[0]]),
            np.array([x[1]]),
            np.array([x[2] * w_lo2]),
            np.array([x[4] * w_lo2]),
            shape,
            None,
            {},
        )

    def res(x):
        m = law(x)
        pr = np.array([[v[0] for v in m.modal(si)] for si in sig])
        out = np.concatenate([(pr[:, 0] - f) / fs, (pr[:, 1] - z) / zs])
        return np.nan_to_num(out, nan=1e8, posinf=1e8, neginf=-1e8)

    if kind == "jenkins":
        lb, ub = [0.9 * f[i0], 1e-6, 0.0, -span - 3.0, 0.0, -1.0], [1.1 * f[i0], 0.5, 1.0, 3.0, 1.0, 1.0]
        shapes = np.linspace(-span, 0.5, 8)
    else:
        lb, ub = [0.9 * f[i0], 1e-6, -1.0, 0.5, 0.0, -1e-9], [1.1 * f[i0], 0.5, 1.0, 8.0, 1e-9, 1e-9]
        shapes = (1.0, 2.0, 4.0)
    drop = abs(1.0 - (f[int(np.argmax(sig))] / f[i0]) ** 2)
    grid = [
        np.array(
            [
                f[i0],
                max(z[i0], 1e-5),
                cs * max(drop, 1e-5),
                sh,
                (cs * max(drop, 1e-5) if kind == "jenkins" else 0.0),
                0.0,
            ]
        )
        for sh in shapes
        for cs in (0.5, 1.0, 3.0, 10.0)
    ]
    lb, ub = np.array(lb), np.array(ub)
    grid = [np.clip(x, lb + 1e-12, ub - 1e-12) for x in grid]
    costs = [float(np.sum(res(x) ** 2)) for x in grid]
    best = None
    for k in np.argsort(costs)[:3]:
        sol = scipy.optimize.least_squares(res, grid[k], bounds=(lb, ub), method="trf", x_scale="jac")
        if best is None or sol.cost < best.cost:
            best = sol
    dof = max(best.fun.size - best.x.size, 1)
    cov = np.linalg.pinv(best.jac.T @ best.jac) * max(2 * best.cost / dof, 1.0)
    sx = np.sqrt(np.maximum(np.diag(cov), 0))
    m = law(best.x)
    shape_v = m.shape["a_slip"][0] if kind == "jenkins" else m.shape["p"][0]
    shape_s = shape_v * sx[3] if kind == "jenkins" else sx[3]
    return (
        best.x[0],
        best.x[1],
        best.x[2] * w_lo2,
        sx[2] * w_lo2,
        shape_v,
        shape_s,
        2 * best.cost / dof,
        best.x[4] * w_lo2,
        best.x[5],
    )


def fit_joint_law(
    table: ModalTable,
    trends: list[ModeTrend],
    physics: str,
    pair,
    frfs: list[LevelFRF],
    model: ReferenceModel,
    train: list[int],
    g: np.ndarray | None = None,
) -> JointLaw:
    """Fit the joint law of ``physics`` across ``pair`` on the training levels.

    Parameters
    ----------
    table : ModalTable
    trends : list of ModeTrend
        The modes whose outcome belongs to ``physics``' law enter the law.
    physics : str
        Screened outcome (a key of ``LAW_OF``).
    pair : (str, str)
    frfs : list of LevelFRF
        All levels (for the measured relative displacement).
    model : ReferenceModel
    train : list of int
    g : ndarray, optional
        Mass-normalised couplings (:func:`scaled_coupling`), for the joint stiffness in N/m.

    Returns
    -------
    JointLaw
    """
    kind = LAW_OF[physics]
    modes = tuple(t.mode - 1 for t in trends if LAW_OF.get(t.outcome) == kind)
    sig = level_sigma(frfs, model, table, pair)[train]
    s_ref = float(np.max(sig))
    rows = []
    for r in modes:
        f = table.frequency_hz[train, r]
        fs = np.maximum(table.frequency_std_hz[train, r], 1e-6 * f)
        z = table.damping_ratio[train, r]
        zs = np.maximum(table.damping_std[train, r], 1e-6)
        rows.append(_fit_mode(kind, f, fs, z, zs, sig, s_ref))
    rows = np.array(rows)
    shape = (
        {"a_slip": rows[:, 4], "a_slip_q": rows[:, 4] * np.exp(rows[:, 8])}
        if kind == "jenkins"
        else {"p": rows[:, 4], "sigma_ref": s_ref}
    )
    params: dict = {}
    scaled = g is not None and np.all(np.isfinite(np.asarray(g)[list(modes)]))
    wts = np.asarray(g)[list(modes)] if scaled else np.abs(rows[:, 2])
    if kind == "jenkins":
        a_s, a_sd = _weighted_median(rows[:, 4], rows[:, 5], wts)
        params["slip_displacement_m"] = {"value": a_s, "unit": "m", "std": a_sd}
    else:
        p, p_sd = _weighted_median(rows[:, 4], rows[:, 5], wts)
        params["exponent"] = {"value": p, "unit": "-", "std": p_sd}
    k = None
    if scaled:
        gm = np.asarray(g)[list(modes)]
        k_r = rows[:, 2] / np.maximum(gm, 1e-30)
        k, k_sd = _weighted_median(k_r, rows[:, 3] / np.maximum(gm, 1e-30), gm)
        params["joint_stiffness_n_per_m"] = {"value": k, "unit": "N/m", "std": k_sd}
        if kind == "jenkins":
            params["slip_force_n"] = {
                "value": k * a_s,
                "unit": "N",
                "std": k * a_s * math.hypot(a_sd / max(a_s, 1e-300), k_sd / max(k, 1e-300)),
            }
    law = JointLaw(kind, tuple(pair), modes, rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 7], shape, k, params)
    return replace(law, residue_slope=fit_residue_slope(model, law, [frfs[i] for i in train], sig))


def _omega2(poles: np.ndarray) -> np.ndarray:
    """``w^2 (1 + 2 j zeta)`` of poles in rad/s."""
    w = np.abs(poles)
    return w**2 * (1.0 - 2j * poles.real / w)


def law_poles_at(model: ReferenceModel, law: JointLaw, sigma: float) -> np.ndarray:
    """Return the model's poles with those of the law's modes at relative displacement ``sigma``.

    Parameters
    ----------
    model : ReferenceModel
        The reference model; its modes outside the law keep their poles.
    law : JointLaw
        The joint law.
    sigma : float
        Rms relative displacement of the law's pair in m.

    Returns
    -------
    ndarray of complex, shape (n_modes,)
        Poles in rad/s.
    """
    poles = model.poles.copy()
    poles[list(law.modes)] = law.poles(sigma)
    return poles


def law_model(model: ReferenceModel, law: JointLaw, poles: np.ndarray) -> ReferenceModel:
    """Return the reference model at a level: ``poles``, and the law modes' residues moved with them.

    A mode's residues change with its shape, and a stiffness change across the joint moves a
    mode's shape in proportion to it (first-order eigenvector sensitivity, Fox & Kapoor 1968):
    ``R_r = R_r,ref + v_r (Omega_r^2 / Omega_r,ref^2 - 1)`` with ``v_r`` the law's
    ``residue_slope`` (:func:`fit_residue_slope`).

    Parameters
    ----------
    model : ReferenceModel
        The reference model (its residues at the reference poles).
    law : JointLaw
        The joint law (its modes and ``residue_slope``; None leaves the residues).
    poles : ndarray of complex, shape (n_modes,)
        The level's poles in rad/s (e.g. :func:`predict_poles`).

    Returns
    -------
    ReferenceModel
        With ``poles`` and the moved residues; everything else as ``model``.
    """
    res = model.residues.copy()
    if law.residue_slope is not None:
        idx = list(law.modes)
        rel = _omega2(np.asarray(poles)[idx]) / _omega2(model.poles[idx]) - 1.0
        res[:, idx] = res[:, idx] + law.residue_slope * rel[None, :]
    return replace(model, poles=np.asarray(poles, complex), residues=res)


def fit_residue_slope(
    model: ReferenceModel, law: JointLaw, frfs: list[LevelFRF], sigmas: np.ndarray
) -> np.ndarray:
    """Residue change per unit relative change of ``Omega_r^2`` of every law mode (see :func:`law_model`).

    At every training level the residues (and residual terms) are fitted by weighted LSFD to
    the level's FRFs with the poles fixed where the law puts them at that level's ``sigma``
    (the poles the prediction will use, so that the residues fit them); ``v_r`` per channel is
    the least-squares slope through the origin of the residue change against the relative
    change of ``Omega_r^2``, pooled over the levels (a level that barely moves adds little).

    Parameters
    ----------
    model : ReferenceModel
        The reference model.
    law : JointLaw
        The fitted law (its modes and poles).
    frfs : list of LevelFRF
        The training levels.
    sigmas : ndarray, shape (len(frfs),)
        Their rms relative displacements in m (:func:`level_sigma`).

    Returns
    -------
    ndarray of complex, shape (n_out, n_law_modes)
        ``v_r`` per channel and law mode, in residue units (FRF unit times rad/s).
    """
    from exudyn_study.identify.lsfd import lsfd

    idx = list(law.modes)
    num = np.zeros((model.residues.shape[0], len(idx)), complex)
    den = np.zeros(len(idx))
    for frf, sigma in zip(frfs, sigmas, strict=True):
        sub = frf.select((frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1]))
        poles = law_poles_at(model, law, float(sigma))
        w = 1.0 / np.maximum(sub.total_sigma, 1e-12 * np.abs(sub.H).max())
        fit = lsfd(
            sub.H[:, None, :],
            sub.freq_hz,
            poles,
            band_hz=model.band_hz,
            frf_form="accelerance",
            weights=w[:, None, :],
        )
        rel = _omega2(poles[idx]) / _omega2(model.poles[idx]) - 1.0
        num += (fit.residues[:, 0, idx] - model.residues[:, idx]) * np.conj(rel)[None, :]
        den += np.abs(rel) ** 2
    return num / np.maximum(den, 1e-300)[None, :]


def _weighted_median(v: np.ndarray, s: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Median of ``v`` weighted by ``w``, and the spread (weighted MAD) or the median's std if larger."""
    o = np.argsort(v)
    cw = np.cumsum(w[o]) / np.sum(w)
    med = float(v[o][np.searchsorted(cw, 0.5)])
    mad = float(np.average(np.abs(v - med), weights=w)) if v.size > 1 else float(s[0])
    return med, max(mad, float(np.median(s)))


def predict_poles(model: ReferenceModel, law: JointLaw, frf: LevelFRF) -> tuple[np.ndarray, float]:
    """Poles of the model at a level predicted from its drive alone, and the relative displacement used.

    ``sigma`` is the fixed point of the relative displacement of the model at the law's poles of
    ``sigma``, found by a damped iteration that starts at the reference model's relative
    displacement (at most 60 steps, to a relative change of 1e-6).

    Parameters
    ----------
    model : ReferenceModel
        The reference model; its modes outside the law keep their poles.
    law : JointLaw
        The fitted joint law (its pair and modes).
    frf : LevelFRF
        The level to predict; only its lines in ``model.band_hz`` and its drive amplitudes ``U``
        are used, not its measured FRFs.

    Returns
    -------
    poles : ndarray of complex, shape (n_modes,)
        The model's poles in rad/s with those of the law's modes at ``sigma``.
    sigma : float
        The predicted rms relative displacement of the law's pair in m.
    """
    ch = list(model.channels)
    i, j = ch.index(law.pair[0]), ch.index(law.pair[1])
    m = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
    f, u = frf.freq_hz[m], frf.U[m]
    sigma = relative_displacement(synthesise(model, f), f, u, i, j)
    for _ in range(60):
        new = relative_displacement(synthesise(model, f, law_poles_at(model, law, sigma)), f, u, i, j)
        if abs(new - sigma) <= 1e-6 * sigma:
            break
        sigma = 0.5 * (sigma + new)
    return law_poles_at(model, law, sigma), sigma


def prove(
    model: ReferenceModel, law: JointLaw, frfs: list[LevelFRF], table: ModalTable | None = None
) -> dict:
    """Relative FRF error per level and channel before (reference model) and after (joint law).

    Each level is predicted from its drive alone (:func:`predict_poles`), training and held-out
    levels alike; the error is ``||H_meas - H_model|| / ||H_meas||`` over ``model.band_hz``.
    Beside it, two floors: the noise alone (period-to-period or coherence scatter,
    ``||sigma|| / ||H_meas||``), and, with ``table``, the error of the level's own modal fit (the
    reference model with that level's fitted poles and residues): what a linear modal model
    fitted to the level itself leaves (noise, the nonlinear distortion of one multisine
    realisation, the modal model's limits), which no prediction of the level from its drive can
    be expected to beat.

    Parameters
    ----------
    model : ReferenceModel
        The reference model ("before").
    law : JointLaw
        The fitted joint law ("after").
    frfs : list of LevelFRF
        The levels to compare (the result is keyed by their labels, which must differ).
    table : ModalTable, optional
        The modal table of the same levels in the same order (:func:`~.amplitude.fit_modes_per_level`),
        for the own-fit floor.

    Returns
    -------
    dict
        label -> {'before': {ch: e}, 'after': {ch: e}, 'mean_before', 'mean_after', 'floor': {ch: e}
        and 'mean_floor' (the noise and distortion estimate), 'mean_noise_floor' (noise alone),
        'mean_own_fit' (with ``table``, else None),
        'sigma_predicted_m', 'sigma_measured_m', and the arrays 'freq_hz', 'H_measured',
        'H_nominal', 'H_fitted' for the report}.
    """
    out = {}
    ch = list(model.channels)
    i, j = ch.index(law.pair[0]), ch.index(law.pair[1])
    for n, frf in enumerate(frfs):
        m = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
        f = frf.freq_hz[m]
        h = frf.H[:, m]
        h0 = synthesise(model, f)
        own = None
        if table is not None:
            w = 2 * np.pi * table.frequency_hz[n]
            z = table.damping_ratio[n]
            p_own = -z * w + 1j * w * np.sqrt(np.maximum(1 - z * z, 1e-12))
            h_own = synthesise(replace(model, residues=table.residues[n]), f, p_own)
            own = float(np.mean(np.linalg.norm(h - h_own, axis=1) / np.linalg.norm(h, axis=1)))
        poles, sigma = predict_poles(model, law, frf)
        h1 = synthesise(law_model(model, law, poles), f)
        nh = np.linalg.norm(h, axis=1)
        e0 = np.linalg.norm(h - h0, axis=1) / nh
        e1 = np.linalg.norm(h - h1, axis=1) / nh
        # the error a perfect linear model would still have: the noise and the nonlinear distortion
        floor = np.linalg.norm(frf.total_sigma[:, m], axis=1) / nh
        out[frf.label] = {
            "before": dict(zip(frf.channels, e0.tolist(), strict=True)),
            "after": dict(zip(frf.channels, e1.tolist(), strict=True)),
            "mean_before": float(e0.mean()),
            "mean_after": float(e1.mean()),
            "floor": dict(zip(frf.channels, floor.tolist(), strict=True)),
            "mean_floor": float(floor.mean()),
            "mean_noise_floor": float(np.mean(np.linalg.norm(frf.sigma[:, m], axis=1) / nh)),
            "mean_own_fit": own,
            "sigma_predicted_m": float(sigma),
            "sigma_measured_m": relative_displacement(h, f, frf.U[m], i, j),
            "freq_hz": f,
            "H_measured": h,
            "H_nominal": h0,
            "H_fitted": h1,
        }
    return out
