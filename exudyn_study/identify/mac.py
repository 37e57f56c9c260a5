"""Mode-shape correlation and complexity: MAC, AutoMAC, MPC, MCF.

Shapes follow the layout ``phi[n_dof, n_modes]`` (complex allowed).

References
----------
Allemang, R. J., Brown, D. L. (1982). A correlation coefficient for modal vector
analysis. Proc. IMAC I, 110-116.

Pappa, R. S., Elliott, K. B., Schenk, A. (1993). Consistent-mode indicator for the
eigensystem realization algorithm. J. Guidance, Control, and Dynamics 16(5), 852-858.

Vacher, P., Jacquier, B., Bucharles, A. (2010). Extensions of the MAC criterion to
complex modes. Proc. ISMA 2010, 2713-2726.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify._checks import callable_module

__all__ = ["mac", "automac", "mpc", "mcf", "mean_phase_deviation"]


def _as_shapes(phi, name: str) -> np.ndarray:
    phi = np.asarray(phi)
    if phi.ndim == 1:
        phi = phi[:, None]
    if phi.ndim != 2:
        raise InputError(f"{name} of shape {phi.shape}: expected phi[n_dof, n_modes]")
    if not np.all(np.isfinite(phi)):
        raise InputError(f"{name}: expected finite shape values")
    return phi.astype(complex)


def mac(phi_a, phi_b) -> np.ndarray:
    r"""Modal assurance criterion between two sets of shapes.

    .. math:: \mathrm{MAC}_{kl} = \frac{|\phi_{a,k}^H \phi_{b,l}|^2}
              {(\phi_{a,k}^H\phi_{a,k})(\phi_{b,l}^H\phi_{b,l})}

    (thesis eq. 39, with the Hermitian transpose for complex shapes).

    Parameters
    ----------
    phi_a : ndarray, shape (n_dof, n_a)
        First set of shapes (one column per mode; a 1-D array is one mode).
    phi_b : ndarray, shape (n_dof, n_b)
        Second set, same DOFs in the same order.

    Returns
    -------
    ndarray, shape (n_a, n_b)
        MAC values in [0, 1]; 0 where a shape is identically zero.

    Raises
    ------
    InputError
        When the DOF counts differ or values are not finite.
    """
    a = _as_shapes(phi_a, "phi_a")
    b = _as_shapes(phi_b, "phi_b")
    if a.shape[0] != b.shape[0]:
        raise InputError(
            f"phi_a has {a.shape[0]} DOFs, phi_b {b.shape[0]}: expected the same DOFs"
        )
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return np.clip(out, 0.0, 1.0)


def automac(phi) -> np.ndarray:
    """MAC of a set of shapes with itself, shape (n_modes, n_modes); diagonal 1."""
    return mac(phi, phi)


def mpc(phi) -> np.ndarray:
    r"""Modal phase collinearity per mode (1 for a real/normal mode, 0 for a circular one).

    Computed from the eigenvalues of the 2x2 covariance of real and imaginary
    parts, :math:`\mathrm{MPC} = ((\mu_1-\mu_2)/(\mu_1+\mu_2))^2` (Vacher et al.
    2010), which is independent of the shape's complex scaling.

    Parameters
    ----------
    phi : ndarray, shape (n_dof, n_modes)
        Complex shapes.

    Returns
    -------
    ndarray, shape (n_modes,)
    """
    p = _as_shapes(phi, "phi")
    re, im = p.real, p.imag
    sxx = np.sum(re * re, axis=0)
    syy = np.sum(im * im, axis=0)
    sxy = np.sum(re * im, axis=0)
    tot = sxx + syy
    with np.errstate(invalid="ignore", divide="ignore"):
        val = ((sxx - syy) ** 2 + 4 * sxy**2) / tot**2
    return np.clip(np.where(tot > 0, val, 0.0), 0.0, 1.0)


def mcf(phi) -> np.ndarray:
    """Mode complexity factor per mode, ``1 - MPC`` (0 for a real mode, 1 for circular)."""
    return 1.0 - mpc(phi)


def mean_phase_deviation(phi) -> np.ndarray:
    """Mean phase deviation in rad of the shape components from their best-fit line.

    Parameters
    ----------
    phi : ndarray, shape (n_dof, n_modes)
        Complex shapes.

    Returns
    -------
    ndarray, shape (n_modes,)
        Amplitude-weighted mean absolute phase deviation in rad (0 for real modes).
    """
    p = _as_shapes(phi, "phi")
    out = np.zeros(p.shape[1])
    for k in range(p.shape[1]):
        v = p[:, k]
        w = np.abs(v)
        if not np.any(w > 0):
            continue
        # best-fit phase: principal direction of (Re, Im)
        c = np.array([[v.real @ v.real, v.real @ v.imag], [v.real @ v.imag, v.imag @ v.imag]])
        _, e = np.linalg.eigh(c)
        theta = np.arctan2(e[1, -1], e[0, -1])
        dev = np.angle(v * np.exp(-1j * theta))
        dev = np.minimum(np.abs(dev), np.pi - np.abs(dev))
        out[k] = np.sum(w * dev) / np.sum(w)
    return out


# calling the module calls the function (see _checks.callable_module)
callable_module(__name__, mac)
