"""A small test structure of our own with a nonlinear joint, simulated at several levels.

Two beams, each lumped into point masses, on a shaker table (base displacement
``u(t)``, the drive): beam A (masses ``A1``, ``A2``) is clamped to the table, beam B
(``B1``, ``B2``, ``B3``) is bolted to the tip of beam A by a lap joint between ``A2``
and ``B1``. One accelerometer (vertical, ``Z``) per mass, so five response channels
and the drive displacement. The joint's small-amplitude (stuck, no contact) stiffness
is in the linear structure; its nonlinear remainder is a local force element across
the sensor pair ``('A2', 'B1')`` (:data:`INTERFACE`)::

    table --k_A1-- A1 --k_A2-- A2 ==joint== B1 --k_B2-- B2 --k_B3-- B3

Joint laws (``joint=``):

``'none'``
    A linear joint (the structure is linear: diagnosis must find nothing).
``'friction'``
    Jenkins micro-slip: a share of the joint stiffness acts through a Coulomb slider
    (:class:`~exudyn_study.linear.nonlinear.JenkinsFriction`); above the slip
    displacement the joint softens and dissipates (frequencies down, damping up with
    level).
``'stiffening'``
    A cubic hardening spring (:class:`~exudyn_study.linear.nonlinear.CubicStiffening`):
    frequencies up with level, damping unchanged.
``'clearance'``
    A dead zone: beyond a gap the joint gains contact stiffness
    (:class:`DeadZoneSpring`); frequencies up with level once the gap closes.

The truth is simulated with :func:`exudyn_study.linear.nonlinear.simulate_local_nonlinear`
(exact linear part, the joint's residual force held over a sub-step) on a hand-built
:class:`~exudyn_study.linear.modes.LinearSystem`; measurement noise (white, absolute, the same at
every level) is added to the accelerations. Imports neither exudyn nor ngsolve.

Examples
--------
>>> from exudyn_study.diagnose.testbench import simulate_levels
>>> recs = simulate_levels("friction", levels=(1.0, 4.0), duration_s=4.0)  # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.recording.types import Channel, Recording

__all__ = [
    "JOINTS",
    "INTERFACE",
    "SENSORS",
    "TestStructure",
    "DeadZoneSpring",
    "linear_system",
    "joint_law",
    "drive_signal",
    "simulate_levels",
]

#: joint laws of the test structure
JOINTS = ("none", "friction", "stiffening", "clearance")
#: response channels (one vertical accelerometer per lumped mass)
SENSORS = ("A1", "A2", "B1", "B2", "B3")
#: the bolted lap joint as a sensor pair across it
INTERFACE = ("A2", "B1")
_POSITIONS_M = {
    "A1": (0.2, 0.0, 0.0),
    "A2": (0.4, 0.0, 0.0),
    "B1": (0.45, 0.0, 0.0),
    "B2": (0.65, 0.0, 0.0),
    "B3": (0.85, 0.0, 0.0),
}


@dataclass(frozen=True)
class TestStructure:
    """Masses, springs and damping of the two-beam test structure (SI).

    Parameters
    ----------
    masses_kg : tuple of 5 float
        A1, A2, B1, B2, B3.
    springs_n_per_m : tuple of 5 float
        table-A1, A1-A2, A2-B1 (the joint's small-amplitude stiffness), B1-B2, B2-B3.
    damping_ratio : float
        Modal damping ratio of every mode of the linear structure (-).
    friction_share : float
        Friction joint: share of the joint stiffness that acts through the slider (-).
    slip_displacement_m : float
        Friction joint: relative displacement at which the slider slips (m).
    cubic_n_per_m3 : float
        Stiffening joint: cubic stiffness ``k3`` (N/m^3).
    gap_m : float
        Clearance joint: half-width of the dead zone (m).
    contact_ratio : float
        Clearance joint: contact stiffness beyond the gap per joint stiffness (-).
    """

    __test__ = False  # not a pytest class

    masses_kg: tuple = (1.0, 0.8, 0.6, 0.6, 0.5)
    springs_n_per_m: tuple = (6.0e4, 4.0e4, 2.0e4, 3.0e4, 2.5e4)
    damping_ratio: float = 0.02
    friction_share: float = 0.6
    slip_displacement_m: float = 6.0e-5
    cubic_n_per_m3: float = 1.5e10
    gap_m: float = 6.0e-5
    contact_ratio: float = 1.0

    def __post_init__(self) -> None:
        if len(self.masses_kg) != 5 or len(self.springs_n_per_m) != 5:
            raise InputError("TestStructure: expected 5 masses and 5 springs")
        if min(self.masses_kg) <= 0 or min(self.springs_n_per_m) <= 0:
            raise InputError("TestStructure: masses and springs must be positive")
        if not 0 < self.damping_ratio < 1:
            raise InputError(f"TestStructure: damping_ratio {self.damping_ratio!r}; expected in (0, 1)")


class DeadZoneSpring:
    """Clearance: no force inside ``|delta| <= gap_m``, ``stiffness (|delta| - gap)`` beyond.

    A :class:`~exudyn_study.linear.nonlinear.ForceLaw` (memoryless). Its linear tangent at
    rest is zero, so the structure's small-amplitude joint stiffness is the spring in
    parallel with the clearance.

    Parameters
    ----------
    stiffness_n_per_m : float
        Contact stiffness beyond the gap (N/m).
    gap_m : float
        Half-width of the dead zone (m).
    """

    def __init__(self, stiffness_n_per_m: float, gap_m: float) -> None:
        self.stiffness_n_per_m = float(stiffness_n_per_m)
        self.gap_m = float(gap_m)

    def initial_state(self):
        """No state."""
        return None

    def residual(self, delta, delta_t, state):
        """Contact force in N (resisting positive ``delta``), no state.

        Parameters
        ----------
        delta : float
            Relative displacement across the element (m).
        delta_t : float
            Relative velocity across the element (m/s); unused (the law is memoryless).
        state : None
            The law's state (none).

        Returns
        -------
        tuple
            ``(force, None)``: the contact force (N) and the unchanged (absent) state.
        """
        g = self.gap_m
        if delta > g:
            return self.stiffness_n_per_m * (delta - g), None
        if delta < -g:
            return self.stiffness_n_per_m * (delta + g), None
        return 0.0, None


def _matrices(structure: TestStructure):
    """Full (base + 5 masses) M, K and the modal-damping C in absolute coordinates."""
    m = np.asarray(structure.masses_kg, dtype=float)
    k = np.asarray(structure.springs_n_per_m, dtype=float)
    n = 6
    kf = np.zeros((n, n))
    for i, ki in enumerate(k):  # spring i between DOF i and i+1 (DOF 0: the table)
        kf[i, i] += ki
        kf[i + 1, i + 1] += ki
        kf[i, i + 1] -= ki
        kf[i + 1, i] -= ki
    mf = np.diag(np.concatenate([[0.0], m]))
    # modal damping of the table-clamped structure: C = M Phi diag(2 zeta w) Phi^T M
    kz, mz = kf[1:, 1:], mf[1:, 1:]
    w2, phi = np.linalg.eigh(np.linalg.solve(np.sqrt(mz), np.linalg.solve(np.sqrt(mz), kz).T))
    phi = np.linalg.solve(np.sqrt(mz), phi)  # mass-normalised
    cz = mz @ phi @ np.diag(2.0 * structure.damping_ratio * np.sqrt(w2)) @ phi.T @ mz
    cf = np.zeros((n, n))
    cf[1:, 1:] = cz
    cf[0, 1:] = cf[1:, 0] = -cz.sum(axis=1)  # rigid motion with the table is undamped
    cf[0, 0] = cz.sum()
    return mf, cf, kf


def linear_system(structure: TestStructure | None = None, force_at: str | None = None):
    """Return the structure as a :class:`~exudyn_study.linear.modes.LinearSystem` (table = drive).

    Sensors measure absolute accelerations; the joint spring is the small-amplitude stiffness.

    Parameters
    ----------
    structure : TestStructure, optional
    force_at : str, optional
        If given, the drive is a force in N on this mass (the table is fixed) instead of the
        table displacement.

    Returns
    -------
    exudyn_study.linear.modes.LinearSystem
        Coordinates ``q = (table, A1, A2, B1, B2, B3)``, ``z`` = the five masses.
    """
    from exudyn_study.linear.system import LinearSystem

    structure = structure or TestStructure()
    mf, cf, kf = _matrices(structure)
    null = np.hstack([np.zeros((5, 1)), np.eye(5)])
    if force_at is not None:
        if force_at not in SENSORS:
            raise InputError(f"force_at {force_at!r}: expected one of {', '.join(SENSORS)}")
        e = np.zeros(5)
        e[SENSORS.index(force_at)] = 1.0
        z = np.zeros(5)
        return LinearSystem(
            mass=null @ mf @ null.T,
            damping=null @ cf @ null.T,
            stiffness=null @ kf @ null.T,
            nullspace=null,
            drive_shape=np.zeros(6),
            b0=-e,
            b1=z,
            b2=z.copy(),
            sensor_map=null.copy(),
            sensor_names=SENSORS,
        )
    r = np.ones(6)
    return LinearSystem(
        mass=null @ mf @ null.T,
        damping=null @ cf @ null.T,
        stiffness=null @ kf @ null.T,
        nullspace=null,
        drive_shape=r,
        b0=null @ kf @ r,
        b1=null @ cf @ r,
        b2=null @ mf @ r,
        sensor_map=null.copy(),
        sensor_names=SENSORS,
    )


def joint_law(joint: str, structure: TestStructure | None = None):
    """(structure with the joint's small-amplitude stiffness, force law of the remainder or None).

    Parameters
    ----------
    joint : {'none', 'friction', 'stiffening', 'clearance'}
    structure : TestStructure, optional

    Returns
    -------
    structure : TestStructure
        Unchanged (the joint spring of the structure is the small-amplitude stiffness).
    law : ForceLaw or None
        The joint's force beyond that spring (None for 'none').

    Notes
    -----
    Friction: the stuck joint has the nominal stiffness; a share ``friction_share`` of it
    slips. Clearance: the open joint has the nominal stiffness, the closed one
    ``1 + contact_ratio`` times it. Stiffening: the nominal stiffness plus ``k3 delta^3``.
    """
    from exudyn_study.linear.nonlinear import CubicStiffening, JenkinsFriction

    structure = structure or TestStructure()
    if joint not in JOINTS:
        raise InputError(f"joint {joint!r}: expected one of {', '.join(JOINTS)}")
    k_joint = structure.springs_n_per_m[2]
    if joint == "none":
        return structure, None
    if joint == "friction":
        k_t = structure.friction_share * k_joint
        return structure, JenkinsFriction(k_t, k_t * structure.slip_displacement_m)
    if joint == "stiffening":
        return structure, CubicStiffening(structure.cubic_n_per_m3)
    return structure, DeadZoneSpring(structure.contact_ratio * k_joint, structure.gap_m)


def drive_signal(
    level: float,
    duration_s: float,
    sample_rate_hz: float,
    seed: int,
    band_hz: tuple[float, float] = (5.0, 120.0),
) -> np.ndarray:
    """Band-limited random table displacement (m) whose acceleration rms is ``level`` m/s^2.

    Flat acceleration spectrum in ``band_hz`` (random phases), a 0.5 s cosine fade-in.

    Parameters
    ----------
    level : float
        Acceleration rms of the table (m/s^2).
    duration_s : float
        Duration (s).
    sample_rate_hz : float
        Sampling rate (Hz).
    seed : int
        Seed of the random phases.
    band_hz : tuple of float, optional
        Band (Hz) of the flat acceleration spectrum (default (5, 120)).

    Returns
    -------
    numpy.ndarray
        Table displacement (m), shape (round(duration_s * sample_rate_hz),).
    """
    n = int(round(duration_s * sample_rate_hz))
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    spec = np.zeros(f.size, complex)
    band = (f >= band_hz[0]) & (f <= band_hz[1])
    spec[band] = np.exp(2j * np.pi * rng.random(band.sum())) / (2 * np.pi * f[band]) ** 2
    u = -np.fft.irfft(spec, n)
    acc = np.fft.irfft(spec * (2 * np.pi * f) ** 2 * -1.0, n)
    u *= level / np.sqrt(np.mean(acc**2))
    t = np.arange(n) / sample_rate_hz
    fade = np.where(t < 0.5, 0.5 - 0.5 * np.cos(np.pi * np.minimum(t, 0.5) / 0.5), 1.0)
    return u * fade


def _force_signal(level, duration_s, sample_rate_hz, seed, band_hz) -> np.ndarray:
    """Band-limited random force (N) of rms ``level`` (flat spectrum), a 0.5 s cosine fade-in."""
    n = int(round(duration_s * sample_rate_hz))
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    spec = np.zeros(f.size, complex)
    band = (f >= band_hz[0]) & (f <= band_hz[1])
    spec[band] = np.exp(2j * np.pi * rng.random(band.sum()))
    x = np.fft.irfft(spec, n)
    x *= level / np.sqrt(np.mean(x**2))
    t = np.arange(n) / sample_rate_hz
    return x * np.where(t < 0.5, 0.5 - 0.5 * np.cos(np.pi * np.minimum(t, 0.5) / 0.5), 1.0)


def simulate_levels(
    joint: str = "friction",
    levels: Sequence[float] = (0.1, 0.3, 1.0, 3.0),
    *,
    structure: TestStructure | None = None,
    duration_s: float = 16.0,
    sample_rate_hz: float = 512.0,
    noise_m_s2: float = 0.01,
    seed: int = 0,
    substeps: int = 4,
    band_hz: tuple[float, float] = (5.0, 120.0),
    force_at: str | None = None,
) -> list[Recording]:
    """Simulate the test structure at several drive levels into recordings.

    Parameters
    ----------
    joint : {'none', 'friction', 'stiffening', 'clearance'}
        The joint law of the truth.
    levels : sequence of float
        Table acceleration rms per recording in m/s^2 (each with its own random drive).
    structure : TestStructure, optional
        Default :class:`TestStructure()`.
    duration_s, sample_rate_hz : float
        Record length (s) and sampling rate (Hz) of every channel.
    noise_m_s2 : float
        Rms of the white measurement noise on each acceleration (m/s^2), the same at
        every level (a sensor noise floor).
    seed : int
        Seed of the drives and the noise (recording ``i`` uses ``seed + i``).
    substeps : int
        Sub-steps per sample of the local-nonlinear integrator.
    band_hz : (float, float)
        Band of the drive's flat acceleration spectrum in Hz (below the Nyquist frequency).
    force_at : str, optional
        Drive with a shaker force on this mass instead (table fixed): ``levels`` are then the
        force rms in N (flat force spectrum in ``band_hz``) and the drive channel ``force`` (N,
        role 'drive') sits at the mass's position.

    Returns
    -------
    list of Recording
        One per level: channels ``A1 .. B3`` (acceleration, Z) and ``drive`` (table
        displacement, role 'drive'); metadata ``source``, ``joint``, ``level_m_s2``, ``seed``.
    """
    from exudyn_study.linear.nonlinear import CubicStiffening, simulate_local_nonlinear
    from exudyn_study.model.rig import Drive

    structure, law = joint_law(joint, structure)
    lin = linear_system(structure, force_at)
    gather = np.zeros((1, 6))
    gather[0, 2], gather[0, 3] = -1.0, 1.0  # delta = B1 - A2
    law = law if law is not None else CubicStiffening(0.0)
    if not 0 < band_hz[0] < band_hz[1] < sample_rate_hz / 2:
        raise InputError(
            f"band_hz {band_hz!r}: expected 0 < low < high < Nyquist ({sample_rate_hz / 2:g} Hz)"
        )
    levels = [float(v) for v in levels]
    if not levels or min(levels) <= 0 or not all(math.isfinite(v) for v in levels):
        raise InputError(f"levels {levels!r}: expected positive accelerations in m/s^2")
    out = []
    for i, level in enumerate(levels):
        if force_at is None:
            u = drive_signal(level, duration_s, sample_rate_hz, seed + i, band_hz)
        else:
            u = _force_signal(level, duration_s, sample_rate_hz, seed + i, band_hz)
        drive = Drive()
        drive.set_signal(u, sample_rate_hz)
        acc = simulate_local_nonlinear(lin, drive, gather, [law], substeps=substeps)
        rng = np.random.default_rng(10_000 + seed + i)
        acc = acc + noise_m_s2 * rng.standard_normal(acc.shape)
        chans = [
            Channel(name, "acceleration", "m/s^2", "Z", _POSITIONS_M[name], sample_rate_hz, row)
            for name, row in zip(SENSORS, acc, strict=True)
        ]
        if force_at is None:
            chans.append(Channel("drive", "displacement", "m", "Z", None, sample_rate_hz, u, role="drive"))
        else:
            pos = _POSITIONS_M[force_at]
            chans.append(Channel("force", "force", "N", "Z", pos, sample_rate_hz, u, role="drive"))
        out.append(
            Recording(
                tuple(chans),
                {
                    "source": "exudyn_study.diagnose.testbench",
                    "joint": joint,
                    "level_m_s2": level,
                    "seed": seed + i,
                },
            )
        )
    return out
