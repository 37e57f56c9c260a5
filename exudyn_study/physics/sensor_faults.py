"""Sensor faults as catalogue entries: what the acquisition did wrong, not the structure.

Each entry appends a :class:`SensorFault` to ``model.output_faults`` (a list the entry creates
on the model if absent); :func:`~exudyn_study.simulate.run.simulate` applies them, in order, to
the simulated channels after the sensors' ``output_gains``. None adds an Exudyn item: the
modes and the linearisation are unchanged. The diagnosis applies the same :class:`SensorFault`
to its simulations (:mod:`exudyn_study.diagnose.rig_candidates`).

- ``sensor_polarity``: a sensor mounted the wrong way round (reads ``-gain`` times the truth);
- ``sensor_swap``: two channels' cables swapped (location ``'A/B'``);
- ``sensor_axis``: a sensor mounted rotated, measuring another axis of its point (``'A>B'``:
  channel ``A`` reads what channel ``B``, at the same point, measures);
- ``sensor_dead``: a channel that records only noise (broken cable, unpowered sensor);
- ``sensor_clipped``: a channel that saturates at ``clip_level_m_per_s2`` (its range set too low);
- ``sensor_delay``: a channel recorded ``delay_s`` late (a filter or sampling offset).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.physics.catalogue import Parameter, PhysicsEntry, register

__all__ = [
    "SensorFault",
    "SENSOR_POLARITY",
    "SENSOR_SWAP",
    "SENSOR_AXIS",
    "SENSOR_DEAD",
    "SENSOR_CLIPPED",
    "SENSOR_DELAY",
    "FAULT_KINDS",
]

#: fault kind -> catalogue entry
FAULT_KINDS = {
    "polarity": "sensor_polarity",
    "swap": "sensor_swap",
    "axis": "sensor_axis",
    "dead": "sensor_dead",
    "clipped": "sensor_clipped",
    "delay": "sensor_delay",
}

#: two sensors of one measuring point (a triaxial block, one bracket) are closer than this (m)
SAME_POINT_M = 0.05


@dataclass(frozen=True)
class SensorFault:
    """One acquisition fault on channel ``channel`` (and ``other`` for a swap or a wrong axis).

    Parameters
    ----------
    kind : {'polarity', 'swap', 'axis', 'dead', 'clipped', 'delay'}
        See the module docstring.
    channel : str
        The faulty channel.
    other : str, optional
        The channel it is swapped with (``'swap'``) or whose axis it measures (``'axis'``).
    value : float
        ``'polarity'``: the gain magnitude (the channel reads ``-value`` times the truth);
        ``'clipped'``: the saturation level (m/s^2); ``'delay'``: the delay (s); else unused.
    """

    kind: str
    channel: str
    other: str | None = None
    value: float = 1.0

    def __post_init__(self):
        if self.kind not in FAULT_KINDS:
            raise InputError(f"sensor fault kind {self.kind!r}; expected one of {sorted(FAULT_KINDS)}")
        if (self.kind in ("swap", "axis")) != (self.other is not None):
            raise InputError(f"sensor fault {self.kind!r} on {self.channel!r}: other channel {self.other!r}")
        if not math.isfinite(self.value):
            raise InputError(f"sensor fault {self.kind!r} on {self.channel!r}: value {self.value!r}")

    @property
    def linear(self) -> bool:
        """Whether the fault is a linear map of the channels (all but clipping)."""
        return self.kind != "clipped"

    def _rows(self, names) -> tuple:
        names = list(names)
        if self.channel not in names or (self.other is not None and self.other not in names):
            raise InputError(
                f"sensor fault {self.kind!r} on {self.channel!r}"
                + (f"/{self.other!r}" if self.other else "")
                + f": not among the channels {names}"
            )
        return names.index(self.channel), (names.index(self.other) if self.other is not None else None)

    def apply(self, y: np.ndarray, names, rate_hz: float) -> np.ndarray:
        """Return the channels ``y`` (n_channels, n_samples; rows ``names``) as recorded with the fault.

        Parameters
        ----------
        y : numpy.ndarray
            Recorded channels, shape ``(n_channels, n_samples)``.
        names : sequence of str
            Channel name of each row of ``y``; the fault's channels are looked up in it.
        rate_hz : float
            Sampling rate in Hz (used by the delay fault).

        Returns
        -------
        numpy.ndarray
            Copy of ``y`` (float) with the fault applied to its channels.
        """
        i, j = self._rows(names)
        out = np.array(y, dtype=float, copy=True)
        if self.kind == "polarity":
            out[i] = -self.value * out[i]
        elif self.kind == "swap":
            out[[i, j]] = out[[j, i]]
        elif self.kind == "axis":
            out[i] = y[j]
        elif self.kind == "dead":
            out[i] = 0.0
        elif self.kind == "clipped":
            out[i] = np.clip(out[i], -self.value, self.value)
        else:  # delay: y(t - tau), band-limited (the phase of each Fourier line), zero-padded
            n = out.shape[1]
            pad = int(math.ceil(abs(self.value) * rate_hz)) + 64
            n_fft = 1 << int(math.ceil(math.log2(n + pad)))
            spec = np.fft.rfft(out[i], n_fft)
            f = np.fft.rfftfreq(n_fft, 1.0 / rate_hz)
            out[i] = np.fft.irfft(spec * np.exp(-2j * np.pi * f * self.value), n_fft)[:n]
        return out

    def apply_frf(self, h: np.ndarray, names, freq_hz) -> np.ndarray:
        """Return the FRFs ``h`` (n_channels, n_freq) as the faulty channels see them (clipping: none).

        Parameters
        ----------
        h : numpy.ndarray
            Complex FRFs, shape ``(n_channels, n_freq)``.
        names : sequence of str
            Channel name of each row of ``h``; the fault's channels are looked up in it.
        freq_hz : array_like
            Frequency lines in Hz, shape ``(n_freq,)`` (used by the delay fault).

        Returns
        -------
        numpy.ndarray
            Complex copy of ``h`` with the fault applied to its channels.
        """
        i, j = self._rows(names)
        out = np.array(h, dtype=complex, copy=True)
        if self.kind == "polarity":
            out[i] = -self.value * out[i]
        elif self.kind == "swap":
            out[[i, j]] = out[[j, i]]
        elif self.kind == "axis":
            out[i] = h[j]
        elif self.kind == "dead":
            out[i] = 0.0
        elif self.kind == "delay":
            out[i] = out[i] * np.exp(-2j * np.pi * np.asarray(freq_hz) * self.value)
        return out


def _faults(model) -> list:
    faults = getattr(model, "output_faults", None)
    if faults is None:
        faults = []
        model.output_faults = faults
    return faults


def _sensor(who: str):
    def check(model, location) -> str:
        if not (isinstance(location, str) and location in model.sensors):
            raise InputError(
                f"{who}: location {location!r}; expected a sensor of the model, one of {list(model.sensors)}"
            )
        return location

    return check


def _pair(who: str, sep: str, same_point: bool):
    def check(model, location) -> str:
        parts = location.split(sep) if isinstance(location, str) else []
        if len(parts) != 2 or parts[0] == parts[1] or not all(p in model.sensors for p in parts):
            raise InputError(
                f"{who}: location {location!r}; expected two different sensors of the model as "
                f"'A{sep}B', from {list(model.sensors)}"
            )
        if same_point:
            a, b = (np.asarray(model.sensors[p].sensor.position_m, dtype=float) for p in parts)
            if np.linalg.norm(a - b) > SAME_POINT_M:
                raise InputError(
                    f"{who}: sensors {parts[0]!r} and {parts[1]!r} are {np.linalg.norm(a - b):.3f} m apart; "
                    "a sensor mounted rotated measures another axis of its own point"
                )
        return location

    return check


def _add(kind: str, sep: str | None = None, value: str | None = None):
    def add(model, location: str, params: dict) -> dict:
        channel, other = location.split(sep) if sep else (location, None)
        _faults(model).append(SensorFault(kind, channel, other, float(params[value]) if value else 1.0))
        return {}

    return add


_SIGNATURE_NONE = "gives no Exudyn item; the modes and the linearised system are unchanged."

SENSOR_POLARITY = register(PhysicsEntry(
    name="sensor_polarity",
    doc=f"""A sensor mounted the wrong way round: its channel reads ``-gain`` times the true acceleration.

