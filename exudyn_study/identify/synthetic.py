r"""Synthetic systems with known poles and shapes, for tests and benchmarks.

Two generators:

- :func:`pole_residue_frf`: exact FRFs of a pole-residue model, noise- and
  leakage-free (the strongest reference for the estimators).
- :class:`BaseExcitedSystem` with :func:`table1_system` and :func:`simulate`: a
  base-excited, proportionally damped multi-mode structure with the ten modes of
  thesis Table 1, measured by accelerometers at the sensor positions of thesis
  Appendix A, and its time response to band-limited random base acceleration at
  1000 Hz with measurement noise. The time response is computed by FFT-domain
  filtering over the whole record with the exact transmissibility, i.e. the exact
  periodic steady state: no integration error, no start-up transient. Leakage
  then arises only where it arises in a real test, in the Welch segments.

Model of the base-excited structure (relative modal coordinates :math:`q_k`,
base acceleration :math:`a_b`):

.. math:: \ddot q_k + 2\zeta_k\omega_k\dot q_k + \omega_k^2 q_k = -\Gamma_k a_b,
          \qquad a_o = r_o a_b + \sum_k \phi_{ok}\ddot q_k,

so the acceleration transmissibility is
:math:`T_o(\omega) = r_o + \sum_k \phi_{ok}\Gamma_k\omega^2 /
(\omega_k^2 - \omega^2 + 2j\zeta_k\omega_k\omega)`, whose poles are those of
the structure and whose residues are proportional to :math:`\phi_{ok}`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.polymax import modal_to_pole
from exudyn_study.model.sensors import SENSORS as _SENSOR_TABLE

__all__ = [
    "TABLE1_FREQUENCY_HZ",
    "TABLE1_DAMPING",
    "APPENDIX_A_SENSORS",
    "BaseExcitedSystem",
    "table1_system",
    "simulate",
    "pole_residue_frf",
    "to_recording",
    "RandomCase",
    "random_case",
]

#: thesis Table 1: undamped natural frequencies (Hz) identified from the white-noise test
TABLE1_FREQUENCY_HZ = (12.05, 13.21, 14.15, 15.00, 21.21, 32.69, 36.64, 41.37, 43.84, 47.60)
#: thesis Table 1: modal damping ratios (-)
TABLE1_DAMPING = (0.0181, 0.0146, 0.0178, 0.0218, 0.0119, 0.0547, 0.0346, 0.0119, 0.0209,
                  0.0053)

#: thesis Appendix A: (name, direction, position in whole mm, local rig coordinates), from
#: :data:`exudyn_study.model.sensors.SENSORS` (the one table of the 42 accelerometers)
APPENDIX_A_SENSORS = tuple(
    (s.name, s.direction, tuple(int(round(1000.0 * c)) for c in s.position_m)) for s in _SENSOR_TABLE
)

#: response channels of the thesis's identification (channels 1 and 8-42, Section 5.1)
_THESIS_RESPONSES = tuple(s[0] for i, s in enumerate(APPENDIX_A_SENSORS, start=1)
                          if i == 1 or i >= 8)


def pole_residue_frf(
    poles: np.ndarray,
    residues: np.ndarray,
    freq_hz: np.ndarray,
    *,
    constant: np.ndarray | None = None,
) -> np.ndarray:
    r"""Exact FRFs of a pole-residue model with conjugate pole pairs.

    .. math:: H_{oi}(\omega) = c_{oi} + \sum_k \frac{R_{oik}}{j\omega-\lambda_k}
              + \frac{R^*_{oik}}{j\omega-\lambda^*_k}

    Parameters
    ----------
    poles : ndarray of complex, shape (n_modes,)
        Poles in rad/s (upper half plane).
    residues : ndarray of complex, shape (n_out, n_in, n_modes)
        Residues in FRF unit times rad/s.
    freq_hz : ndarray, shape (n_freq,)
        Frequencies in Hz.
    constant : ndarray, shape (n_out, n_in), optional
        Real constant term (e.g. the rigid transmissibility); default 0.

    Returns
    -------
    ndarray of complex, shape (n_out, n_in, n_freq)
    """
    poles = np.asarray(poles, dtype=complex)
    residues = np.asarray(residues, dtype=complex)
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    b1 = 1.0 / (jw[None, :] - poles[:, None])
    b2 = 1.0 / (jw[None, :] - np.conj(poles)[:, None])
    h = residues @ b1 + np.conj(residues) @ b2
    if constant is not None:
        h = h + np.asarray(constant, dtype=float)[:, :, None]
    return h


@dataclass(frozen=True, eq=False)
class BaseExcitedSystem:
    """Proportionally damped structure excited by base acceleration (see module notes).

    Attributes
    ----------
    frequency_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies in Hz.
    damping_ratio : ndarray, shape (n_modes,)
        Modal damping ratios (-).
    shapes : ndarray, shape (n_out, n_modes)
        Real mode shapes at the response channels (phi[n_dof, n_modes] layout).
    participation : ndarray, shape (n_modes,)
        Base-excitation participation factors Gamma_k (-).
    rigid : ndarray, shape (n_out,)
        Rigid-body transmissibility r_o of each channel (1 for channels measuring
        along the excitation, 0 across it).
    names : tuple of str
        Response channel names.
    directions : tuple of str
        Measuring direction per channel ('X', 'Y' or 'Z').
    positions_m : ndarray, shape (n_out, 3)
        Sensor positions in m.
    reference : str
        Name of the reference channel (the base acceleration, or the force).
    excitation : {'base', 'force'}
        'base': ``participation`` are base-excitation factors and ``rigid`` the rigid
        transmissibility. 'force': a force at one point, ``participation`` is minus the
        mass-normalised shape at the drive point and ``rigid`` is 0, so that
        :meth:`transmissibility` is the accelerance in (m/s^2)/N.
    """

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray
    rigid: np.ndarray
    names: tuple[str, ...]
    directions: tuple[str, ...]
    positions_m: np.ndarray
    reference: str = "ARFVZ"
    excitation: str = "base"

    def __post_init__(self) -> None:
        n_out, n_modes = np.shape(self.shapes)
        if np.shape(self.frequency_hz) != (n_modes,) or np.shape(self.damping_ratio) != (
            n_modes,
        ):
            raise InputError("frequency_hz and damping_ratio: expected one value per mode")
        if len(self.names) != n_out or np.shape(self.rigid) != (n_out,):
            raise InputError("names and rigid: expected one entry per shape row")
        if np.any(np.asarray(self.damping_ratio) <= 0) or np.any(
            np.asarray(self.damping_ratio) >= 1
        ):
            raise InputError("damping_ratio: expected values in (0, 1)")
        if self.excitation not in ("base", "force"):
            raise InputError(f"excitation {self.excitation!r}: expected 'base' or 'force'")

    @property
    def poles(self) -> np.ndarray:
        """Poles in rad/s (upper half plane), shape (n_modes,)."""
        return modal_to_pole(self.frequency_hz, self.damping_ratio)

    def transmissibility(self, freq_hz: np.ndarray) -> np.ndarray:
        """Exact acceleration transmissibility ``H[n_out, 1, n_freq]`` (-).

        Parameters
        ----------
        freq_hz : ndarray, shape (n_freq,)
            Frequencies in Hz.
        """
        w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
        wk = 2 * np.pi * np.asarray(self.frequency_hz)[:, None]
        zk = np.asarray(self.damping_ratio)[:, None]
        modal = w[None, :] ** 2 / (wk**2 - w[None, :] ** 2 + 2j * zk * wk * w[None, :])
        h = self.rigid[:, None] + (self.shapes * self.participation[None, :]) @ modal
        return h[:, None, :]

    def residues(self) -> np.ndarray:
        """Residues ``R[n_out, 1, n_modes]`` of :meth:`transmissibility` at :attr:`poles`."""
        lam = self.poles
        wk = 2 * np.pi * np.asarray(self.frequency_hz)
        zk = np.asarray(self.damping_ratio)
        # T = r + phi*Gamma*(wk^2 + 2 zeta wk s)/((s - lam)(s - lam*)), s = j w
        c = (wk**2 + 2 * zk * wk * lam) / (lam - np.conj(lam))
        return (self.shapes * (self.participation * c)[None, :])[:, None, :]

    def constant(self) -> np.ndarray:
        """Constant term ``c[n_out, 1]`` of the pole-residue form of the transmissibility."""
        return (self.rigid - self.shapes @ self.participation)[:, None]


def table1_system(n_channels: int = 36, seed: int = 1) -> BaseExcitedSystem:
    """Return the ten modes of thesis Table 1 on the thesis's response channels.

    Mode shapes are smooth random fields over the sensor positions (seeded), with
    modes 8 and 9 (both "frame bending about y") made correlated as in thesis
    Figure 15. Participation factors are 1; channels measuring along Z carry the
    rigid base motion.

    Parameters
    ----------
    n_channels : int, optional
        Number of response channels, 1..36 (thesis channels 1 and 8-42 in order).
    seed : int, optional
        Seed of the mode-shape generator.

    Returns
    -------
    BaseExcitedSystem
        Reference channel ``'ARFVZ'`` (the base acceleration).
    """
    if not 1 <= int(n_channels) <= len(_THESIS_RESPONSES):
        raise InputError(
            f"n_channels={n_channels!r}: expected 1..{len(_THESIS_RESPONSES)}"
        )
    table = {s[0]: s for s in APPENDIX_A_SENSORS}
    names = _THESIS_RESPONSES[: int(n_channels)]
    pos = np.array([table[n][2] for n in names], dtype=float) / 1000.0
    dirs = tuple(table[n][1] for n in names)
    rng = np.random.default_rng(seed)
    # smooth basis over the normalised positions, plus a direction-dependent part
    u = (pos - pos.mean(axis=0)) / np.maximum(pos.std(axis=0), 1e-9)
    basis = [np.ones(len(names))]
    for d in range(3):
        for k in (1, 2):
            basis.append(np.cos(k * np.pi * u[:, d] / 3.0))
            basis.append(np.sin(k * np.pi * u[:, d] / 3.0))
    basis.append(u[:, 0] * u[:, 1])
    basis.append(u[:, 1] * u[:, 2])
    dir_onehot = np.array([[d == "X", d == "Y", d == "Z"] for d in dirs], dtype=float)
    b = np.column_stack(basis + [dir_onehot[:, j] * u[:, 0] for j in range(3)])
    n_modes = len(TABLE1_FREQUENCY_HZ)
    coef = rng.standard_normal((b.shape[1], n_modes))
    phi = b @ coef + 0.35 * rng.standard_normal((len(names), n_modes))
    phi[:, 8] = 0.6 * phi[:, 7] + 0.8 * phi[:, 8]  # modes 8/9 correlated (thesis Fig. 15)
    phi /= np.max(np.abs(phi), axis=0, keepdims=True)
    return BaseExcitedSystem(
        frequency_hz=np.array(TABLE1_FREQUENCY_HZ),
        damping_ratio=np.array(TABLE1_DAMPING),
        shapes=phi,
        participation=np.ones(n_modes),
        rigid=np.array([1.0 if d == "Z" else 0.0 for d in dirs]),
        names=tuple(names),
        directions=dirs,
        positions_m=pos,
    )


def simulate(
    system: BaseExcitedSystem,
    duration_s: float,
    *,
    sample_rate_hz: float = 1000.0,
    noise: float = 0.02,
    excitation_band_hz: tuple[float, float] = (3.0, 60.0),
    base_rms: float = 1.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate a random base-excitation test of ``system``.

    The base acceleration is Gaussian random noise with a flat spectrum in
    ``excitation_band_hz``; the responses are the exact periodic steady state
    (FFT-domain filtering with :meth:`BaseExcitedSystem.transmissibility`).
    Independent Gaussian white noise of ``noise`` times each channel's rms is then
    added to every channel, reference included.

    Parameters
    ----------
    system : BaseExcitedSystem
        The structure.
    duration_s : float
        Record length in s.
    sample_rate_hz : float, optional
        Sampling rate in Hz (default 1000).
    noise : float, optional
        Noise rms relative to the signal rms per channel (default 0.02 = 2 %).
    excitation_band_hz : (float, float), optional
        Band of the base acceleration in Hz (default 3-60, the thesis's drive band).
    base_rms : float, optional
        Rms of the base acceleration in m/s^2.
    seed : int, optional
        Seed of the excitation and noise.

    Returns
    -------
    reference : ndarray, shape (1, n_samples)
        Measured base acceleration in m/s^2.
    responses : ndarray, shape (n_out, n_samples)
        Measured response accelerations in m/s^2.
    """
    n = int(round(duration_s * sample_rate_hz))
    if n < 16:
        raise InputError(f"duration_s={duration_s!r}: expected at least 16 samples")
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    lo, hi = excitation_band_hz
    inband = (f >= lo) & (f <= hi)
    spec = np.zeros(f.size, complex)
    spec[inband] = rng.standard_normal(inband.sum()) + 1j * rng.standard_normal(inband.sum())
    base = np.fft.irfft(spec, n)
    base *= base_rms / np.sqrt(np.mean(base**2))
    spec = np.fft.rfft(base)
    resp = np.fft.irfft(system.transmissibility(f)[:, 0, :] * spec[None, :], n, axis=1)
    ref = base[None, :]
    if noise > 0:
        ref = ref + noise * np.sqrt(np.mean(ref**2)) * rng.standard_normal(ref.shape)
        rms = np.sqrt(np.mean(resp**2, axis=1, keepdims=True))
        resp = resp + noise * rms * rng.standard_normal(resp.shape)
    return ref, resp


