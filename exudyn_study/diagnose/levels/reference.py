"""Compare stage, second half: the reference model, and its check against its own recording.

The reference (linear) model is identified from the lowest level: PolyMAX over model orders,
automatic selection of the stable poles, LSFD with residual terms (lower and upper) weighted
by the inverse noise (+ distortion) level of every line, and every pole refitted around its
mode with the others held (:func:`~.modal.fit_mode`, bounded to the mode's window), three
sweeps. A peak of the residual that stands out of the noise gets a pole of its own, kept if it
lowers the misfit by a tenth, so that the model holds as many modes as the band does. The model must then
reproduce its own recording per channel:
a misfit within 3 times the noise, or (flagged) a relative FRF error within ``reference_tolerance``;
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
from dataclasses import replace

import numpy as np

from exudyn_study.diagnose.levels.frf import LevelFRF
from exudyn_study.diagnose.levels.modal import ReferenceModel, fit_mode, mode_term, pole_of, synthesise
from exudyn_study.diagnose.levels.settings import LevelSettings
from exudyn_study.errors import InputError

__all__ = ["ReferenceModel", "identify_reference", "check_reference", "synthesise", "mode_term"]

log = logging.getLogger(__name__)


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
    # a short band (a stepped sine around one mode) holds too few lines for high orders
    top = int(min(max_order, max(4, f.size // 4)))
    poles = polymax(h[:, None, :], f, range(2, top + 1), band_hz=band)
    return select_modes(poles).poles


def identify_reference(
    frf: LevelFRF,
    band: tuple[float, float],
    settings: LevelSettings,
    drive_point: str | None = None,
    max_added: int = 12,
) -> ReferenceModel:
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
    if poles.size == 0:
        k = int(np.argmax(np.sum(np.abs(sub.H) ** 2 / sub.total_sigma**2, axis=0)))
        poles = np.array([_pole_at(sub.freq_hz[k], 0.01)])
    model, chi = _refine(sub, poles, band)
    for _ in range(max_added):
        # a peak of the normalised residual far above the noise where no pole is near gets a pole of
        # its own, kept only if it lowers the misfit by a tenth
        z = _smooth(
            np.sum(np.abs(sub.H - synthesise(model, sub.freq_hz)) ** 2 / sub.total_sigma**2, axis=0)
            / sub.H.shape[0]
        )
        k = int(np.argmax(z))
        fk = sub.freq_hz[k]
        if z[k] < 25.0 or np.min(np.abs(model.frequency_hz - fk)) < 2 * sub.resolution_hz:
            break
        trial, chi_t = _refine(sub, np.concatenate([model.poles, [_pole_at(fk, 0.005)]]), band)
        if not chi_t < 0.9 * chi:
            break
        model, chi = trial, chi_t
    check = _self_check(model, sub, settings)
    masses, flags = _masses(model, drive_point)
    return ReferenceModel(
        model.poles, model.residues, model.lower, model.upper, frf.channels, tuple(band), check, masses, flags
    )


def _residues(frf: LevelFRF, poles: np.ndarray, band) -> ReferenceModel:
    """LSFD (residues and residual terms) for fixed poles, weighted by the inverse noise and distortion."""
    from exudyn_study.identify.lsfd import lsfd

    w = 1.0 / np.maximum(frf.total_sigma, 1e-12 * np.abs(frf.H).max())
    poles = poles[np.argsort(np.abs(poles))]
    res = lsfd(
        frf.H[:, None, :], frf.freq_hz, poles, band_hz=band, frf_form="accelerance", weights=w[:, None, :]
    )
    return ReferenceModel(
        res.poles,
        res.residues[:, 0, :],
        res.lower[:, 0],
        res.upper[:, 0],
        frf.channels,
        tuple(band),
        {},
        None,
        (),
    )


def _merge_close(model: ReferenceModel, frf: LevelFRF, band) -> ReferenceModel:
    """Merge poles closer than the wider one's half-power bandwidth (one mode): keep the larger residue."""
    keep = list(range(model.poles.size))
    f, z = model.frequency_hz, model.damping_ratio
    size = np.linalg.norm(model.residues, axis=0)
    changed = True
    while changed and len(keep) > 1:
        changed = False
        for a, b in zip(keep[:-1], keep[1:], strict=True):
            if abs(f[b] - f[a]) < max(z[a] * f[a], z[b] * f[b], frf.resolution_hz):
                keep.remove(a if size[a] < size[b] else b)
                changed = True
                break
    if len(keep) == model.poles.size:
        return model
    return _residues(frf, model.poles[keep], band)