Physics: an accelerometer glued upside down (or a reversed cable polarity) measures along the
negative of its stated direction; with a calibration error besides, ``gain`` times that. It
{_SIGNATURE_NONE}

Signature: one channel's FRF phase turned by 180 degrees at all frequencies (its magnitude times
``gain``); its coefficient in every mode shape changes sign, so the MAC with a shape that moves
that sensor drops; no other channel changes.
""",
    parameters=(Parameter("gain", "1", 0.5, 2.0, 1.0, "magnitude of true / stated sensitivity"),),
    add_items=_add("polarity", value="gain"),
    locations="a sensor of the model (e.g. 'ARFVZ')",
    check_location=_sensor("sensor_polarity"),
))

SENSOR_SWAP = register(PhysicsEntry(
    name="sensor_swap",
    doc=f"""Two channels' cables swapped: channel ``A`` records sensor ``B``'s signal and vice versa.

Physics: a wiring or channel-table error of the acquisition; location ``'A/B'``. It {_SIGNATURE_NONE}

Signature: the two channels' FRFs exchanged at all frequencies and levels (each matches the
other's model FRF exactly); no other channel changes.
""",
    parameters=(),
    add_items=_add("swap", sep="/"),
    locations="two sensors of the model as 'A/B' (e.g. 'ARFVZ/ARHBZ')",
    check_location=_pair("sensor_swap", "/", same_point=False),
))

SENSOR_AXIS = register(PhysicsEntry(
    name="sensor_axis",
    doc=f"""A sensor mounted rotated: channel ``A`` measures the axis of channel ``B`` at the same point.