def to_recording(system: BaseExcitedSystem, reference: np.ndarray, responses: np.ndarray,
                 sample_rate_hz: float = 1000.0, metadata: dict | None = None):
    """Pack a :func:`simulate` result into a :class:`~exudyn_study.recording.Recording`.

    Parameters
    ----------
    system : BaseExcitedSystem
        The simulated structure (names, directions, positions).
    reference, responses : ndarray
        Outputs of :func:`simulate`, shapes (1, n) and (n_out, n).
    sample_rate_hz : float, optional
        Sampling rate in Hz.
    metadata : dict, optional
        Recording metadata.

    Returns
    -------
    Recording
        Reference channel first (named ``system.reference``), then the responses.
    """
    from exudyn_study.recording.types import Recording

    table = {s[0]: s for s in APPENDIX_A_SENSORS}
    ref_pos = tuple(np.array(table[system.reference][2]) / 1000.0) \
        if system.reference in table else None
    names = (system.reference,) + tuple(system.names)
    dirs = ("Z",) + tuple(system.directions)
    pos = [ref_pos] + [tuple(map(float, p)) for p in system.positions_m]
    x = np.vstack([reference, responses])
    return Recording.from_arrays(
        x, sample_rate_hz, names, directions=dirs, positions_m=pos,
        metadata=dict(metadata or {"source": "exudyn_study.identify.synthetic"}),
    )


