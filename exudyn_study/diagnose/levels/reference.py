"""Compare stage, second half: the reference model, and its check against its own recording.

The reference (linear) model is identified from the lowest level: PolyMAX over model orders,
automatic selection of the stable poles, LSFD with residual terms (lower and upper) weighted
by the inverse noise (+ distortion) level of every line. A peak of the residual that stands
out of the noise gets a pole of its own and the fit is repeated, so that the model holds as
many modes as the band does. The model must then reproduce its own recording per channel:
relative FRF error at most ``max(reference_tolerance, 3 x the noise's relative level)``;
otherwise :func:`check_reference` raises, naming the band and the modes that fail, since
everything diagnosed on top of a misfit would inherit it.

With a force drive and an accelerometer at the force (the drive point), the drive-point
residues scale the modes: ``m_r = 1 / phi_dp,r^2`` (kg), which must be real and positive;
a mode whose drive-point residue gives a negative or strongly complex ``phi_dp^2`` is flagged
as a degenerate mass (a wrong drive point, a sign error, or a spurious mode).
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np

from exudyn_study.diagnose.levels.frf import LevelFRF
from exudyn_study.diagnose.levels.settings import LevelSettings
from exudyn_study.errors import InputError

__all__ = ["ReferenceModel", "identify_reference", "check_reference", "synthesise", "mode_term"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class ReferenceModel:
    """Linear modal model of the reference level (accelerance form, one input).

    Attributes
    ----------
    poles : ndarray of complex, shape (n_modes,)
        rad/s, upper half plane, ascending frequency.
    residues : ndarray of complex, shape (n_out, n_modes)
        ``H(w) = sum_r R_r / (jw - p_r) + conj(R_r) / (jw - conj(p_r)) + lower + upper (jw)^2``.
    lower, upper : ndarray, shape (n_out,)
        Residual terms.
    channels : tuple of str
    band_hz : (float, float)
    check : dict
        Per channel: ``relative_error``, ``noise_level`` (relative), ``tolerance``, ``passed``.
    modal_mass_kg : ndarray, shape (n_modes,) or None
        From the drive-point residues (force drive with a drive-point accelerometer).
    degenerate : tuple of str
        One message per mode whose mass is degenerate.
    """

    poles: np.ndarray
    residues: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    channels: tuple[str, ...]
    band_hz: tuple[float, float]
    check: dict
    modal_mass_kg: np.ndarray | None
    degenerate: tuple[str, ...]

    @property
    def frequency_hz(self) -> np.ndarray:
        """Undamped natural frequencies in Hz."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        """Damping ratios (-)."""
        return -self.poles.real / np.abs(self.poles)


def mode_term(residue: np.ndarray, pole: complex, freq_hz: np.ndarray) -> np.ndarray:
    """One mode's contribution ``R / (jw - p) + conj(R) / (jw - conj(p))``, shape (n_out, n_freq)."""
    jw = 2j * np.pi * np.asarray(freq_hz, float)
    r = np.asarray(residue)[:, None]
    return r / (jw - pole) + np.conj(r) / (jw - np.conj(pole))


def synthesise(model: ReferenceModel, freq_hz: np.ndarray, poles: np.ndarray | None = None) -> np.ndarray:
    """FRFs of the model at ``freq_hz`` (optionally with other poles, same residues), (n_out, n_freq)."""
    f = np.asarray(freq_hz, float)
    jw = 2j * np.pi * f
    p = model.poles if poles is None else np.asarray(poles)
    h = model.lower[:, None] + model.upper[:, None] * jw**2 + np.zeros((model.residues.shape[0], f.size), complex)
    for k in range(p.size):
        h = h + mode_term(model.residues[:, k], p[k], f)
    return h


def _lsfd(frf: LevelFRF, poles: np.ndarray, band):
    from exudyn_study.identify.lsfd import fit_modal_model

    w = 1.0 / np.maximum(frf.total_sigma, 1e-12 * np.abs(frf.H).max())
    return fit_modal_model(frf.H[:, None, :], frf.freq_hz, poles, band_hz=band, frf_form="accelerance",
                           refine=True, weights=w[:, None, :])


def _polymax_poles(frf: LevelFRF, band, max_order: int) -> np.ndarray:
    from exudyn_study.identify.polymax import polymax
    from exudyn_study.identify.selection import select_modes

    f = frf.freq_hz
    step = float(np.min(np.diff(f)))
    if np.max(np.diff(f)) > 1.01 * step:  # detection lines between excited ones: an equidistant grid
        grid = np.arange(f[0], f[-1] + 0.5 * step, step)
        h = np.array([np.interp(grid, f, row.real) + 1j * np.interp(grid, f, row.imag) for row in frf.H])
        f = grid
    else:
        h = frf.H
    poles = polymax(h[:, None, :], f, range(2, max_order + 1), band_hz=band)
    return select_modes(poles).poles