def _refine(frf: LevelFRF, poles: np.ndarray, band, sweeps: int = 3) -> tuple[ReferenceModel, float]:
    """Residues by LSFD, then every pole refitted around its mode with the others held, ``sweeps`` times.

    Returns the model and its chi-square against the noise and distortion.
    """
    model = _merge_close(_residues(frf, poles, band), frf, band)
    for _ in range(sweeps):
        new = model.poles.copy()
        for r in range(new.size):
            f, _, z, _, res, _, _ = fit_mode(model, r, frf)
            new[r] = pole_of((f, z))
            resid = model.residues.copy()
            resid[:, r] = res
            model = replace(model, poles=new.copy(), residues=resid)
        model = _residues(frf, new, band)
    chi = float(np.sum(np.abs(frf.H - synthesise(model, frf.freq_hz)) ** 2 / frf.total_sigma**2))
    return model, chi


def _pole_at(f_hz: float, zeta: float) -> complex:
    w = 2 * np.pi * f_hz
    return complex(-zeta * w, w * np.sqrt(1 - zeta**2))


def _smooth(z: np.ndarray) -> np.ndarray:
    return np.convolve(z, np.ones(3) / 3.0, mode="same")


def _self_check(model: ReferenceModel, frf: LevelFRF, settings: LevelSettings) -> dict:
    """Per channel: relative error, the noise's relative level, the misfit in noise units, pass/fail.

    A channel passes when its misfit is within the noise, or (``within_noise`` False: flagged) its
    relative FRF error within ``reference_tolerance``; within the noise means
    ``sqrt(mean(|H - H_model|^2 / sigma^2)) <= 3`` (sigma: noise and distortion of every line,
    floored at 0.1 % of |H| so that a noise-free line cannot demand an exact fit).
    """
    syn = synthesise(model, frf.freq_hz)
    sig = np.maximum(frf.total_sigma, 1e-3 * np.abs(frf.H))
    out = {}
    for c, name in enumerate(frf.channels):
        nh = float(np.linalg.norm(frf.H[c]))
        rel = float(np.linalg.norm(frf.H[c] - syn[c]) / nh)
        noise = float(np.sqrt(np.mean((sig[c] / np.maximum(np.abs(frf.H[c]), 1e-300)) ** 2)))
        misfit = float(np.sqrt(np.mean(np.abs(frf.H[c] - syn[c]) ** 2 / sig[c] ** 2)))
        ok = rel <= settings.reference_tolerance or misfit <= 3.0
        out[name] = {
            "relative_error": rel,
            "noise_level": noise,
            "misfit_in_noise_units": misfit,
            "tolerance": settings.reference_tolerance,
            "passed": bool(ok),
            "within_noise": bool(misfit <= 3.0),
        }
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
                f"{phi2[k]:.3g} (phase {np.degrees(ang):.0f} deg), not a positive mass; check the "
                "drive point "
                f"{drive_point!r} and the sign of the force"
            )
        else:
            masses[k] = 1.0 / phi2[k].real
    return masses, tuple(flags)


def check_reference(model: ReferenceModel, frf: LevelFRF) -> None:
    """Raise when the reference model does not reproduce its own recording.

    Everything diagnosed later is relative to this model, so a model that misfits its own
    recording stops the diagnosis here. The verdict per channel is ``model.check`` (made by
    :func:`identify_reference`); this function only reports it, locating the sub-band where the
    misfit is largest.

    Parameters
    ----------
    model : ReferenceModel
        The reference model with its self-check, from :func:`identify_reference`.
    frf : LevelFRF
        The reference level's FRFs the model was identified from (all lines; only those in
        ``model.band_hz`` are compared).

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
    errs = ", ".join(
        f"{c} {model.check[c]['relative_error']:.2f} ({model.check[c]['misfit_in_noise_units']:.1f} x "
        "the noise)"
        for c in bad
    )
    raise InputError(
        f"reference {frf.label!r}: the modal model ({model.poles.size} modes in {model.band_hz[0]:.4g}-"
        f"{model.band_hz[1]:.4g} Hz) does not reproduce its own recording: relative error {errs}, worst in "
        f"{f0:.4g}-{f1:.4g} Hz (modes: {', '.join(modes)}); narrow --band to where the drive excites the "
        "structure, refine --resolution, or record longer"
    )