@dataclass(frozen=True, eq=False)
class RandomCase:
    """A randomly drawn test case: a structure and how it is measured.

    Attributes
    ----------
    system : BaseExcitedSystem
        The structure (base or force excitation).
    duration_s : float
        Record length in s.
    noise : float
        Measurement noise rms relative to each channel's rms (-).
    excitation_band_hz : (float, float)
        Band of the random excitation in Hz.
    seed : int
        Seed the case was drawn with (also used for its time data).
    """

    system: BaseExcitedSystem
    duration_s: float
    noise: float
    excitation_band_hz: tuple[float, float]
    seed: int

    def simulate(self, sample_rate_hz: float = 1000.0) -> tuple[np.ndarray, np.ndarray]:
        """Return the time data of the case, see :func:`simulate`.

        Parameters
        ----------
        sample_rate_hz : float
            Sample rate of the time data (Hz).

        Returns
        -------
        (ndarray, ndarray)
            As :func:`simulate`: the drive and the responses.
        """
        return simulate(self.system, self.duration_s, sample_rate_hz=sample_rate_hz,
                        noise=self.noise, excitation_band_hz=self.excitation_band_hz,
                        seed=self.seed + 1_000_003)


def random_case(
    seed: int,
    *,
    n_channels: int = 24,
    n_modes: tuple[int, int] = (6, 12),
    damping: tuple[float, float] = (0.003, 0.06),
    close_spacing: tuple[float, float] = (0.005, 0.02),
    duration_s: tuple[float, float] = (60.0, 300.0),
    noise: tuple[float, float] = (0.01, 0.05),
) -> RandomCase:
    """Draw a random identification test case.

    The excitation band starts at 2-5 Hz and ends at 50-100 Hz; the modes lie uniformly in
    its inner part (above 1.5 times the lower edge, below 0.85 times the upper edge), at
    least 5 % apart except one close pair (two with 9 or more modes) whose second mode lies
    ``close_spacing`` (relative) above the first. Damping ratios are log-uniform in
    ``damping``, with one isolated mode at least 5 % damped (a heavily damped mode) and the
    close-pair modes at most 1.5 % damped. Shapes are independent Gaussian
    vectors over the channels (a close pair has distinct shapes, which is what makes it
    identifiable from one reference); modal participations are drawn with magnitude
    0.5-1.5. Half the cases are base excited (reference: base acceleration, rigid
    transmissibility 1 on a third of the channels), half force excited (reference: the
    force; accelerances).

    Parameters
    ----------
    seed : int
        Seed of the draw.
    n_channels : int, optional
        Number of response channels (default 24: with the reference 25 channels).
    n_modes : (int, int), optional
        Inclusive range of the number of modes (default 6-12).
    damping : (float, float), optional
        Range of damping ratios (-), default 0.3-6 %.
    close_spacing : (float, float), optional
        Relative spacing of close pairs (default 0.5-2 %).
    duration_s : (float, float), optional
        Range of record lengths in s (default 60-300).
    noise : (float, float), optional
        Range of the relative noise (default 1-5 %).

    Returns
    -------
    RandomCase
    """
    rng = np.random.default_rng(seed)
    n = int(rng.integers(n_modes[0], n_modes[1] + 1))
    lo = float(rng.uniform(2.0, 5.0))
    hi = float(rng.uniform(50.0, 100.0))
    f_lo, f_hi = 1.5 * lo, 0.85 * hi
    n_pairs = 1 if n < 9 else 2
    n_single = n - n_pairs
    for _ in range(10000):
        f = np.sort(rng.uniform(f_lo, f_hi / 1.02, n_single))
        if np.all(np.diff(f) / f[1:] > 0.05):
            break
    pair_at = rng.choice(n_single, n_pairs, replace=False)
    extra = f[pair_at] * (1 + rng.uniform(*close_spacing, n_pairs))
    freq = np.concatenate([f, extra])
    zeta = np.exp(rng.uniform(np.log(damping[0]), np.log(damping[1]), n))
    single = np.setdiff1d(np.arange(n_single), pair_at)
    zeta[rng.choice(single)] = rng.uniform(0.05, damping[1])
    # close pairs are lightly damped (at most 1.5 %): two modes 0.5 % apart at 5 % damping
    # are one peak that no single-reference test separates
    pair = np.concatenate([pair_at, np.arange(n_single, n)])
    zeta[pair] = np.exp(rng.uniform(np.log(damping[0]), np.log(min(damping[1], 0.015)), pair.size))
    order = np.argsort(freq)
    freq, zeta = freq[order], zeta[order]
    phi = rng.standard_normal((n_channels, n))
    phi /= np.max(np.abs(phi), axis=0, keepdims=True)
    base = bool(seed % 2 == 0)
    gamma = rng.uniform(0.5, 1.5, n) * rng.choice([-1.0, 1.0], n)
    names = tuple(f"R{i + 1:02d}{'XYZ'[i % 3]}" for i in range(n_channels))
    dirs = tuple("XYZ"[i % 3] for i in range(n_channels))
    if base:
        rigid = np.array([1.0 if d == "Z" else 0.0 for d in dirs])
        system = BaseExcitedSystem(freq, zeta, phi, gamma, rigid, names, dirs,
                                   rng.uniform(0, 2, (n_channels, 3)), reference="BASEZ",
                                   excitation="base")
    else:
        # force at one point: accelerance sum_k phi_o phi_d (-w^2) / (wk^2 - w^2 + ...), modal
        # masses 1 kg, so participation = -phi_d (scaled like gamma)
        system = BaseExcitedSystem(freq, zeta, phi, -gamma, np.zeros(n_channels), names, dirs,
                                   rng.uniform(0, 2, (n_channels, 3)), reference="FORCEZ",
                                   excitation="force")
    return RandomCase(system=system, duration_s=float(rng.uniform(*duration_s)),
                      noise=float(rng.uniform(*noise)), excitation_band_hz=(lo, hi), seed=int(seed))
