"""Diagnosis of a generic structure tested at several levels: locate, name and model a joint nonlinearity.

The nominal model is a linear modal model identified from the lowest-level (reference)
recording; the recordings are a drive (role 'drive': the table displacement of a base
excitation, or a shaker force with an accelerometer at the drive point) and a handful of
accelerometers. :func:`diagnose_generic` then

1. **compares** every recording with the nominal model per channel and frequency band:
   transmissibility residuals (H1, response acceleration per drive acceleration)
   against the measurement's own noise (the FRF standard error from coherence and
   averages, Bendat & Piersol 2010 eq. 9.90) with a chi-square test; per-mode
   frequency, damping and MAC at every level (paired modes); the coherence deficit as
   the harmonic-distortion indicator;
2. **locates** the significant mismatch: the sensors and bands where it is significant,
   whether it grows with level, and the interface (a declared sensor pair across a joint,
   or any sensor pair and sensor-to-table pair) where a local complex stiffness change,
   fitted level by level, explains it best;
3. **names** the physics: each candidate joint law (``joint_friction``,
   ``joint_stiffening``, ``joint_clearance``) is scored by how its documented signature
   (direction of the frequency and damping shifts with level) matches the observed one;
4. **models and fits** the candidates whose signature fits at the located interface in a
   reduced model (the identified modes + one local element across the interface), by
   fast equivalent-linearised (statistical linearisation) frequency-domain fitting;
   rejects candidates whose parameters are not identifiable or drift between training
   recordings; ranks by an information criterion (BIC) on the training recordings;
5. **proves** it by time simulation of the reduced nonlinear model with the recorded
   drives: FRF error per channel on the training and the held-out recordings (never used
   for fitting) before and after; a candidate that does not improve the held-out error is
   rejected. A plain-language explanation goes with every finding.

Names used (the generic structure has no catalogue entry for its joint; these are the
generic counterparts of the catalogue's rig entries):

``joint_friction``
    Jenkins micro-slip across the interface: a share of the joint's stiffness acts through
    a Coulomb slider. Signature: frequencies of the modes that load the joint drop and
    their damping rises with level; the coherence drops.
``joint_stiffening``
    Cubic hardening spring (``k3 delta^3``) across the interface. Signature: frequencies
    rise with level (the rise grows with the square of the relative motion), damping
    unchanged.
``joint_clearance``
    A dead zone (gap) in parallel with the joint: contact stiffness beyond the gap.
    Signature: frequencies rise with level once the gap closes and level off when it is
    always closed; strong distortion (coherence drop).

With a displacement drive the reduced model's mass scale is not observable; the relative
masses at the sensors come from the orthogonality of the identified shapes (lumped at the
sensors). With a force drive the drive-point residues mass-normalise the shapes and the
masses come out in kg. Either way the element's parameters are reported relative to the
identified linear stiffness of the interface (shares, ratios) and in metres (slip
displacement, gap), which do not depend on the mass scale.

Limitations: one drive (a table displacement or one shaker force); one local element at one
interface is fitted per diagnosis; the equivalent-linear fit (Gaussian statistical
linearisation, Rayleigh-averaged describing function for the Jenkins element) only starts
the time-simulation refinement; parameter standard deviations are statistical (from the
time-simulation Jacobian) and do not include the bias of the identified linear link
stiffness (a few per cent on the test structure).

References
----------
Bendat, J. S., Piersol, A. G. (2010). Random Data, 4th ed., Wiley (FRF random error).
Roberts, J. B., Spanos, P. D. (2003). Random Vibration and Statistical Linearization, Dover.
Caughey, T. K. (1960). Random excitation of a system with bilinear hysteresis. J. Appl. Mech. 27, 649-652.
Iwan, W. D. (1966). A distributed-element model for hysteresis and its steady-state dynamic response.
J. Appl. Mech. 33, 893-900 (Jenkins elements).
Kerschen, G., Worden, K., Vakakis, A. F., Golinval, J.-C. (2006). Past, present and future of
nonlinear system identification in structural dynamics. MSSP 20, 505-592.
"""

from __future__ import annotations

import logging
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import scipy.signal
import scipy.special
import scipy.stats
from scipy.interpolate import CubicSpline

from exudyn_study.diagnose.schema import Diagnosis, Finding
from exudyn_study.errors import InputError
from exudyn_study.infra.progress import StatusProgress
from exudyn_study.recording.types import Recording

__all__ = [
    "diagnose_generic",
    "GenericSettings",
    "ReducedModel",
    "CANDIDATES",
    "check_recordings",
]

log = logging.getLogger(__name__)
TWO_PI = 2.0 * math.pi
GROUND = "drive"  # name of the table/shaker side in an interface pair


# ------------------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class GenericSettings:
    """Settings of :func:`diagnose_generic` (defaults suit a few-minute test at several levels).

    Parameters
    ----------
    resolution_hz : float
        Welch resolution of the FRF estimates in Hz.
    band_hz : (float, float) or None
        Analysis band in Hz; default the lines where the reference's median coherence is >= 0.5.
    alpha : float
        Family-wise significance level of the mismatch tests (Bonferroni over the cells
        recording x channel x band).
    min_effect : float
        A cell counts only if its relative FRF error also exceeds this (-): a statistically
        significant but negligible mismatch is not reported.
    correlation_factor : float
        Variance inflation of the chi-square sum for correlated neighbouring lines
        (Hann window, 50 % overlap).
    substeps : int
        Minimum sub-steps per sample in the time simulation of the reduced nonlinear model.
    max_step_s : float
        Longest sub-step in s (more sub-steps at low sampling rates): the element force is held
        over a sub-step, which a stiff element (a hardened cubic spring) tolerates only if short.
    max_rel_std : float
        A fitted parameter whose relative standard deviation exceeds this is not identifiable.
    """

    resolution_hz: float = 0.25
    band_hz: tuple[float, float] | None = None
    alpha: float = 0.01
    min_effect: float = 0.05
    correlation_factor: float = 2.0
    substeps: int = 4
    max_step_s: float = 1.0 / 2048.0
    max_rel_std: float = 0.5

    def __post_init__(self) -> None:
        if not (self.resolution_hz > 0 and math.isfinite(self.resolution_hz)):
            raise InputError(f"resolution_hz {self.resolution_hz!r}; expected a positive frequency in Hz")
        if not 0 < self.alpha < 1:
            raise InputError(f"alpha {self.alpha!r}; expected a probability in (0, 1)")
        if not (isinstance(self.substeps, int) and self.substeps >= 1):
            raise InputError(f"substeps {self.substeps!r}; expected an integer >= 1")


# ------------------------------------------------------------------------------------- input checks
@dataclass(frozen=True)
class _Layout:
    channels: tuple[str, ...]
    sample_rate_hz: float
    drive: str
    force: bool = False


def _label(rec: Recording, default: str) -> str:
    for key in ("file", "name", "label"):
        if key in rec.metadata:
            return str(rec.metadata[key])
    return default


def _layout_of(rec: Recording, who: str) -> tuple:
    drives = rec.drive_channels
    if not drives:
        raise InputError(
            f"{who}: recording has no drive channel (role 'drive'); the diagnosis needs the "
            "table/shaker displacement: record it, or mark its channel role='drive'"
        )
    if len(drives) > 1:
        raise InputError(
            f"{who}: recording has {len(drives)} drive channels "
            f"({', '.join(d.name for d in drives)}); expected exactly one"
        )
    if drives[0].quantity not in ("displacement", "force"):
        raise InputError(
            f"{who}: drive channel {drives[0].name!r} is an {drives[0].quantity}; expected the table "
            "displacement (base excitation) or the shaker force (with a drive-point accelerometer)"
        )
    resp = rec.response_channels
    if not resp:
        raise InputError(f"{who}: recording has no response channels; expected accelerometers")
    return tuple((c.name, c.quantity, c.direction) for c in resp), drives[0]


def check_recordings(
    reference: Recording,
    train: Sequence[Recording],
    holdout: Sequence[Recording],
    interfaces=None,
    *,
    labels: Mapping[int, str] | None = None,
):
    """Validate the inputs of :func:`diagnose_generic`; return (layout, labels, interface dict).

    Parameters
    ----------
    reference : Recording
        The model reference recording (acceleration channels, one drive channel, one sampling rate).
    train : sequence of Recording
        The training recordings.
    holdout : sequence of Recording
        The held-out recordings.
    interfaces : mapping or sequence of tuple or None, optional
        Interfaces to search: name -> ``(a, b)`` or a list of ``(a, b)`` pairs of channel names
        (``GROUND``, ``'drive'``, for the table); None: every pair of channels and every channel to the table.
    labels : mapping of int to str or None, optional
        Accepted for the caller's labels of the recordings (unused here).

    Raises
    ------
    InputError
        No training or no held-out recording; a recording without a drive channel; a
        recording whose sensor layout (channel names, quantities, directions) or sampling rate
        differs from the reference model's; an interface naming an unknown sensor.

    Returns
    -------
    tuple
        ``(layout, labels, interfaces)``: the reference's channel layout, ``(group, index) -> label`` of
        the training and held-out recordings, and interface name -> ``(a, b)``.
    """
    if not isinstance(reference, Recording):
        raise InputError(f"reference of type {type(reference).__name__}; expected a Recording")
    train, holdout = list(train or ()), list(holdout or ())
    if not train:
        raise InputError("train: no training recording given; pass at least one (e.g. --train REC)")
    if not holdout:
        raise InputError(
            "holdout: no held-out recording given; the improvement must be shown on data not "
            "used for fitting: pass at least one (another level or signal, --holdout REC)"
        )
    ref_layout, ref_drive = _layout_of(reference, "model reference recording")
    quantities = {q for _, q, _ in ref_layout}
    if quantities != {"acceleration"}:
        raise InputError(
            f"model reference recording: response quantities {sorted(quantities)}; the generic "
            "diagnosis expects acceleration channels"
        )
    fs = ref_drive.sample_rate_hz
    for name, _, _ in ref_layout:
        if reference.channel(name).sample_rate_hz != fs:
            raise InputError(
                f"model reference recording: channel {name!r} sampled at "
                f"{reference.channel(name).sample_rate_hz:g} Hz, the drive at {fs:g} Hz; expected one "
                "rate (resample first)"
            )
    names = {}
    for group, recs in (("train", train), ("holdout", holdout)):
        for i, rec in enumerate(recs):
            if not isinstance(rec, Recording):
                raise InputError(f"{group}[{i}] of type {type(rec).__name__}; expected a Recording")
            who = f"{group} recording {_label(rec, f'{group}[{i}]')!r}"
            lay, drv = _layout_of(rec, who)
            if lay != ref_layout:
                ref_names = [n for n, _, _ in ref_layout]
                got = [n for n, _, _ in lay]
                if got != ref_names:
                    diff = f"channels {got} vs the model's {ref_names}"
                else:
                    diff = "the same channel names with other quantities or directions"
                raise InputError(
                    f"{who}: sensor layout differs from the model reference recording ({diff}); "
                    "all recordings must come from the same sensor layout as the model"
                )
            if drv.quantity != ref_drive.quantity:
                raise InputError(
                    f"{who}: drive channel is a {drv.quantity}, the model reference's a "
                    f"{ref_drive.quantity}; all recordings must be driven the same way"
                )
            rates = {c.sample_rate_hz for c in rec.response_channels} | {drv.sample_rate_hz}
            if rates != {fs}:
                raise InputError(
                    f"{who}: sampled at {sorted(rates)} Hz; the model reference at {fs:g} Hz; "
                    "resample to one rate"
                )
            names[(group, i)] = _label(rec, f"{group}[{i}]")
    chans = tuple(n for n, _, _ in ref_layout)
    itfs = _check_interfaces(interfaces, chans)
    return _Layout(chans, fs, ref_drive.name, ref_drive.quantity == "force"), names, itfs


