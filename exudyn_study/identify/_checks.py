"""Input validation shared by the identification functions (private)."""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError


def as_frf(frf, freq_hz) -> tuple[np.ndarray, np.ndarray]:
    """Validate and return ``frf[n_out, n_in, n_freq]`` (complex) and ``freq_hz``.

    Parameters
    ----------
    frf : array_like
        Frequency response functions ``H[n_out, n_in, n_freq]``, finite values.
    freq_hz : array_like
        Frequency lines in Hz, shape ``(n_freq,)``: finite, strictly increasing, at least 4.

    Returns
    -------
    frf : numpy.ndarray
        ``frf`` as a complex array of shape ``(n_out, n_in, n_freq)``.
    freq_hz : numpy.ndarray
        ``freq_hz`` as a float array of shape ``(n_freq,)``.

    Raises
    ------
    InputError
        If ``frf`` is not 3-D or holds non-finite values, or ``freq_hz`` does not match its last
        axis, has fewer than 4 lines or is not finite and strictly increasing.
    """
    frf = np.asarray(frf)
    if frf.ndim != 3:
        raise InputError(
            f"frf of shape {frf.shape}: expected a 3-D array H[n_out, n_in, n_freq]"
        )
    frf = frf.astype(complex)
    freq_hz = np.asarray(freq_hz, dtype=float)
    if freq_hz.ndim != 1 or freq_hz.shape[0] != frf.shape[2]:
        raise InputError(
            f"freq_hz of shape {freq_hz.shape}: expected ({frf.shape[2]},) to match "
            f"frf of shape {frf.shape}"
        )
    if freq_hz.size < 4:
        raise InputError(f"freq_hz has {freq_hz.size} lines: expected at least 4")
    if not np.all(np.isfinite(freq_hz)) or np.any(np.diff(freq_hz) <= 0):
        raise InputError("freq_hz: expected finite, strictly increasing frequencies")
    bad = ~np.isfinite(frf)
    if bad.any():
        o, i, k = np.argwhere(bad)[0]
        raise InputError(
            f"frf contains {int(bad.sum())} non-finite values (first at output {o}, "
            f"input {i}, {freq_hz[k]:.4g} Hz): expected finite values"
        )
    return frf, freq_hz


def band_mask(freq_hz: np.ndarray, band_hz) -> np.ndarray:
    """Boolean mask of the lines inside ``band_hz`` (default: all lines > 0 Hz).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequency lines in Hz, shape ``(n_freq,)``, strictly increasing.
    band_hz : tuple of float or None
        Band ``(fmin, fmax)`` in Hz with ``0 <= fmin < fmax`` inside the data's range; None selects
        from the first line above 0 Hz to the last line.

    Returns
    -------
    numpy.ndarray
        Boolean mask of shape ``(n_freq,)``, True on the lines above 0 Hz inside the band.

    Raises
    ------
    InputError
        If ``band_hz`` is not two numbers, is not ordered, lies outside the data, or holds fewer
        than 4 lines.
    """
    if band_hz is None:
        band = (freq_hz[freq_hz > 0][0] if np.any(freq_hz > 0) else 0.0, freq_hz[-1])
    else:
        try:
            band = tuple(float(b) for b in band_hz)
        except (TypeError, ValueError):
            raise InputError(
                f"band_hz={band_hz!r}: expected two numbers (fmin, fmax) in Hz"
            ) from None
        if len(band) != 2:
            raise InputError(f"band_hz={band_hz!r}: expected two numbers (fmin, fmax) in Hz")
    fmin, fmax = band
    if not (np.isfinite(fmin) and np.isfinite(fmax) and 0 <= fmin < fmax):
        raise InputError(f"band_hz=({fmin:g}, {fmax:g}): expected 0 <= fmin < fmax")
    if fmin < freq_hz[0] - 1e-9 * max(1.0, abs(freq_hz[0])) or fmax > freq_hz[-1] * (1 + 1e-9):
        raise InputError(
            f"band_hz=({fmin:g}, {fmax:g}) Hz lies outside the data "
            f"({freq_hz[0]:g}-{freq_hz[-1]:g} Hz)"
        )
    sel = (freq_hz >= fmin) & (freq_hz <= fmax) & (freq_hz > 0)
    if sel.sum() < 4:
        raise InputError(
            f"band_hz=({fmin:g}, {fmax:g}) Hz holds {int(sel.sum())} frequency lines: "
            "expected at least 4; widen the band or refine the resolution"
        )
    return sel


def callable_module(module_name: str, func) -> None:
    """Make the module ``module_name`` callable as its main function ``func``.

    ``lsfd``, ``polymax`` and ``mac`` are both modules of this package and its main
    functions. The package re-exports the *modules*; calling one calls the function,
    so ``from exudyn_study.identify import lsfd; lsfd(H, f, poles)`` works, and so
    do ``exudyn_study.identify.lsfd.Leakage`` and ``import exudyn_study.identify.lsfd``
    (a re-exported function of the same name would shadow the module attribute).
    Uses module ``__class__`` assignment (Python >= 3.5).

    Parameters
    ----------
    module_name : str
        Fully qualified name of a module already in ``sys.modules``.
    func : callable
        Function called when the module is called; its signature becomes the module's.
    """
    import sys
    import types

    class _CallableModule(types.ModuleType):
        __call__ = staticmethod(func)

        @property
        def __signature__(self):
            import inspect

            return inspect.signature(func)

    sys.modules[module_name].__class__ = _CallableModule