Physics: a triaxial block or a single-axis sensor turned by 90 degrees on its mount, so the
channel stated as one direction records another (location ``'A>B'``: both sensors at one point).
It {_SIGNATURE_NONE}

Signature: channel ``A``'s FRF equals the model's FRF of ``B`` (its own direction's model FRF
fits nowhere); channel ``B`` is unchanged, so the two recorded channels agree.
""",
    parameters=(),
    add_items=_add("axis", sep=">"),
    locations="two sensors of one point of the model as 'A>B' (e.g. 'ARFVZ>ARFVY')",
    check_location=_pair("sensor_axis", ">", same_point=True),
))

SENSOR_DEAD = register(PhysicsEntry(
    name="sensor_dead",
    doc=f"""A dead channel: it records only the acquisition's noise (broken cable, unpowered sensor).

Physics: no acceleration reaches the channel; the measurement chain's noise and quantisation
remain. It {_SIGNATURE_NONE}

Signature: one channel at the noise floor at all frequencies, incoherent with the drive, while
the model predicts a response there; no other channel changes.
""",
    parameters=(),
    add_items=_add("dead"),
    locations="a sensor of the model (e.g. 'ARFVZ')",
    check_location=_sensor("sensor_dead"),
))

SENSOR_CLIPPED = register(PhysicsEntry(
    name="sensor_clipped",
    doc=f"""A clipped channel: it saturates at ``clip_level_m_per_s2`` (its input range set too low).

Physics: the sensor's or the amplifier's range ends below the peaks of the response; the
channel is flat at plus or minus the level while the response exceeds it. It {_SIGNATURE_NONE}

Signature: flat tops at one constant magnitude in one channel; odd harmonics and a broadband
residual that grow with the drive level (the response exceeds the level more often); the FRF
magnitude drops at the strongest resonances; no other channel changes.
""",
    parameters=(Parameter("clip_level_m_per_s2", "m/s^2", 0.01, 1e4, 10.0, "saturation level"),),
    add_items=_add("clipped", value="clip_level_m_per_s2"),
    locations="a sensor of the model (e.g. 'ARFVZ')",
    check_location=_sensor("sensor_clipped"),
))

SENSOR_DELAY = register(PhysicsEntry(
    name="sensor_delay",
    doc=f"""A channel recorded late by ``delay_s`` (negative: early), e.g. a filter or sampling offset.

Physics: the channel's samples belong to ``delay_s`` earlier than their time stamps (a group
delay of its conditioning, a multiplexer's offset). It {_SIGNATURE_NONE}

Signature: one channel's FRF phase falls linearly with frequency (``-2 pi f delay_s``); its
magnitude and the other channels are unchanged, so the residual grows with frequency.
""",
    parameters=(Parameter("delay_s", "s", -0.05, 0.05, 0.002, "delay of the channel"),),
    add_items=_add("delay", value="delay_s"),
    locations="a sensor of the model (e.g. 'ARFVZ')",
    check_location=_sensor("sensor_delay"),
))