def _check_interfaces(interfaces, channels) -> dict[str, tuple[str, str]]:
    if interfaces is None:
        pairs = {}
        for i, a in enumerate(channels):
            pairs[f"{GROUND}-{a}"] = (GROUND, a)
            for b in channels[i + 1 :]:
                pairs[f"{a}-{b}"] = (a, b)
        return pairs
    items = interfaces.items() if isinstance(interfaces, Mapping) else ((None, p) for p in interfaces)
    out = {}
    for name, pair in items:
        try:
            a, b = (str(x) for x in pair)
        except (TypeError, ValueError):
            raise InputError(f"interface {pair!r}: expected a pair of sensor names (a, b)") from None
        for s in (a, b):
            if s != GROUND and s not in channels:
                raise InputError(
                    f"interface {name or (a, b)!r}: sensor {s!r} is not in the recordings; "
                    f"expected one of {list(channels)} or {GROUND!r} (the table)"
                )
        if a == b:
            raise InputError(f"interface {(a, b)!r}: expected two different sensors")
        out[str(name) if name else f"{a}-{b}"] = (a, b)
    if not out:
        raise InputError("interfaces: an empty list; pass None to search every sensor pair")
    return out


# ------------------------------------------------------------------------------------- spectra
@dataclass(frozen=True, eq=False)
class _Spectra:
    label: str
    freq_hz: np.ndarray  # lines in the analysis band
    T: np.ndarray  # (n_s, n_f) transmissibility H1 (response acc / drive acc)
    coherence: np.ndarray  # (n_s, n_f)
    sigma: np.ndarray  # (n_s, n_f) standard error of T (complex, E|dT|^2 = sigma^2)
    g_aa: np.ndarray  # (n_f,) autospectrum of the reference signal ((m/s^2)^2/Hz or N^2/Hz)
    level: float  # reference rms: drive acceleration in m/s^2, or force in N
    drive_m: np.ndarray  # drive samples: table displacement (m) or force (N)
    drive_acc: np.ndarray  # reference signal: drive acceleration (band-limited, m/s^2) or the force (N)
    response: np.ndarray  # (n_s, n) measured accelerations
    resolution_hz: float
    n_averages: int
    rate_hz: float
    force: bool = False


def _drive_on_grid(u: np.ndarray, fs: float, substeps: int = 1, derivative: int = 2) -> np.ndarray:
    """Return the drive ``u`` (sampled at ``fs`` Hz) or its ``derivative`` at ``substeps`` points per sample.

    The band-limited reconstruction of the rig's drive
    (:func:`exudyn_study.model.rig.band_limited_upsample` by
    :data:`~exudyn_study.model.rig.DRIVE_UPSAMPLING`, then a cubic spline through the fine samples),
    the one the virtual rig and :func:`~exudyn_study.linear.nonlinear.simulate_local_nonlinear`
    drive with. A spline through the samples themselves is off by about ``(omega / fs)^2 / 12`` in
    acceleration (12 % at 100 Hz sampled at 512 Hz); on the fine grid that is 64 times smaller.

    Returns
    -------
    ndarray, shape ((N - 1) substeps + 1,)
    """
    from exudyn_study.model.rig import DRIVE_UPSAMPLING, band_limited_upsample

    fine = band_limited_upsample(np.asarray(u, dtype=float), DRIVE_UPSAMPLING)
    spline = CubicSpline(np.arange(fine.size) / (fs * DRIVE_UPSAMPLING), fine, bc_type="natural")
    return spline(np.arange((u.size - 1) * substeps + 1) / (fs * substeps), derivative)


def _drive_acceleration(u: np.ndarray, fs: float) -> np.ndarray:
    return _drive_on_grid(u, fs, 1, 2)


def _welch_T(a_b: np.ndarray, x: np.ndarray, fs: float, resolution_hz: float, fmax: float):
    from exudyn_study.identify.frf import estimate_frf

    return estimate_frf(a_b, x, fs, resolution_hz=resolution_hz, estimator="H1", fmax_hz=fmax)