def identify_reference(frf: LevelFRF, band: tuple[float, float], settings: LevelSettings,
                       drive_point: str | None = None, max_added: int = 12) -> ReferenceModel:
    """Identify the reference model (PolyMAX + LSFD with residuals), adding poles at unexplained peaks.

    Parameters
    ----------
    frf : LevelFRF
        The reference level's FRFs.
    band : (float, float)
        Fitted band in Hz.
    settings : LevelSettings
    drive_point : str, optional
        The accelerometer at the force (force drive), for the modal masses.
    max_added : int
        At most this many poles are added at residual peaks.

    Returns
    -------
    ReferenceModel
        With its self-check (see :func:`check_reference`, which raises on a misfit).
    """
    mask = (frf.freq_hz >= band[0]) & (frf.freq_hz <= band[1])
    sub = frf.select(mask)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the resolution warnings are issued once, by the pipeline
        poles = _polymax_poles(sub, band, settings.max_order)
    sig = sub.total_sigma
    res = None
    for _ in range(max_added + 1):
        if poles.size == 0:
            k = int(np.argmax(np.sum(np.abs(sub.H) ** 2 / sig**2, axis=0)))
            poles = np.array([_pole_at(sub.freq_hz[k], 0.01)])
        res = _lsfd(sub, poles, band)
        syn = res.synthesised[:, 0, :]
        z = np.sum(np.abs(sub.H - syn) ** 2 / sig**2, axis=0) / sub.H.shape[0]
        # a peak of the normalised residual far above the noise (chi2 per line >> 1) where no pole is near
        k = int(np.argmax(_smooth(z)))
        fk = sub.freq_hz[k]
        near = np.min(np.abs(res.frequency_hz - fk)) if res.poles.size else np.inf
        rel = np.linalg.norm(sub.H - syn, axis=1) / np.linalg.norm(sub.H, axis=1)
        if _smooth(z)[k] < 25.0 or near < 2 * sub.resolution_hz or np.all(rel < settings.reference_tolerance / 4):
            break
        poles = np.sort_complex(np.concatenate([res.poles, [_pole_at(fk, 0.005)]]))
    order = np.argsort(res.frequency_hz)
    poles_f = res.poles[order]
    residues = res.residues[:, 0, order]
    model = ReferenceModel(poles_f, residues, res.lower[:, 0], res.upper[:, 0], frf.channels, tuple(band), {},
                           None, ())
    check = _self_check(model, sub, settings)
    masses, flags = _masses(model, drive_point)
    return ReferenceModel(poles_f, residues, model.lower, model.upper, frf.channels, tuple(band), check, masses,
                          flags)


def _pole_at(f_hz: float, zeta: float) -> complex:
    w = 2 * np.pi * f_hz
    return complex(-zeta * w, w * np.sqrt(1 - zeta**2))


def _smooth(z: np.ndarray) -> np.ndarray:
    return np.convolve(z, np.ones(3) / 3.0, mode="same")


def _self_check(model: ReferenceModel, frf: LevelFRF, settings: LevelSettings) -> dict:
    syn = synthesise(model, frf.freq_hz)
    sig = frf.total_sigma
    out = {}
    for c, name in enumerate(frf.channels):
        nh = float(np.linalg.norm(frf.H[c]))
        rel = float(np.linalg.norm(frf.H[c] - syn[c]) / nh)
        noise = float(np.linalg.norm(sig[c]) / nh)
        tol = max(settings.reference_tolerance, 3.0 * noise)
        out[name] = {"relative_error": rel, "noise_level": noise, "tolerance": tol, "passed": bool(rel <= tol)}
    return out


def _masses(model: ReferenceModel, drive_point: str | None):
    if drive_point is None:
        return None, ()
    c = model.channels.index(drive_point)
    lam = model.poles
    phi2 = model.residues[c] / lam**2 * 2j * lam.imag  # receptance residue times 2 j w_d = phi_dp^2
    flags = []
    masses = np.full(lam.size, np.nan)
    for k in range(lam.size):
        ang = abs(np.angle(phi2[k]))
        if phi2[k].real <= 0 or ang > np.deg2rad(30):
            flags.append(
                f"mode {k + 1} at {model.frequency_hz[k]:.4g} Hz: drive-point residue gives phi^2 = "
                f"{phi2[k]:.3g} (phase {np.degrees(ang):.0f} deg), not a positive mass; check the drive point "
                f"{drive_point!r} and the sign of the force"
            )
        else:
            masses[k] = 1.0 / phi2[k].real
    return masses, tuple(flags)


def check_reference(model: ReferenceModel, frf: LevelFRF) -> None:
    """Raise when the reference model does not reproduce its own recording.

    Raises
    ------
    InputError
        Naming the channels, the sub-bands where the misfit is largest and the modes there.
    """
    bad = [c for c, v in model.check.items() if not v["passed"]]
    if not bad:
        return
    mask = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
    sub = frf.select(mask)
    syn = synthesise(model, sub.freq_hz)
    r = np.sum(np.abs(sub.H - syn) ** 2, axis=0)
    k = int(np.argmax(_smooth(r)))
    lo, hi = k, k
    thr = 0.1 * _smooth(r)[k]
    while lo > 0 and _smooth(r)[lo - 1] > thr:
        lo -= 1
    while hi < r.size - 1 and _smooth(r)[hi + 1] > thr:
        hi += 1
    f0, f1 = sub.freq_hz[lo], sub.freq_hz[hi]
    modes = [f"{f:.4g} Hz" for f in model.frequency_hz if f0 - 1 <= f <= f1 + 1] or ["none found there"]
    errs = ", ".join(f"{c} {model.check[c]['relative_error']:.2f} (noise allows {model.check[c]['tolerance']:.2f})"
                     for c in bad)
    raise InputError(
        f"reference {frf.label!r}: the modal model ({model.poles.size} modes in {model.band_hz[0]:.4g}-"
        f"{model.band_hz[1]:.4g} Hz) does not reproduce its own recording: relative error {errs}, worst in "
        f"{f0:.4g}-{f1:.4g} Hz (modes: {', '.join(modes)}); narrow --band to where the drive excites the "
        "structure, refine --resolution, or record longer"
    )
