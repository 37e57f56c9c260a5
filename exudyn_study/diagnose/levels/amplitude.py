"""Amplitude-dependent modal parameters: every mode's frequency, damping and amplitude at every level.

For each level and each mode of the reference model, the mode's pole and residues are re-fitted
around the mode (``f_r`` +- 3 half-power bandwidths, at least +-5 lines) with the other modes held
and a complex offset per channel taking up their remainder, in sweeps over the modes (each starting
from the others' latest values of the level) until no pole moves by more than a tenth of its
standard deviation, every pole bounded to its reference mode's window (so that a mode that drowns in
noise at some level cannot walk off into its neighbour's band over the sweeps) and fitted over that
window and its current one (a mode whose damping grew needs more band): variable projection
(residues and offsets linear, the pole nonlinear), every line weighted by the inverse of its noise
and distortion level. The standard deviations come from the Jacobian at the optimum, scaled by the
fit's reduced chi-square when above 1. The mode's *amplitude* at a level is its rms acceleration at
the channel where the reference mode is largest,
``sqrt(sum_k |R_c / (jw_k - p) + c.c.|^2 |U_k|^2 / 2)``, computed from the drive's spectrum, so
that it can be predicted for a level from its drive alone (the fit stage does that for held-out
levels).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from exudyn_study.diagnose.levels.frf import LevelFRF
from exudyn_study.diagnose.levels.modal import ReferenceModel, fit_mode, mode_term, pole_of

__all__ = ["ModalTable", "fit_modes_per_level", "mode_amplitude", "MAX_SWEEPS"]

#: most sweeps of the per-mode refits at one level (they stop earlier once no pole moves)
MAX_SWEEPS = 10
NEIGHBOURS = 1


@dataclass(frozen=True, eq=False)
class ModalTable:
    """Modal parameters per level, arrays of shape (n_levels, n_modes) unless noted.

    Attributes
    ----------
    labels : tuple of str
    levels : ndarray, shape (n_levels,)
        Drive rms per level (drive unit).
    frequency_hz, frequency_std_hz, damping_ratio, damping_std : ndarray
    amplitude, amplitude_unit
        The mode's rms response at ``amplitude_channel[r]``.
    amplitude_channel : tuple of str, length n_modes
    residues, residue_std : ndarray, shape (n_levels, n_out, n_modes)
    chi2 : ndarray
        Reduced chi-square of each local fit (about 1 when the fit is within the noise).
    """

    labels: tuple[str, ...]
    levels: np.ndarray
    frequency_hz: np.ndarray
    frequency_std_hz: np.ndarray
    damping_ratio: np.ndarray
    damping_std: np.ndarray
    amplitude: np.ndarray
    amplitude_unit: str
    amplitude_channel: tuple[str, ...]
    residues: np.ndarray
    residue_std: np.ndarray
    chi2: np.ndarray

    def rows(self) -> list[dict]:
        """Return the table as JSON rows (one per level and mode)."""
        out = []
        for i, lab in enumerate(self.labels):
            for r in range(self.frequency_hz.shape[1]):
                out.append(
                    {
                        "recording": lab,
                        "level": float(self.levels[i]),
                        "mode": r + 1,
                        "frequency_hz": float(self.frequency_hz[i, r]),
                        "frequency_std_hz": float(self.frequency_std_hz[i, r]),
                        "damping_ratio": float(self.damping_ratio[i, r]),
                        "damping_std": float(self.damping_std[i, r]),
                        "amplitude": float(self.amplitude[i, r]),
                        "amplitude_unit": self.amplitude_unit,
                        "amplitude_channel": self.amplitude_channel[r],
                        "reduced_chi2": float(self.chi2[i, r]),
                    }
                )
        return out


def mode_amplitude(residue: complex, pole: complex, freq_hz: np.ndarray, u: np.ndarray) -> float:
    """Rms response of one mode at one channel driven by line amplitudes ``u`` (see module docstring).

    ``sqrt(sum_k |R / (jw_k - p) + conj(R) / (jw_k - conj(p))|^2 |u_k|^2 / 2)``: computed from the
    drive alone, so that it can be evaluated for a level that was not fitted.

    Parameters
    ----------
    residue : complex
        The mode's residue at the channel (FRF unit times rad/s).
    pole : complex
        The mode's pole in rad/s (upper half plane).
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz.
    u : ndarray of complex, shape (n_freq,)
        The drive's peak amplitude per line (drive unit, e.g. N), as ``LevelFRF.U``.

    Returns
    -------
    float
        Rms response of the mode at the channel, in the FRF's response unit (e.g. m/s^2).
    """
    t = mode_term(np.array([residue]), pole, freq_hz)[0]
    return float(np.sqrt(0.5 * np.sum(np.abs(t * u) ** 2)))


def fit_modes_per_level(model: ReferenceModel, frfs: list[LevelFRF], progress=None) -> ModalTable:
    """Frequency, damping, residues and amplitude of every reference mode at every level.

    Parameters
    ----------
    model : ReferenceModel
    frfs : list of LevelFRF
        One per level (any order; the table keeps it).
    progress : callable(int), optional
        Called with 1 after each level.

    Returns
    -------
    ModalTable
    """
    nl, nm, no = len(frfs), model.poles.size, model.residues.shape[0]
    fr, fs_, ze, zs, amp, chi = (np.zeros((nl, nm)) for _ in range(6))
    res = np.zeros((nl, no, nm), complex)
    rstd = np.zeros((nl, no, nm))
    ch = np.argmax(np.abs(model.residues), axis=0)
    for i, frf in enumerate(frfs):
        inb = (frf.freq_hz >= model.band_hz[0]) & (frf.freq_hz <= model.band_hz[1])
        sub = frf.select(inb)
        cur = model
        # sweeps over the modes, each refitted with the others at their latest values of this level
        # (a neighbour that moves with level into the mode's window is then not mistaken for it):
        # single modes until no pole moves by more than a tenth of its standard deviation, then
        # every mode together with its NEIGHBOURS on either side until the same holds, so that the
        # tails of overlapping modes settle together (at most MAX_SWEEPS sweeps each)
        for group in (0, NEIGHBOURS):
            for sweep in range(MAX_SWEEPS):
                prev = np.stack([fr[i], ze[i]]).copy()
                for r in range(nm):
                    got = fit_mode(cur, r, sub, neighbours=group, anchor=model)
                    fr[i, r], fs_[i, r], ze[i, r], zs[i, r], res[i, :, r], rstd[i, :, r], chi[i, r] = got
                    poles = cur.poles.copy()
                    poles[r] = pole_of((fr[i, r], ze[i, r]))
                    resid = cur.residues.copy()
                    resid[:, r] = res[i, :, r]
                    cur = replace(cur, poles=poles, residues=resid)
                moved = np.abs(np.stack([fr[i], ze[i]]) - prev) / np.maximum(
                    np.stack([fs_[i], zs[i]]), 1e-300
                )
                if sweep > 0 and np.max(moved) < 0.1:
                    break
        for r in range(nm):
            amp[i, r] = mode_amplitude(
                model.residues[ch[r], r], pole_of((fr[i, r], ze[i, r])), frf.freq_hz, frf.U
            )
        if progress is not None:
            progress(1)
    unit = frfs[0].response_unit
    return ModalTable(
        tuple(f.label for f in frfs),
        np.array([f.level for f in frfs]),
        fr,
        fs_,
        ze,
        zs,
        amp,
        unit,
        tuple(model.channels[c] for c in ch),
        res,
        rstd,
        chi,
    )