def _spectra(
    rec: Recording, layout: _Layout, label: str, settings: GenericSettings, band: tuple[float, float] | None
) -> _Spectra:
    x, fs = rec.time_data(layout.channels)
    u = rec.channel(rec.drive.name).data
    force = rec.drive.quantity == "force"
    a_b = np.asarray(u, dtype=float) if force else _drive_acceleration(np.asarray(u, dtype=float), fs)
    try:
        frf = _welch_T(a_b, x, fs, settings.resolution_hz, fs / 2)
    except InputError as exc:
        raise InputError(f"recording {label!r}: {exc}") from None
    f = frf.freq_hz
    keep = (f > 0) if band is None else (f >= band[0]) & (f <= band[1])
    _, g = scipy.signal.welch(
        a_b, fs, window="hann", nperseg=frf.n_segment, noverlap=frf.n_segment // 2, detrend="constant"
    )
    coh = np.clip(frf.coherence[:, 0, :], 1e-6, 0.9999)
    h = frf.H[:, 0, :]
    eps = np.sqrt((1.0 - coh) / (coh * 2.0 * frf.n_averages))
    sigma = np.sqrt(2.0) * eps * np.abs(h)
    return _Spectra(
        label,
        f[keep],
        h[:, keep],
        coh[:, keep],
        sigma[:, keep],
        g[: f.size][keep],
        float(np.sqrt(np.mean(a_b[a_b.size // 16 :] ** 2))),
        np.asarray(u, float),
        a_b,
        x,
        frf.resolution_hz,
        frf.n_averages,
        float(fs),
        force,
    )


def _auto_band(spec: _Spectra) -> tuple[float, float]:
    coh = np.median(spec.coherence, axis=0)
    good = np.flatnonzero(coh >= 0.5)
    if good.size < 8:
        raise InputError(
            "model reference recording: the coherence between drive and responses is below 0.5 "
            "almost everywhere; no excited band can be found (check the drive channel, or give "
            "band_hz)"
        )
    return float(spec.freq_hz[good[0]]), float(spec.freq_hz[good[-1]])


# ------------------------------------------------------------------------------------- reduced model
@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Real-mode model of the base-excited structure identified from the reference recording.

    Transmissibility (response acceleration per drive acceleration) of channel ``s``::

        T_s(w) = 1 + w^2 sum_r psi[s, r] / (w_r^2 - w^2 + 2 i zeta_r w_r w) + upper[s] w^2

    and in the time domain, per mode, ``eta_r'' + 2 zeta_r w_r eta_r' + w_r^2 eta_r = -a_b - f_r``
    with the relative displacement of channel ``s`` ``z_s = sum_r psi[s, r] eta_r``. A local
    element with force ``F`` across the interface ``(a, b)`` (``delta = z_b - z_a``) adds
    ``f_r = (psi[b, r] - psi[a, r]) F / gamma2[r]``.

    Attributes
    ----------
    channels : tuple of str
    frequency_hz, damping_ratio : ndarray, shape (n_modes,)
    psi : ndarray, shape (n_channels, n_modes)
        Real participation-scaled shapes (-).
    upper : ndarray, shape (n_channels,)
        Upper residual (s^2).
    masses : ndarray, shape (n_channels,)
        Relative masses lumped at the sensors (sum 1; the mass scale is unobservable).
    gamma2 : ndarray, shape (n_modes,)
        Effective modal masses in the same relative unit.
    masses_estimated : bool
        False when the orthogonality estimate failed and equal masses are used.
    metadata : dict
        Further facts of the identification (for a force drive, ``drive_point``: the channel at the
        drive point); empty by default.
    direct : float
        1 for a displacement drive (T is the transmissibility, the table's acceleration passes
        straight through); 0 for a force drive (T is the accelerance, ``psi`` the negated residues
        ``phi_r(s) phi_r(d)``, ``gamma2`` the drive-point residues: mass-normalised, in kg).
    """

    channels: tuple
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    psi: np.ndarray
    upper: np.ndarray
    masses: np.ndarray
    gamma2: np.ndarray
    masses_estimated: bool = True
    metadata: dict = field(default_factory=dict)
    direct: float = 1.0

    @property
    def omega(self) -> np.ndarray:
        """Natural frequencies in rad/s."""
        return TWO_PI * self.frequency_hz

    def transmissibility(self, freq_hz, kern=None) -> np.ndarray:
        """``T[n_channels, n_freq]`` of the linear model (Welch-smoothed with ``kern`` = (grid, weights)).

        Parameters
        ----------
        freq_hz : numpy.ndarray
            Frequencies (Hz), shape (n_freq,).
        kern : tuple of numpy.ndarray or None, optional
            ``(grid, weights)`` of the Welch spectral window: frequencies (Hz) around each of ``freq_hz``,
            shape (n_freq, n_off), and their weights, so the result is the expected Welch estimate
            (None: the exact transmissibility).

        Returns
        -------
        numpy.ndarray
            Complex transmissibility (accelerance for a force drive), shape (n_channels, n_freq).
        """
        b = _modal_basis(freq_hz, self.frequency_hz, self.damping_ratio, kern)
        return self.direct + self.psi @ b[:-1] + self.upper[:, None] * b[-1]

    def _row(self, s: str) -> np.ndarray:
        if s == GROUND:
            return np.zeros(self.psi.shape[1])
        return self.psi[self.channels.index(s)]

    def coupling(self, pair) -> tuple[np.ndarray, np.ndarray, float]:
        """(v, w, k_link) of an interface: ``delta = v . eta``, ``f_r = w_r F``, linear link stiffness.

        ``k_link`` is the identified linear stiffness between the two lumped sensor masses
        (or the sensor and the table), in the relative mass unit times 1/s^2.

        Parameters
        ----------
        pair : tuple of str
            The interface ``(a, b)``: two channels, or a channel and ``GROUND`` (the table, ``'drive'``).

        Returns
        -------
        tuple
            ``(v, w, k_link)``: the relative displacement per modal coordinate, shape (n_modes,), the modal
            force per unit interface force, shape (n_modes,), and the link stiffness (float).
        """
        a, b = pair
        v = self._row(b) - self._row(a)
        w = v / self.gamma2
        # K = M Phi W^2 Phi^T M with Phi = psi / gamma (mass-normalised), M = diag(masses)
        kmat = (
            (self.masses[:, None] * self.psi)
            @ np.diag(self.omega**2 / self.gamma2)
            @ (self.psi.T * self.masses[None, :])
        )
        ia = None if a == GROUND else self.channels.index(a)
        ib = None if b == GROUND else self.channels.index(b)
        if ia is None or ib is None:
            i = ib if ia is None else ia
            k_link = float(kmat[i].sum())
        else:
            k_link = float(-kmat[ia, ib])
        if not (k_link > 0 and math.isfinite(k_link)):
            # no positive link stiffness identified: use the interface's modal stiffness instead
            k_link = float(np.max(self.omega**2 / np.maximum(v**2 / self.gamma2, 1e-30)) * 1e-2)
        return v, w, k_link


def _kernel(spec: _Spectra) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (Hz) and weights of the Welch spectral window: E[H1](f) = sum_k H(f + off_k) w_k."""
    from exudyn_study.identify.lsfd import Leakage

    n_seg = int(round(spec.rate_hz / spec.resolution_hz))
    off, k = Leakage(spec.rate_hz, n_seg, "hann").kernel(oversample=2, half_width=3)
    return off * spec.resolution_hz, k


def _grid(spec: _Spectra) -> tuple[np.ndarray, np.ndarray]:
    """(frequency grid (n_f, n_off) in Hz, kernel weights (n_off,)): model evaluation points."""
    off, k = _kernel(spec)
    return np.maximum(spec.freq_hz[:, None] + off[None, :], 1e-6), k


def _modal_basis(freq_hz, f_r, z_r, kern=None):
    """Basis ``[w^2 / D_r(w) ..., w^2]`` (n_m + 1, n_f), Welch-smoothed when ``kern`` = (grid, weights)."""
    om = TWO_PI * np.asarray(f_r, float)
    if kern is None:
        w = TWO_PI * np.asarray(freq_hz, float)
        d = om[:, None] ** 2 - w**2 + 2j * np.asarray(z_r)[:, None] * om[:, None] * w
        return np.vstack([w**2 / d, (w**2)[None, :].astype(complex)])
    grid, k = kern
    w = TWO_PI * grid  # (n_f, n_off)
    d = om[:, None, None] ** 2 - w**2 + 2j * np.asarray(z_r)[:, None, None] * om[:, None, None] * w
    b = np.concatenate([w[None] ** 2 / d, (w**2)[None].astype(complex)], axis=0)
    return b @ k


def _vp_fit(spec: _Spectra, f0, z0, fixed_poles: bool = False):
    """Variable projection: poles (f, zeta) by NLLS, residues psi (real) and upper residual by LS.

    The model is compared with the Welch estimate through the spectral window (expected H1),
    so the damping carries no resolution bias.
    """
    T1 = spec.T - (0.0 if spec.force else 1.0)
    wgt = 1.0 / np.maximum(spec.sigma, 1e-12 * np.max(np.abs(spec.T)))
    n_s, n_m = T1.shape[0], len(f0)
    kern = _grid(spec)

    def solve(p):
        f_r, z_r = p[:n_m], p[n_m:]
        basis = _modal_basis(spec.freq_hz, f_r, z_r, kern)  # (n_m+1, n_f)
        coef = np.empty((n_s, n_m + 1))
        res = []
        for s in range(n_s):
            a = (basis * wgt[s]).T
            a_ri = np.vstack([a.real, a.imag])
            b = T1[s] * wgt[s]
            b_ri = np.concatenate([b.real, b.imag])
            c, *_ = np.linalg.lstsq(a_ri, b_ri, rcond=None)
            coef[s] = c
            res.append(a_ri @ c - b_ri)
        return coef, np.concatenate(res)

    p0 = np.concatenate([f0, z0])
    if fixed_poles:
        coef, res = solve(p0)
        return p0[:n_m], p0[n_m:], coef[:, :n_m], coef[:, n_m], res, None
    lo = np.concatenate([np.asarray(f0) * 0.7, np.full(n_m, 1e-4)])
    hi = np.concatenate([np.asarray(f0) * 1.3, np.full(n_m, 0.5)])
    p0 = np.clip(p0, lo + 1e-9, hi - 1e-9)
    sol = scipy.optimize.least_squares(
        lambda p: solve(p)[1],
        p0,
        bounds=(lo, hi),
        x_scale=np.concatenate([np.asarray(f0) * 0.01, np.full(n_m, 0.005)]),
        method="trf",
    )
    coef, res = solve(sol.x)
    cov = _covariance(sol.jac, res)
    return sol.x[:n_m], sol.x[n_m:], coef[:, :n_m], coef[:, n_m], res, cov


def _covariance(jac, res):
    jac = np.asarray(jac)
    dof = max(res.size - jac.shape[1], 1)
    s2 = float(res @ res) / dof
    try:
        return np.linalg.pinv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return np.full((jac.shape[1], jac.shape[1]), np.inf)


def _relative_masses(psi: np.ndarray) -> tuple[np.ndarray, bool]:
    """Masses lumped at the sensors from the orthogonality of the participation-scaled shapes.

    With mass-normalised ``phi_r`` and ``psi_r = phi_r Gamma_r``, ``Gamma_r = phi_r^T M 1``:
    ``psi_r^T M psi_q = 0`` (r != q) and ``psi_r^T M psi_r = psi_r^T M 1``: homogeneous linear
    equations in diag(M), solved by the smallest singular vector (the scale is unobservable).
    """
    n_s, n_m = psi.shape
    rows = []
    for r in range(n_m):
        for q in range(r, n_m):
            rows.append(psi[:, r] * (psi[:, q] - (1.0 if r == q else 0.0)))
    a = np.array(rows)
    if n_m >= 2 and a.shape[0] >= n_s:
        _, s, vt = np.linalg.svd(a / np.linalg.norm(a, axis=1, keepdims=True).clip(1e-30))
        m = vt[-1]
        m = m * np.sign(m.sum())
        if np.all(m > 0.02 * m.max()) and s[-1] < 0.2 * s[0]:
            return m / m.sum(), True
    return np.full(n_s, 1.0 / n_s), False


def _add_missed_peaks(spec: _Spectra, f0: np.ndarray, z0: np.ndarray):
    """Add a pole at every clear resonance peak the automatic PolyMAX selection left out.

    Peaks of the summed power ``sum_s |T_s|^2`` (prominence of a factor 2) farther than two
    half-power bandwidths (or two lines) from every selected pole start at 2 % damping; the
    pole fit then refines or (if spurious) damps them out.
    """
    power = np.sum(np.abs(spec.T) ** 2, axis=0)
    peaks, _ = scipy.signal.find_peaks(np.log10(np.maximum(power, 1e-300)), prominence=math.log10(2.0))
    add = []
    for k in peaks:
        f = float(spec.freq_hz[k])
        near = np.abs(f0 - f) <= np.maximum(2.0 * 2.0 * z0 * f0, 2.0 * spec.resolution_hz)
        if not near.any():
            add.append(f)
    if add:
        log.info(
            "adding %d resonance(s) the automatic selection missed: %s Hz",
            len(add),
            ", ".join(f"{f:.3g}" for f in add),
        )
        order = np.argsort(np.concatenate([f0, add]))
        f0 = np.concatenate([f0, add])[order]
        z0 = np.concatenate([z0, np.full(len(add), 0.02)])[order]
    return f0, z0


def identify_reduced_model(
    spec: _Spectra, channels, f0=None, z0=None, drive_point: str | None = None
) -> ReducedModel:
    """Identify the real-mode reduced model from the reference spectra (poles from PolyMAX).

    With a force drive, ``drive_point`` names the accelerometer at the force (its residues give
    the mass normalisation).
    """
    from exudyn_study.identify.frf import FRF
    from exudyn_study.identify.pipeline import identify_frf

    if f0 is None:
        frf = FRF(
            spec.freq_hz,
            spec.T[:, None, :],
            spec.coherence[:, None, :],
            "H1",
            spec.resolution_hz,
            spec.n_averages,
            tuple(channels),
            ("drive_acc",),
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # resolution advice is for EMA users, not here
            res = identify_frf(
                frf,
                band_hz=(float(spec.freq_hz[0]), float(spec.freq_hz[-1])),
                orders=range(2, 41),
                leakage_correction=False,
                refine=False,
            )
        if not len(res.model):
            raise InputError(
                f"model reference recording {spec.label!r}: no stable modes found in "
                f"{spec.freq_hz[0]:.3g}-{spec.freq_hz[-1]:.3g} Hz; the generic diagnosis needs a "
                "structure with resonances in the excited band"
            )
        f0, z0 = res.model.frequency_hz, np.maximum(res.model.damping_ratio, 2e-3)
        f0, z0 = _add_missed_peaks(spec, np.asarray(f0, float), np.asarray(z0, float))
    f_r, z_r, psi, upper, _, _ = _vp_fit(spec, np.asarray(f0, float), np.asarray(z0, float))
    if spec.force:
        return _force_model(spec, tuple(channels), f_r, z_r, psi, upper, drive_point)
    masses, ok = _relative_masses(psi)
    gamma2 = masses @ psi
    if np.any(gamma2 <= 0):
        masses, ok = np.full(len(channels), 1.0 / len(channels)), False
        gamma2 = np.maximum(masses @ psi, 1e-6 * np.max(np.abs(masses @ psi)))
    return ReducedModel(tuple(channels), f_r, z_r, psi, upper, masses, gamma2, ok)


def _force_model(spec, channels, f_r, z_r, psi, upper, drive_point) -> ReducedModel:
    """Mass-normalised model of a force-driven structure (drive-point residues positive)."""
    d = channels.index(drive_point)
    gamma2 = -psi[d]
    keep = gamma2 > 1e-6 * np.max(np.abs(gamma2))
    if not keep.any():
        raise InputError(
            f"model reference recording {spec.label!r}: channel {drive_point!r} does not behave as the "
            "drive-point accelerometer (no positive drive-point residue); name the accelerometer at the force"
        )
    if not keep.all():
        log.info("dropping %d mode(s) without a positive drive-point residue", int((~keep).sum()))
    f_r, z_r, psi, gamma2 = f_r[keep], z_r[keep], psi[:, keep], gamma2[keep]
    phi = -psi / np.sqrt(gamma2)  # mass-normalised shapes at the sensors
    # lumped masses at the sensors from phi^T M phi = I (absolute scale here)
    n_m = phi.shape[1]
    rows, rhs = [], []
    for r in range(n_m):
        for q in range(r, n_m):
            rows.append(phi[:, r] * phi[:, q])
            rhs.append(1.0 if r == q else 0.0)
    m, *_ = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)
    ok = bool(np.all(m > 0))
    if not ok:
        m = np.full(len(channels), 1.0 / max(np.mean(np.sum(phi**2, axis=0)), 1e-300))
    return ReducedModel(channels, f_r, z_r, psi, upper, m, gamma2, ok, {"drive_point": drive_point}, 0.0)


# ------------------------------------------------------------------------------------- joint laws
@dataclass(frozen=True)
class _Param:
    name: str
    unit: str
    lower: float
    upper: float
    log: bool
    description: str


class _Law:
    """A candidate joint law, parameters relative to the interface's linear stiffness ``k_link``."""

    name = ""
    physics = ""
    params: tuple = ()
    #: expected sign of the frequency shift and the damping shift with level (0: none expected)
    signature = (0, 0)

    def el(self, sigma, theta) -> np.ndarray:
        """Equivalent complex stiffness change per ``k_link`` at delta rms ``sigma`` (vectorised)."""
        raise NotImplementedError

    def step(self, delta, state, theta):
        """Vectorised residual force per ``k_link`` and new state."""
        raise NotImplementedError

    def init_state(self, n):
        """State at rest for ``n`` parallel simulations."""
        return np.zeros(n)

    def start(self, sigma_max) -> list[np.ndarray]:
        """Return starting points for the fit (internal coordinates)."""
        raise NotImplementedError

    def to_internal(self, theta):
        return np.array([math.log(t) if p.log else t for t, p in zip(theta, self.params, strict=True)])

    def from_internal(self, x):
        return np.array([math.exp(v) if p.log else v for v, p in zip(x, self.params, strict=True)])

    def bounds(self):
        lo = [math.log(p.lower) if p.log else p.lower for p in self.params]
        hi = [math.log(p.upper) if p.log else p.upper for p in self.params]
        return np.array(lo), np.array(hi)


# Rayleigh amplitude quadrature (x = A / sigma), weight A^2 p(A): x^3 exp(-x^2/2) / 2
_X = np.linspace(1e-3, 7.0, 241)
_WX = _X**3 * np.exp(-0.5 * _X**2) / 2.0
_WX = _WX / np.trapezoid(_WX, _X)


class _Friction(_Law):
    name = "joint_friction"
    physics = "friction micro-slip in the joint (Jenkins element: spring in series with a Coulomb slider)"
    params = (
        _Param(
            "slip_share",
            "1",
            1e-3,
            3.0,
            True,
            "share of the joint's linear stiffness acting through the slider",
        ),
        _Param(
            "slip_displacement_m",
            "m",
            1e-9,
            1e-1,
            True,
            "relative displacement across the joint at which the slider slips",
        ),
    )
    signature = (-1, +1)

    def el(self, sigma, theta):
        share, ds = theta
        a = np.asarray(sigma, float)[..., None] * _X  # amplitudes
        r = np.clip(ds / np.maximum(a, 1e-300), 0.0, 1.0)
        beta = np.arccos(np.clip(1.0 - 2.0 * r, -1.0, 1.0))
        k_re = (beta - 0.5 * np.sin(2.0 * beta)) / math.pi - 1.0
        k_im = 4.0 * r * (1.0 - r) / math.pi
        return share * (np.trapezoid((k_re + 1j * k_im) * _WX, _X, axis=-1))

    def step(self, delta, state, theta):
        share, ds = theta
        state = np.minimum(np.maximum(state, delta - ds), delta + ds)
        return -share * state, state

    def start(self, sigma_max):
        return [self.to_internal([0.5, s]) for s in (0.3 * sigma_max, 1.0 * sigma_max)]


class _Stiffening(_Law):
    name = "joint_stiffening"
    physics = "a hardening joint (cubic spring k3 delta^3 in parallel with the linear joint stiffness)"
    params = (
        _Param(
            "cubic_ratio_per_m2",
            "1/m^2",
            1e-2,
            1e18,
            True,
            "cubic stiffness per linear joint stiffness, k3 / k_link",
        ),
    )
    signature = (+1, 0)

    def el(self, sigma, theta):
        return 3.0 * theta[0] * np.asarray(sigma, float) ** 2 + 0j

    def step(self, delta, state, theta):
        return theta[0] * delta**3, state

    def start(self, sigma_max):
        return [self.to_internal([0.1 / sigma_max**2])]


class _Clearance(_Law):
    name = "joint_clearance"
    physics = "a clearance (dead zone) in the joint: contact stiffness once the gap closes"
    params = (
        _Param("gap_m", "m", 1e-9, 1e-1, True, "half-width of the dead zone"),
        _Param("contact_ratio", "1", 1e-3, 30.0, True, "contact stiffness per linear joint stiffness"),
    )
    signature = (+1, 0)

    def el(self, sigma, theta):
        g, ratio = theta
        s = np.maximum(np.asarray(sigma, float), 1e-300)
        return ratio * scipy.special.erfc(g / (math.sqrt(2.0) * s)) + 0j

    def step(self, delta, state, theta):
        g, ratio = theta
        return ratio * (delta - np.minimum(np.maximum(delta, -g), g)), state

    def start(self, sigma_max):
        return [self.to_internal([g, 0.5]) for g in (0.5 * sigma_max, 1.5 * sigma_max)]


#: candidate joint laws of the generic path, by name
CANDIDATES = {law.name: law for law in (_Friction(), _Stiffening(), _Clearance())}


# ------------------------------------------------------------------------------------- EL prediction
class _EL:
    """Equivalent-linear transmissibilities of the reduced model with a local element at ``pair``.

    The element's complex stiffness ``k_link * dk`` (relative to the reference level) is a
    rank-one update of the modal dynamics (Sherman-Morrison), so everything but ``dk`` is
    precomputed per recording; the prediction is the expected Welch H1 (smoothed by the
    spectral window). For a law, the relative-displacement rms ``sigma`` that sets ``dk`` is
    iterated to a fixed point (statistical linearisation).
    """

    def __init__(self, model: ReducedModel, pair, specs: Sequence[_Spectra], kerns) -> None:
        v, w, k_link = model.coupling(pair)
        self.k_link = k_link
        om, ze = model.omega, model.damping_ratio
        self.items = []
        for sp, (grid, kw) in zip(specs, kerns, strict=True):
            wf = TWO_PI * grid
            d = om[:, None, None] ** 2 - wf**2 + 2j * ze[:, None, None] * om[:, None, None] * wf
            inv = 1.0 / d
            delta0 = -np.tensordot(v, inv, axes=1)  # (n_f, n_off)
            gvd = np.tensordot(v * w, inv, axes=1)
            t_lin = (
                model.direct
                + np.tensordot(model.psi, inv, axes=1) * wf**2
                + model.upper[:, None, None] * wf**2
            )
            p_el = np.tensordot(model.psi, w[:, None, None] * inv, axes=1) * wf**2  # (n_s, n_f, n_off)
            c = kw.size // 2
            self.items.append(
                dict(
                    delta0=delta0,
                    gvd=gvd,
                    t_lin=t_lin @ kw,
                    p=p_el,
                    kw=kw,
                    freq_hz=sp.freq_hz,
                    d0c=delta0[:, c],
                    gc=gvd[:, c],
                    ga=sp.g_aa * sp.resolution_hz,
                )
            )

    def sigma(self, i: int, dk: complex = 0j) -> float:
        """Relative-displacement rms of recording ``i`` with the element change ``dk``."""
        it = self.items[i]
        return math.sqrt(
            float(np.sum(np.abs(it["d0c"] / (1.0 + self.k_link * dk * it["gc"])) ** 2 * it["ga"]))
        )

    def predict(self, i: int, dk: complex) -> np.ndarray:
        """Smoothed T (n_s, n_f) of recording ``i`` with the element change ``dk`` (per k_link)."""
        it = self.items[i]
        ke = self.k_link * dk
        if ke == 0:
            return it["t_lin"]
        delta = it["delta0"] / (1.0 + ke * it["gvd"])
        return it["t_lin"] + ke * ((it["p"] * delta[None]) @ it["kw"])

    def derivative(self, i: int, dk: complex) -> np.ndarray:
        """Return dT/d(dk), shape (n_s, n_f), of recording ``i`` (complex derivative)."""
        it = self.items[i]
        ke = self.k_link * dk
        q = 1.0 + ke * it["gvd"]
        return self.k_link * ((it["p"] * (it["delta0"] / q**2)[None]) @ it["kw"])

    def law(self, i: int, law: _Law, theta, dk_ref: complex, n_iter: int = 60) -> tuple[np.ndarray, float]:
        """(T, sigma) of recording ``i`` with ``law`` (fixed point of sigma)."""
        sigma = self.sigma(i)
        for _ in range(n_iter):
            new = self.sigma(i, complex(law.el(sigma, theta)) - dk_ref)
            if abs(new - sigma) <= 1e-6 * max(sigma, 1e-30):
                sigma = new
                break
            sigma = 0.5 * (sigma + new)
        return self.predict(i, complex(law.el(sigma, theta)) - dk_ref), sigma


def _kernel_offsets(kw):
    """Index offsets of a symmetric kernel (centre at 0)."""
    return np.arange(kw.size) - kw.size // 2


def _weighted_residuals(preds, specs, band_masks, sigma_extra=None):
    res = []
    for k, (t, sp) in enumerate(zip(preds, specs, strict=True)):
        m = band_masks[k]
        sig = sp.sigma if sigma_extra is None else np.sqrt(sp.sigma**2 + sigma_extra[k] ** 2)
        r = ((t - sp.T) / np.maximum(sig, 1e-12))[:, m]
        res.append(r.real.ravel())
        res.append(r.imag.ravel())
    return np.concatenate(res)


# ------------------------------------------------------------------------------------- time simulation
class _TimeSim:
    """Time simulation of the reduced model (+ one local element) driven by the recorded drives.

    Per mode ``eta'' + 2 zeta w eta' + w^2 eta = p``, integrated exactly on a fine grid
    (``substeps`` per sample) in complex modal form: the drive acceleration (band-limited
    reconstruction of the drive displacement, :func:`_drive_on_grid`) with first-order hold,
    the element force held over a sub-step (one sub-step of delay, as
    :func:`exudyn_study.linear.nonlinear.simulate_local_nonlinear`).
    The linear response is computed once per recording (``lfilter``); the element's
    correction is integrated for many (parameter set, recording) jobs in parallel, vectorised.
    """

    def __init__(self, model: ReducedModel, specs: Sequence[_Spectra], substeps: int = 4) -> None:
        self.model, self.specs, self.substeps = model, list(specs), substeps
        om, ze = model.omega, model.damping_ratio
        self.wd = om * np.sqrt(1.0 - ze**2)
        self.lam = -ze * om + 1j * self.wd
        rate = specs[0].rate_hz
        self.h = h = 1.0 / (rate * substeps)
        self.mu = np.exp(self.lam * h)
        self.scale = 1.0 / (2j * self.wd)
        i0 = (self.mu - 1.0) / self.lam
        i1 = (self.mu - 1.0 - self.lam * h) / (self.lam**2 * h)
        self.n = max(sp.drive_m.size for sp in specs)
        self.n_f = (self.n - 1) * substeps + 1
        n_rec = len(specs)
        p_fine = np.zeros((n_rec, self.n_f))
        for k, sp in enumerate(specs):
            n_k = (sp.drive_m.size - 1) * substeps + 1
            p_fine[k, :n_k] = -_drive_on_grid(sp.drive_m, rate, substeps, 0 if sp.force else 2)
        xi = np.empty((n_rec, om.size, self.n_f), complex)
        for r in range(om.size):
            b = np.array([i1[r], i0[r] - i1[r]]) * self.scale[r]
            xi[:, r, :] = scipy.signal.lfilter(b, [1.0, -self.mu[r]], p_fine, axis=-1)
        self.eta = 2.0 * xi.real  # (R, m, n_f)
        self.eta_t = 2.0 * (self.lam[None, :, None] * xi).real
        samp = slice(0, self.n_f, substeps)
        eta_dd = (
            p_fine[:, None, samp]
            - om[None, :, None] ** 2 * self.eta[..., samp]
            - (2 * ze * om)[None, :, None] * self.eta_t[..., samp]
        )
        a_b = -p_fine[:, samp]
        acc = model.direct * a_b[:, None, :] + np.einsum("sm,rmn->rsn", model.psi, eta_dd)
        if np.any(model.upper != 0):
            spec = np.fft.rfft(a_b, axis=-1)
            wf = TWO_PI * np.fft.rfftfreq(a_b.shape[-1], 1.0 / rate)
            acc = acc + np.fft.irfft(
                model.upper[None, :, None] * (wf**2 * spec)[:, None, :], a_b.shape[-1], axis=-1
            )
        self.acc_lin = acc  # (R, n_s, n)

    def run(self, pair, law: _Law, jobs, dk_ref=0j, w_ref: float = 1.0) -> np.ndarray:
        """Accelerations ``(n_jobs, n_channels, n_samples)`` for jobs ``[(theta, recording index), ...]``.

        The element force per ``k_link`` is ``law(delta) - Re(dk_ref) delta - Im(dk_ref)/w_ref delta'``
        (the reference level's equivalent stiffness is already in the identified modes); ``dk_ref``
        is one complex number or one per job. Jobs that diverge come back as NaN.
        """
        model = self.model
        om, ze, lam, mu = model.omega, model.damping_ratio, self.lam, self.mu
        v, w, k_link = model.coupling(pair)
        idx = np.array([k for _, k in jobs], dtype=int)
        th = np.array([np.asarray(t, float) for t, _ in jobs])
        th_cols = [th[:, j].copy() for j in range(th.shape[1])]
        bsz = len(jobs)
        dkr = np.broadcast_to(np.asarray(dk_ref, complex), (bsz,))
        k_re, c_re = dkr.real.copy(), dkr.imag / w_ref
        linear_ref = bool(np.any(k_re != 0.0) or np.any(c_re != 0.0))
        # the reference de-embedding acts on the total delta: its linear-response part is precomputed
        dl = np.einsum("m,rmn->rn", v, self.eta)[idx]  # (B, n_f)
        ref_lin = None
        if linear_ref:
            dlt = np.einsum("m,rmn->rn", v, self.eta_t)[idx]
            ref_lin = -(k_re[:, None] * dl + c_re[:, None] * dlt)  # (B, n_f)
        g_r = -(mu - 1.0) / lam * self.scale * w * k_link
        m = om.size
        xi = np.zeros((bsz, m), complex)
        state = law.init_state(bsz)
        r_out = np.zeros((bsz, self.n))
        xi_out = np.zeros((bsz, m, self.n), complex)
        bad = np.zeros(bsz, bool)
        # delta = Re(xi . 2v) (+ linear part); delta' = Re(xi . 2 v lam): one matmul for both
        proj = np.column_stack([2.0 * v, 2.0 * v * lam]).astype(complex)
        with np.errstate(all="ignore"):  # a diverging job is detected and returned as NaN
            self._loop(
                law.step,
                dl,
                proj,
                ref_lin,
                k_re,
                c_re,
                linear_ref,
                th_cols,
                state,
                xi,
                mu,
                g_r,
                r_out,
                xi_out,
                bad,
            )
            eta_c = 2.0 * xi_out.real
            eta_ct = 2.0 * (lam[None, :, None] * xi_out).real
            eta_cdd = (
                -(w * k_link)[None, :, None] * r_out[:, None, :]
                - om[None, :, None] ** 2 * eta_c
                - (2 * ze * om)[None, :, None] * eta_ct
            )
            acc = self.acc_lin[idx] + np.einsum("sm,bmn->bsn", model.psi, eta_cdd)
        acc[bad] = np.nan
        return acc

    def _loop(
        self, step, dl, proj, ref_lin, k_re, c_re, linear_ref, th_cols, state, xi, mu, g_r, r_out, xi_out, bad
    ):
        sub = self.substeps
        g_row = g_r[None, :]
        for kf in range(self.n_f):
            z = (xi @ proj).real  # (B, 2): correction delta and delta'
            delta = dl[:, kf] + z[:, 0]
            force, state = step(delta, state, th_cols)
            if linear_ref:
                force = force + ref_lin[:, kf] - k_re * z[:, 0] - c_re * z[:, 1]
            if kf % sub == 0:
                ks = kf // sub
                r_out[:, ks] = force
                xi_out[:, :, ks] = xi
            xi = mu * xi + force[:, None] * g_row
            if kf % 1024 == 0:
                blown = ~np.isfinite(xi).all(axis=1) | (np.abs(xi).max(axis=1) > 1e6)
                if blown.any():
                    bad |= blown
                    xi[blown] = 0.0
        bad |= ~np.isfinite(xi).all(axis=1) | ~np.isfinite(r_out).all(axis=1)


def _sim_T(specs, k: int, acc: np.ndarray, settings) -> np.ndarray | None:
    """Welch H1 transmissibility of simulated accelerations on the lines of ``specs[k]`` (None if NaN)."""
    sp = specs[k]
    n = sp.drive_m.size
    if not np.all(np.isfinite(acc[:, :n])):
        return None
    frf = _welch_T(sp.drive_acc, acc[:, :n], sp.rate_hz, settings.resolution_hz, sp.rate_hz / 2)
    sel = np.searchsorted(frf.freq_hz, sp.freq_hz - 1e-9)
    return frf.H[:, 0, sel]


def _rel_error(t_model, sp: _Spectra, mask) -> np.ndarray:
    """Relative FRF error per channel over the masked lines: ||T_model - T|| / ||T||."""
    if t_model is None:
        return np.full(sp.T.shape[0], np.inf)
    num = np.linalg.norm((t_model - sp.T)[:, mask], axis=1)
    return num / np.maximum(np.linalg.norm(sp.T[:, mask], axis=1), 1e-30)


# ------------------------------------------------------------------------------------- compare
@dataclass(frozen=True, eq=False)
class Comparison:
    """Nominal model against every recording, per channel and band.

    Attributes
    ----------
    labels : tuple of str
        Recordings (reference first, then train, then held-out; duplicates of the reference kept).
    levels : ndarray, shape (n_rec,)
        Drive acceleration rms in m/s^2 (force rms in N for a force drive).
    bands_hz : ndarray, shape (n_bands, 2)
        Frequency bands (one per identified mode, split at the geometric means).
    statistic : ndarray, shape (n_rec, n_channels, n_bands)
        Residual chi-square per degree of freedom (1 expected for a right model).
    p_value : ndarray, shape (n_rec, n_channels, n_bands)
    rel_error : ndarray, shape (n_rec, n_channels, n_bands)
        ||T_model - T|| / ||T|| in the band.
    significant : ndarray of bool, shape (n_rec, n_channels, n_bands)
        p below the Bonferroni level and the relative error above ``min_effect``.
    coherence : ndarray, shape (n_rec, n_channels)
        Mean coherence in the analysis band (harmonic distortion lowers it).
    residual_map : ndarray, shape (n_rec, n_channels, n_freq)
        ``|T_model - T|^2 / sigma^2`` per line (for the residual map figure).
    """

    labels: tuple
    levels: np.ndarray
    bands_hz: np.ndarray
    statistic: np.ndarray
    p_value: np.ndarray
    rel_error: np.ndarray
    significant: np.ndarray
    coherence: np.ndarray
    residual_map: np.ndarray


def _mode_bands(model: ReducedModel, band) -> np.ndarray:
    f = np.sort(model.frequency_hz)
    edges = [band[0]] + [math.sqrt(a * b) for a, b in zip(f[:-1], f[1:], strict=True)] + [band[1]]
    return np.array([(lo, hi) for lo, hi in zip(edges[:-1], edges[1:], strict=True) if hi > lo])


def _compare(model, specs, kerns, ref: _Spectra, settings: GenericSettings, labels) -> Comparison:
    bands = _mode_bands(model, (float(ref.freq_hz[0]), float(ref.freq_hz[-1])))
    n_rec, n_s, n_b = len(specs), ref.T.shape[0], len(bands)
    stat = np.zeros((n_rec, n_s, n_b))
    pval = np.ones((n_rec, n_s, n_b))
    rel = np.zeros((n_rec, n_s, n_b))
    rmap = np.zeros((n_rec, n_s, ref.freq_hz.size))
    coh = np.zeros((n_rec, n_s))
    kappa = settings.correlation_factor
    for i, (sp, kern) in enumerate(zip(specs, kerns, strict=True)):
        t_mod = model.transmissibility(sp.freq_hz, kern)
        var = sp.sigma**2 + ref.sigma**2
        z = np.abs(t_mod - sp.T) ** 2 / np.maximum(var, 1e-300)
        rmap[i] = z
        coh[i] = sp.coherence.mean(axis=1)
        for b, (lo, hi) in enumerate(bands):
            m = (sp.freq_hz >= lo) & ((sp.freq_hz < hi) | (b == n_b - 1))
            n = int(m.sum())
            if n == 0:
                continue
            chi = 2.0 * z[:, m].sum(axis=1)  # ~ chi2(2n) for a right model, independent lines
            stat[i, :, b] = chi / (2 * n)
            pval[i, :, b] = scipy.stats.chi2.sf(chi / kappa, 2 * n / kappa)
            rel[i, :, b] = np.linalg.norm((t_mod - sp.T)[:, m], axis=1) / np.maximum(
                np.linalg.norm(sp.T[:, m], axis=1), 1e-30
            )
    level = settings.alpha / pval.size
    sig = (pval < level) & (rel > settings.min_effect)
    return Comparison(
        tuple(labels), np.array([sp.level for sp in specs]), bands, stat, pval, rel, sig, coh, rmap
    )


# ------------------------------------------------------------------------------------- locate
def _fit_dk(el: _EL, specs, idx, masks) -> tuple[np.ndarray, float]:
    """Per-recording complex stiffness change (per k_link) at the interface: (dk (n,), chi2)."""
    dks, chi = [], 0.0
    for i in idx:
        sp = specs[i]
        m = masks[i]
        wgt = 1.0 / np.maximum(sp.sigma[:, m], 1e-12)
        t_meas = sp.T[:, m]

        def res(x, i=i, m=m, wgt=wgt, t_meas=t_meas):
            r = ((el.predict(i, complex(x[0], x[1]))[:, m] - t_meas) * wgt).ravel()
            return np.concatenate([r.real, r.imag])

        def jac(x, i=i, m=m, wgt=wgt):
            d = (el.derivative(i, complex(x[0], x[1]))[:, m] * wgt).ravel()
            return np.column_stack([np.concatenate([d.real, d.imag]), np.concatenate([-d.imag, d.real])])

        best = None
        for x0 in ((0.0, 0.0), (-0.3, 0.1), (0.3, 0.0)):
            try:
                sol = scipy.optimize.least_squares(
                    res, np.array(x0), jac=jac, method="lm", x_scale=0.1, max_nfev=100
                )
            except (ValueError, np.linalg.LinAlgError):
                continue
            if best is None or sol.cost < best.cost:
                best = sol
            if 2.0 * best.cost < 1.5 * (2 * t_meas.size):
                break  # as good as the noise allows
        dks.append(complex(best.x[0], best.x[1]))
        chi += 2.0 * best.cost
    return np.array(dks), chi


def _chi2_nominal(el: _EL, specs, idx, masks) -> float:
    out = 0.0
    for i in idx:
        m = masks[i]
        r = (el.predict(i, 0j) - specs[i].T)[:, m] / np.maximum(specs[i].sigma[:, m], 1e-12)
        out += float(np.sum(np.abs(r) ** 2))
    return out


def _modal_shifts(model: ReducedModel, pair, k_link_dk: complex):
    """(frequency_hz, damping_ratio, MAC) of the modes with a complex link stiffness change added."""
    v, w, _ = model.coupling(pair)
    om, ze = model.omega, model.damping_ratio
    n = om.size
    kmat = np.diag(om**2).astype(complex) + k_link_dk.real * np.outer(w, v)
    cmat = np.diag(2 * ze * om).astype(complex)
    # hysteretic part as viscous at each mode's frequency: iterate once per mode
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-kmat, -cmat]])
    lam, vec = np.linalg.eig(a)
    f, z, mac = np.zeros(n), np.zeros(n), np.zeros(n)
    keep = np.flatnonzero(lam.imag > 0)
    for r in range(n):
        # the eigenvalue nearest to the reference mode r
        j = keep[np.argmin(np.abs(np.abs(lam[keep]) - om[r]))]
        wr = abs(lam[j])
        ch = k_link_dk.imag * np.outer(w, v) / max(wr, 1e-9)
        a2 = np.block([[np.zeros((n, n)), np.eye(n)], [-kmat, -(cmat + ch)]])
        l2, vec2 = np.linalg.eig(a2)
        j2 = np.argmin(np.abs(l2 - lam[j]))
        f[r] = abs(l2[j2]) / TWO_PI
        z[r] = -l2[j2].real / abs(l2[j2])
        phi_new = model.psi @ vec2[:n, j2]
        phi_ref = model.psi[:, r]
        mac[r] = abs(np.vdot(phi_ref, phi_new)) ** 2 / (
            np.vdot(phi_ref, phi_ref).real * np.vdot(phi_new, phi_new).real
        )
    return f, z, mac


# ------------------------------------------------------------------------------------- fit candidates
@dataclass
class _Candidate:
    law: _Law
    theta: np.ndarray | None = None
    std: np.ndarray | None = None
    rejected: str = ""
    bic: float = math.inf
    chi2: float = math.inf
    dk_ref: complex = 0j
    drift: str = ""
    errors: dict = field(default_factory=dict)  # 'train_after', 'holdout_after' per (rec, channel)
    signature_score: float = 0.0
    holdout_after: float = math.inf
    accs: dict = field(default_factory=dict)


def _signature_score(law: _Law, dk_levels: np.ndarray) -> float:
    """How well the observed link-stiffness change with level matches the law's documented signature.

    1: frequency and damping shifts in the documented directions; 0.5: frequency direction right,
    damping not; 0: frequency direction wrong (the law cannot produce the observation).
    """
    top = dk_levels[np.argmax(np.abs(dk_levels))]
    f_dir = np.sign(top.real) if abs(top.real) > 1e-3 else 0.0
    damp_rel = top.imag / max(abs(top), 1e-12)
    d_dir = 1.0 if damp_rel > 0.1 else (-1.0 if damp_rel < -0.1 else 0.0)
    want_f, want_d = law.signature
    if f_dir != want_f:
        return 0.0
    return 1.0 if d_dir == want_d else 0.5


def _el_fit(el: _EL, law: _Law, specs, idx, masks, ref_i: int | None, sigma_ref: float):
    """Equivalent-linear least-squares fit of ``law`` on recordings ``idx``; returns (theta, cost)."""
    lo, hi = law.bounds()

    def res(x):
        theta = law.from_internal(x)
        dk_ref = complex(law.el(sigma_ref, theta))
        out = []
        for i in idx:
            t, _ = el.law(i, law, theta, dk_ref)
            m = masks[i]
            r = ((t - specs[i].T)[:, m] / np.maximum(specs[i].sigma[:, m], 1e-12)).ravel()
            out.extend([r.real, r.imag])
        return np.concatenate(out)

    sig_max = max(el.sigma(i) for i in idx)
    best = None
    for x0 in law.start(sig_max):
        x0 = np.clip(x0, lo + 1e-6, hi - 1e-6)
        try:
            sol = scipy.optimize.least_squares(res, x0, bounds=(lo, hi), x_scale=1.0, max_nfev=60)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    return (None, math.inf) if best is None else (law.from_internal(best.x), float(best.cost))


def _time_residuals(
    tsim: _TimeSim, pair, law: _Law, thetas, idx, specs, masks, settings, dk_refs, w_ref, extra=(), cache=None
):
    """Weighted residual vectors of the time-simulated model, one per parameter set (None if it diverged).

    Recordings ``extra`` are simulated in the same batch (not part of the residuals); with a
    ``cache`` dict, the accelerations of every recording are kept under ``tuple(theta)``.
    """
    recs = list(idx) + [k for k in extra if k not in idx]
    jobs = [(th, k) for th in thetas for k in recs]
    dks = [dk_refs[j // len(recs)] for j in range(len(jobs))]
    accs = tsim.run(pair, law, jobs, np.array(dks, complex), w_ref)
    out = []
    for p, th in enumerate(thetas):
        block = accs[p * len(recs) : (p + 1) * len(recs)]
        if cache is not None:
            cache[tuple(np.asarray(th, float))] = dict(zip(recs, block, strict=True))
        parts = []
        for q, k in enumerate(idx):
            t = _sim_T(specs, k, block[q], settings)
            if t is None:
                parts = None
                break
            m = masks[k]
            r = ((t - specs[k].T)[:, m] / np.maximum(specs[k].sigma[:, m], 1e-12)).ravel()
            parts.extend([r.real, r.imag])
        out.append(None if parts is None else np.concatenate(parts))
    return out


def _time_fit(
    tsim,
    pair,
    law: _Law,
    theta0,
    idx,
    specs,
    masks,
    settings,
    sigma_ref,
    w_ref,
    iterations=3,
    extra=(),
    cache=None,
):
    """Levenberg-Marquardt refinement by time simulation (Jacobian by batched finite differences).

    Every evaluation is one vectorised run: the base point with its Jacobian columns, or three
    damped steps together. Returns (theta, std, chi2, n_residuals, max |correlation|).
    """
    lo, hi = law.bounds()
    x = np.clip(law.to_internal(theta0), lo + 1e-6, hi - 1e-6)
    p = x.size
    step = 0.02

    def evaluate(xs):
        ths = [law.from_internal(xx) for xx in xs]
        dks = [complex(law.el(sigma_ref, th)) for th in ths]
        return _time_residuals(tsim, pair, law, ths, idx, specs, masks, settings, dks, w_ref, extra, cache)

    jac, r0 = None, None
    for it in range(iterations + 1):
        rs = evaluate([x] + [x + step * np.eye(p)[j] for j in range(p)])
        if rs[0] is None:
            if r0 is None:
                return None, None, math.inf, 0, 1.0
            break
        r0 = rs[0]
        if any(r is None for r in rs[1:]):
            break
        jac = np.column_stack([(r - r0) / step for r in rs[1:]])
        if it == iterations:
            break
        jtj, jtr = jac.T @ jac, jac.T @ r0
        dg = np.diag(np.diag(jtj) + 1e-12)
        trials = [np.clip(x - np.linalg.solve(jtj + lam * dg, jtr), lo, hi) for lam in (1e-3, 1e-1, 10.0)]
        rt = evaluate(trials)
        costs = [math.inf if r is None else float(r @ r) for r in rt]
        b = int(np.argmin(costs))
        if not costs[b] < float(r0 @ r0):
            break
        dx = trials[b] - x
        x = trials[b]
        if np.max(np.abs(dx)) < 2e-3:
            r0 = rt[b]
            break
    theta = law.from_internal(x)
    if jac is None:
        return theta, np.full(p, np.inf), float(r0 @ r0), r0.size, 1.0
    cov = _covariance(jac, r0)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    std = np.array([t * sd[j] if law.params[j].log else sd[j] for j, t in enumerate(theta)])
    corr = cov / np.maximum(np.outer(sd, sd), 1e-300)
    max_corr = float(np.max(np.abs(corr - np.diag(np.diag(corr))))) if p > 1 else 0.0
    at_bound = [j for j in range(p) if min(abs(x[j] - lo[j]), abs(x[j] - hi[j])) < 1e-3]
    if at_bound:
        std = std.copy()
        std[at_bound] = np.inf
    return theta, std, float(r0 @ r0), r0.size, max_corr


def _check_identifiable(law: _Law, theta, std, max_rel_std, max_corr: float = 0.0) -> str:
    """'' if every parameter is determined (relative std, correlation, not at a bound), else why not."""
    bad = [
        f"{p.name} = {t:.3g} +- {s:.2g} {p.unit}"
        for p, t, s in zip(law.params, theta, std, strict=True)
        if not (math.isfinite(s) and s <= max_rel_std * abs(t))
    ]
    if max_corr > 0.995:
        bad.append(f"parameters correlated ({max_corr:.4f})")
    if bad:
        return "parameters not identifiable from the training recordings (" + "; ".join(bad) + ")"
    return ""


def _drift(el: _EL, law: _Law, theta, specs, idx, masks, sigma_ref) -> str:
    """Fit ``law`` to each training recording alone (equivalent-linear); report parameters that drift."""
    if len(idx) < 2:
        return ""
    per = []
    for i in idx:
        th, _ = _el_fit(el, law, specs, [i], masks, None, sigma_ref)
        if th is not None:
            per.append((specs[i].label, th))
    msgs = []
    for j, p in enumerate(law.params):
        vals = np.array([th[j] for _, th in per])
        if vals.size < 2:
            continue
        ratio = (
            vals.max() / max(vals.min(), 1e-300)
            if p.log
            else 1.0 + abs(vals.max() - vals.min()) / max(abs(theta[j]), 1e-300)
        )
        if ratio > 3.0:
            desc = ", ".join(f"{lab}: {th[j]:.3g}" for lab, th in per)
            msgs.append(f"{p.name} drifts between training recordings ({desc} {p.unit})")
    return "; ".join(msgs)


# ------------------------------------------------------------------------------------- main
def _fmt_level(x: float, unit: str = "m/s^2") -> str:
    return f"{x:.3g} {unit}"


def diagnose_generic(
    reference: Recording,
    train: Sequence[Recording],
    holdout: Sequence[Recording],
    interfaces=None,
    *,
    settings: GenericSettings | None = None,
    labels=None,
    progress=None,
    figures: dict | None = None,
    drive_point: str | None = None,
) -> Diagnosis:
    """Diagnose a structure tested at several levels against its lowest-level linear modal model.

    Parameters
    ----------
    reference : Recording
        The lowest-level recording: the linear modal model is identified from it. It may also
        be one of ``train``.
    train : sequence of Recording
        Recordings used for fitting (other levels); same sensor layout as ``reference``.
    holdout : sequence of Recording
        Recordings never used for fitting (other levels or signals), for the proof.
    interfaces : mapping name -> (sensor_a, sensor_b), or sequence of pairs, optional
        Declared joints as sensor pairs across them (``'drive'``: the table). Default: every
        sensor pair and every sensor-to-table pair is a candidate location.
    settings : GenericSettings, optional
    labels : mapping, optional
        ``{'reference': str, 'train': [str], 'holdout': [str]}`` names for the report (e.g. files).
    progress : callable(str), optional
        Receives one line per stage.
    drive_point : str, optional
        Force drive only: the accelerometer at the force (default: the response channel at the
        force channel's position).
    figures : dict, optional
        If given, filled with the arrays the report draws
        (:func:`~exudyn_study.diagnose.report.write_report`).

    Returns
    -------
    Diagnosis
        ``mismatch_found`` False ("no missing physics found") when no cell is significant.

    Raises
    ------
    InputError
        See :func:`check_recordings`; also a reference without resonances in the excited band.
    """
    with StatusProgress("diagnosis (generic path)") as status:

        def say(text: str) -> None:
            log.info(text)
            status(text)
            if progress is not None:
                progress(text)

        return _diagnose_generic(reference, train, holdout, interfaces, settings, labels, say, figures,
                                 drive_point)


def _diagnose_generic(reference, train, holdout, interfaces, settings, labels, say, figures, drive_point):
    """Run the stages of :func:`diagnose_generic`, reporting with ``say(text)``."""
    t_start = time.perf_counter()
    settings = settings or GenericSettings()
    train, holdout = list(train or ()), list(holdout or ())
    layout, names, itfs = check_recordings(reference, train, holdout, interfaces)
    declared = interfaces is not None
    labels = dict(labels or {})
    ref_label = str(labels.get("reference") or _label(reference, "reference"))
    tr_labels = list(labels.get("train") or [names[("train", i)] for i in range(len(train))])
    ho_labels = list(labels.get("holdout") or [names[("holdout", i)] for i in range(len(holdout))])

    say("spectra: FRFs (H1) and coherence of every recording against the drive")
    ref0 = _spectra(reference, layout, ref_label, settings, None)
    band = tuple(settings.band_hz) if settings.band_hz else _auto_band(ref0)
    ref = _spectra(reference, layout, ref_label, settings, band)
    specs = [ref] + [
        _spectra(r, layout, lab, settings, band) for r, lab in zip(train, tr_labels, strict=True)
    ]
    specs += [_spectra(r, layout, lab, settings, band) for r, lab in zip(holdout, ho_labels, strict=True)]
    unit = "N" if layout.force else "m/s^2"
    lowest = min(specs, key=lambda sp: sp.level)
    if lowest.level < 0.8 * ref.level:
        warnings.warn(
            f"recording {lowest.label!r} has a lower drive level ({_fmt_level(lowest.level, unit)}) than "
            f"the model reference {ref_label!r} ({_fmt_level(ref.level, unit)}); identify the model from the "
            "lowest level",
            stacklevel=2,
        )
    n_tr = len(train)
    tr_idx = list(range(1, 1 + n_tr))
    ho_idx = list(range(1 + n_tr, len(specs)))
    say(f"model: linear modal model from the reference {ref_label!r} ({band[0]:.3g}-{band[1]:.3g} Hz)")
    if layout.force:
        drive_point = _drive_point(reference, layout, drive_point)
    model = identify_reduced_model(ref, layout.channels, drive_point=drive_point)
    kerns = [_grid(sp) for sp in specs]
    say("compare: residuals per recording, channel and band against the measurement noise")
    comp = _compare(model, specs, kerns, ref, settings, [sp.label for sp in specs])
    meta = {
        "path": "generic",
        "model": f"modal:{ref_label}",
        "reference": ref_label,
        "train": tr_labels,
        "holdout": ho_labels,
        "band_hz": list(band),
        "drive": "force" if layout.force else "displacement",
        "level_unit": unit,
        "levels": {sp.label: sp.level for sp in specs},
        "modes": [
            {"frequency_hz": float(f), "damping_ratio": float(z)}
            for f, z in zip(model.frequency_hz, model.damping_ratio, strict=True)
        ],
        "masses": {c: float(m) for c, m in zip(model.channels, model.masses, strict=True)},
        "mass_unit": "kg"
        if layout.force
        else "relative (sum 1; the scale is unobservable with a displacement drive)",
        "masses_estimated": bool(model.masses_estimated),
        "coherence": {sp.label: float(c) for sp, c in zip(specs, comp.coherence.mean(axis=1), strict=True)},
        "significance": {
            "alpha": settings.alpha,
            "min_effect": settings.min_effect,
            "significant_cells": int(comp.significant.sum()),
            "cells": int(comp.significant.size),
        },
    }
    if figures is not None:
        figures.update(
            level_unit=unit,
            channels=list(layout.channels),
            freq_hz=ref.freq_hz,
            labels=[sp.label for sp in specs],
            levels=comp.levels,
            residual_map=comp.residual_map,
            bands_hz=comp.bands_hz,
            measured={sp.label: sp.T for sp in specs},
            train=[specs[i].label for i in tr_idx],
            holdout=[specs[i].label for i in ho_idx],
        )
    sig_rec = comp.significant.any(axis=(1, 2))
    if not sig_rec.any():
        meta["wall_time_s"] = time.perf_counter() - t_start
        meta["summary"] = (
            "no missing physics found: every recording agrees with the linear modal model of "
            "the reference within its own noise"
        )
        return Diagnosis(False, (), (), meta)

    # ---- locate
    sens_score = comp.statistic.max(axis=(0, 2)) * comp.significant.any(axis=(0, 2))
    sensors = [layout.channels[i] for i in np.argsort(-sens_score) if sens_score[i] > 0]
    sig_bands = comp.significant.any(axis=(0, 1))
    mband = (float(comp.bands_hz[sig_bands, 0].min()), float(comp.bands_hz[sig_bands, 1].max()))
    masks = [(sp.freq_hz >= mband[0]) & (sp.freq_hz <= mband[1]) for sp in specs]
    lv = comp.levels
    higher = lv > 1.2 * ref.level
    level_dep = bool(np.any(sig_rec & higher)) and not bool(np.any(sig_rec & ~higher))
    # with several mismatching recordings, the mismatch must also grow with the level (a constant
    # difference, e.g. a sensor gain, is not level dependent)
    size = comp.rel_error.mean(axis=(1, 2))
    sig_lv = np.flatnonzero(sig_rec)
    if sig_lv.size >= 2:
        lo_i, hi_i = sig_lv[np.argmin(lv[sig_lv])], sig_lv[np.argmax(lv[sig_lv])]
        if lv[hi_i] >= 1.5 * lv[lo_i]:
            level_dep = level_dep and bool(size[hi_i] >= 1.5 * size[lo_i])
    fit_idx = [i for i in tr_idx if sig_rec[i]]
    say(
        f"locate: mismatch at {', '.join(sensors)} in {mband[0]:.3g}-{mband[1]:.3g} Hz"
        f"{', growing with level' if level_dep else ''}; searching {len(itfs)} interface(s)"
    )
    if not fit_idx:
        return _only_unexplained(
            meta,
            t_start,
            sensors,
            mband,
            level_dep,
            "the training recordings show no significant mismatch (only the held-out "
            "ones do), so nothing can be fitted; train on a level that shows it",
        )
    scores = []
    for name, pair in itfs.items():
        el = _EL(model, pair, specs, kerns)
        dk, chi = _fit_dk(el, specs, fit_idx, masks)
        scores.append((chi, name, pair, dk, el))
    scores.sort(key=lambda s: s[0])
    chi0 = _chi2_nominal(scores[0][4], specs, fit_idx, masks)
    chi_best, itf_name, pair, dk_levels, el = scores[0]
    n_res = sum(2 * int(masks[i].sum()) * len(layout.channels) for i in fit_idx)
    # a local stiffness change must explain most of the excess of chi2 over its expectation (n_res)
    explained = (chi0 - chi_best) / max(chi0 - n_res, 1e-12)
    located = chi0 > n_res and explained > 0.5
    meta["interface_search"] = [{"interface": s[1], "chi2": float(s[0])} for s in scores[:5]]
    meta["chi2_nominal"] = float(chi0)
    meta["chi2_expected"] = n_res
    sigmas = np.array([el.sigma(i) for i in range(len(specs))])
    sigma_ref = sigmas[0]
    shifts = []
    for i, dk in zip(fit_idx, dk_levels, strict=True):
        f, z, mac = _modal_shifts(model, pair, el.k_link * dk)
        shifts.append(
            {
                "recording": specs[i].label,
                "level": float(lv[i]),
                "link_stiffness_change": [float(dk.real), float(dk.imag)],
                "frequency_hz": f.tolist(),
                "damping_ratio": z.tolist(),
                "mac": mac.tolist(),
            }
        )
    meta["paired_modes"] = shifts
    if not located:
        return _only_unexplained(
            meta,
            t_start,
            sensors,
            mband,
            level_dep,
            "no single interface explains the mismatch with a local stiffness change "
            f"(best {itf_name}: chi2 {chi_best:.3g} vs {chi0:.3g} nominal)",
        )
    location = {
        "sensors": sensors,
        "component": itf_name if declared and not _is_pair_name(itf_name, pair) else None,
        "interface": f"{pair[0]}-{pair[1]}",
    }

    # ---- name and fit
    w_ref = _mean_omega(el, 0, model)
    say(f"name: scoring {len(CANDIDATES)} candidate laws at {pair[0]}-{pair[1]} by their signature")
    substeps = max(settings.substeps, math.ceil(1.0 / (ref.rate_hz * settings.max_step_s) - 1e-9))
    tsim = _TimeSim(model, specs, substeps)
    all_idx = tr_idx + ho_idx
    nominal = {
        i: _rel_error(_sim_T(specs, i, tsim.acc_lin[i], settings), specs[i], masks[i]) for i in all_idx
    }
    cands = []
    for law in CANDIDATES.values():
        c = _Candidate(law, signature_score=_signature_score(law, dk_levels))
        cands.append(c)
        if c.signature_score == 0:
            c.rejected = "its signature does not fit (frequency shift with level in the other direction)"
            continue
        say(f"fit: {law.name} (equivalent-linear start, time-simulation refinement)")
        th_el, _ = _el_fit(el, law, specs, fit_idx, masks, 0, sigma_ref)
        if th_el is None:
            c.rejected = "the equivalent-linear fit failed"
            continue
        cache: dict = {}
        theta, std, chi, n_r, max_corr = _time_fit(
            tsim,
            pair,
            law,
            th_el,
            fit_idx,
            specs,
            masks,
            settings,
            sigma_ref,
            w_ref,
            extra=all_idx,
            cache=cache,
        )
        if theta is None:
            c.rejected = "the time simulation diverged"
            continue
        c.theta, c.std, c.chi2 = theta, std, chi
        c.bic = chi + law.params.__len__() * math.log(max(n_r, 2))
        c.dk_ref = complex(law.el(sigma_ref, theta))
        c.rejected = _check_identifiable(law, theta, std, settings.max_rel_std, max_corr)
        if not c.rejected:
            c.drift = _drift(el, law, theta, specs, fit_idx, masks, sigma_ref)
            if c.drift:
                c.rejected = c.drift
        accs = cache.get(tuple(np.asarray(theta, float)))
        if accs is None:
            run = tsim.run(pair, law, [(theta, i) for i in all_idx], c.dk_ref, w_ref)
            accs = dict(zip(all_idx, run, strict=True))
        c.accs = accs
        c.errors = {i: _rel_error(_sim_T(specs, i, accs[i], settings), specs[i], masks[i]) for i in all_idx}
    before_ho = float(np.mean([nominal[i].mean() for i in ho_idx]))
    ok = []
    for c in cands:
        if c.rejected:
            continue
        c.holdout_after = float(np.mean([c.errors[i].mean() for i in ho_idx]))
        blown = [specs[i].label for i in all_idx if not np.all(np.isfinite(c.errors[i]))]
        if blown:
            c.rejected = f"the fitted element makes the time simulation diverge on {', '.join(blown)}"
        elif not c.holdout_after < before_ho:
            c.rejected = f"held-out error not reduced ({before_ho:.3g} -> {c.holdout_after:.3g})"
        else:
            ok.append(c)
    # choose by held-out error; within 10 % of the best held-out error the information criterion decides
    chosen = None
    if ok:
        best_ho = min(c.holdout_after for c in ok)
        close = [c for c in ok if c.holdout_after <= 1.1 * best_ho]
        chosen = min(close, key=lambda c: c.bic)
        for c in ok:
            if c is not chosen:
                c.rejected = (
                    f"explains less: held-out error {c.holdout_after:.3g} vs {chosen.holdout_after:.3g}, "
                    f"BIC {c.bic:.4g} vs {chosen.bic:.4g}"
                )
    meta["candidates"] = [
        {
            "physics": c.law.name,
            "signature_score": c.signature_score,
            "bic": c.bic,
            "holdout_after": c.holdout_after,
            "parameters": None if c.theta is None else c.theta.tolist(),
            "rejected": c.rejected or None,
        }
        for c in cands
    ]
    meta["wall_time_s"] = time.perf_counter() - t_start
    if figures is not None:
        figures.update(
            located_sensors=list(pair if pair[0] != GROUND else pair[1:]),
            interface=location["interface"],
            nominal_T={specs[i].label: _sim_T(specs, i, tsim.acc_lin[i], settings) for i in all_idx},
        )
    if chosen is None:
        tried = "; ".join(f"{c.law.name}: {c.rejected}" for c in cands)
        return _only_unexplained(
            meta,
            t_start,
            sensors,
            mband,
            level_dep,
            f"the mismatch is located at interface {pair[0]}-{pair[1]} but no candidate "
            f"explains it ({tried})",
            location,
        )
    law, theta = chosen.law, chosen.theta
    after_T = {specs[i].label: _sim_T(specs, i, chosen.accs[i], settings) for i in all_idx}
    if figures is not None:
        figures.update(after_T=after_T, physics=law.name)
    per_channel = {
        specs[i].label: {
            ch: {"before": float(nominal[i][s]), "after": float(chosen.errors[i][s])}
            for s, ch in enumerate(layout.channels)
        }
        for i in all_idx
    }
    fit = {
        "train_before": float(np.mean([nominal[i].mean() for i in tr_idx])),
        "train_after": float(np.mean([chosen.errors[i].mean() for i in tr_idx])),
        "holdout_before": float(np.mean([nominal[i].mean() for i in ho_idx])),
        "holdout_after": float(np.mean([chosen.errors[i].mean() for i in ho_idx])),
        "metric": (
            f"relative FRF error ||T_sim - T_meas|| / ||T_meas|| in {mband[0]:.3g}-{mband[1]:.3g} Hz, "
            "mean over channels and recordings; T = H1 transmissibility (response per drive "
            "acceleration) of the time-simulated model driven by the recorded drive"
        ),
        "per_channel": per_channel,
    }
    params = {
        p.name: {"value": float(t), "unit": p.unit, "std": float(s) if math.isfinite(s) else None}
        for p, t, s in zip(law.params, theta, chosen.std, strict=True)
    }
    expl = _explain(
        chosen,
        cands,
        pair,
        sensors,
        mband,
        shifts,
        model,
        comp,
        fit,
        specs,
        tr_idx,
        ho_idx,
        level_dep,
        sigmas,
    )
    finding = Finding(law.name, location, mband, level_dep, expl, params, fit)
    meta["summary"] = f"{law.name} at {pair[0]}-{pair[1]}"
    meta["wall_time_s"] = time.perf_counter() - t_start
    return Diagnosis(True, (finding,), (), meta)


def _drive_point(reference: Recording, layout: _Layout, name: str | None) -> str:
    if name is not None:
        if name not in layout.channels:
            raise InputError(
                f"drive_point {name!r} is not a response channel; expected one of {list(layout.channels)}"
            )
        return name
    pos = reference.channel(layout.drive).position_m
    if pos is not None:
        for ch in layout.channels:
            p = reference.channel(ch).position_m
            if p is not None and np.allclose(p, pos, atol=1e-6):
                return ch
    raise InputError(
        f"force drive {layout.drive!r}: no accelerometer at its position; name the drive-point "
        "accelerometer (drive_point=..., --drive-point)"
    )


def _is_pair_name(name: str, pair) -> bool:
    return name == f"{pair[0]}-{pair[1]}"


def _mean_omega(el: _EL, i: int, model: ReducedModel) -> float:
    """Rms angular frequency of the interface's relative motion in recording ``i`` (rad/s)."""
    it = el.items[i]
    w2 = np.abs(it["d0c"]) ** 2 * it["ga"]
    if not np.sum(w2) > 0:
        return float(model.omega[0])
    return float(TWO_PI * math.sqrt(np.sum(it["freq_hz"] ** 2 * w2) / np.sum(w2)))


def _only_unexplained(meta, t_start, sensors, band, level_dep, why, location=None) -> Diagnosis:
    loc = location or {"sensors": sensors, "component": None, "interface": None}
    meta["wall_time_s"] = time.perf_counter() - t_start
    meta["summary"] = "mismatch found, unexplained"
    item = {
        "location": loc,
        "band_hz": list(band),
        "level_dependent": level_dep,
        "explanation": (
            f"Significant mismatch at {', '.join(sensors)} in {band[0]:.3g}-{band[1]:.3g} Hz"
            f"{' that grows with the excitation level' if level_dep else ''}; {why}."
        ),
    }
    return Diagnosis(True, (), (item,), meta)


def _explain(
    chosen: _Candidate,
    cands,
    pair,
    sensors,
    band,
    shifts,
    model,
    comp,
    fit,
    specs,
    tr_idx,
    ho_idx,
    level_dep,
    sigmas,
) -> str:
    law, theta = chosen.law, chosen.theta
    top = shifts[-1] if shifts else None
    unit = "N" if specs[0].force else "m/s^2"
    parts = []
    lv = comp.levels
    parts.append(
        f"The measured response differs from the linear model of the lowest-level recording "
        f"({_fmt_level(lv[0], unit)} rms {'force' if unit == 'N' else 'drive acceleration'}) at "
        f"{', '.join(sensors)} in "
        f"{band[0]:.3g}-{band[1]:.3g} Hz"
        + (", and the difference grows with the level." if level_dep else ".")
    )
    if top is not None:
        f0, f1 = model.frequency_hz, np.array(top["frequency_hz"])
        z0, z1 = model.damping_ratio, np.array(top["damping_ratio"])
        r = int(np.argmax(np.abs(f1 - f0) / f0))
        parts.append(
            f"At {_fmt_level(top['level'], unit)} the mode at {f0[r]:.3g} Hz has moved to {f1[r]:.3g} Hz "
            f"and its damping from {100 * z0[r]:.2g} % to {100 * z1[r]:.2g} %."
        )
    coh0, coh1 = comp.coherence[0].mean(), comp.coherence[int(np.argmax(lv))].mean()
    if coh1 < coh0 - 0.02:
        parts.append(
            f"The coherence falls from {coh0:.2f} to {coh1:.2f} at the highest level although the noise "
            "is relatively smaller there: the response contains distortion a linear model cannot make."
        )
    itf = f"{pair[0]}-{pair[1]}" if pair[0] != GROUND else f"{pair[1]} and the table"
    parts.append(
        f"A local element across {itf} explains it best (relative motion rms "
        f"{1e6 * sigmas[0]:.3g} um at the lowest and {1e6 * sigmas.max():.3g} um at the highest level)."
    )
    desc = {p.name: t for p, t in zip(law.params, theta, strict=True)}
    if law.name == "joint_friction":
        parts.append(
            f"It is friction micro-slip: {100 * desc['slip_share']:.2g} % of the joint's stiffness "
            f"acts through a contact that slips above {1e6 * desc['slip_displacement_m']:.3g} um of "
            "relative motion; as the level rises more of the contact slips, so the joint softens "
            "(frequencies drop) and dissipates energy (damping rises)."
        )
    elif law.name == "joint_stiffening":
        k3 = desc["cubic_ratio_per_m2"]
        parts.append(
            f"It is a hardening joint: its stiffness grows with the square of the relative motion "
            f"(cubic term, +{100 * 3 * k3 * sigmas.max() ** 2:.2g} % equivalent stiffness at the "
            "highest level), so the frequencies rise with level while the damping stays."
        )
    else:
        parts.append(
            f"It is a clearance: inside +-{1e6 * desc['gap_m']:.3g} um the joint is free; beyond it "
            f"contact adds {100 * desc['contact_ratio']:.2g} % of the joint's stiffness, so the "
            "frequencies rise once the gap closes at higher levels."
        )
    others = [f"{c.law.name} ({c.rejected})" for c in cands if c is not chosen and c.rejected]
    if others:
        parts.append("Rejected: " + "; ".join(others) + ".")
    parts.append(
        f"Fitted on {len(tr_idx)} training recording(s); on the held-out recording(s) the FRF error "
        f"falls from {fit['holdout_before']:.3g} to {fit['holdout_after']:.3g} "
        f"(training: {fit['train_before']:.3g} -> {fit['train_after']:.3g})."
    )
    return " ".join(parts)
