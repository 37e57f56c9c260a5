"""Candidate physics as cheap linear systems: ``hypothesis.system(p) -> LinearSystem``.

A hypothesis is a catalogue entry at one location with free parameters. For fitting it
must evaluate fast, so the Exudyn model is not rebuilt per evaluation: the unprojected
linearised matrices ``M(p), C(p), K(p)`` of these entries are affine in their parameters
(a point mass, a spring, a dashpot, a damping factor), and the constrained system is
formed with the null space ``N`` and a drive shape ``r`` that satisfy the constraints of
every ``p`` (``q = r u + N^T z`` is exact for any admissible ``r``):

- :class:`AffineHypothesis`: any catalogue entry whose parameters enter linearly; the
  matrices are linearised once at ``p0`` and once per parameter at ``p0 + step`` (Exudyn
  builds, a few seconds), then interpolated exactly;
- :class:`AddedMassHypothesis`: ``M(p) = M0 + m P^T P`` with ``P`` the location's marker
  displacement map on the nominal model (no build at all);
- :class:`ModalDampingHypothesis`: ``C(p) = C0 + (factor - 1) C_body`` (the body's block);
- :class:`SensorGainHypothesis`: the nominal system, one channel scaled.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..modal import LinearSystem

__all__ = [
    "Hypothesis",
    "AffineHypothesis",
    "AddedMassHypothesis",
    "ModalDampingHypothesis",
    "SensorGainHypothesis",
    "project",
]


def project(full_m, full_c, full_k, base: LinearSystem) -> LinearSystem:
    """The constrained system of full matrices with ``base``'s null space, drive shape and sensors."""
    n = base.nullspace
    r = base.drive_shape
    mz, cz, kz = (n @ a @ n.T for a in (full_m, full_c, full_k))
    mz, cz, kz = (0.5 * (a + a.T) for a in (mz, cz, kz))
    return LinearSystem(
        mass=mz,
        damping=cz,
        stiffness=kz,
        nullspace=n,
        drive_shape=r,
        b0=n @ full_k @ r,
        b1=n @ full_c @ r,
        b2=n @ full_m @ r,
        sensor_map=base.sensor_map,
        sensor_names=base.sensor_names,
        metadata=base.metadata,
        full_mass=full_m,
        full_damping=full_c,
        full_stiffness=full_k,
    )


@dataclass
class Hypothesis:
    """Base: ``physics`` at ``location`` with parameters (names, units, bounds, start values)."""

    physics: str
    location: str | None
    names: tuple
    units: tuple
    lower: np.ndarray
    upper: np.ndarray
    start: np.ndarray
    component: str | None = None
    sensors: tuple = ()
    interface: str | None = None

    def system(self, p) -> LinearSystem:  # pragma: no cover - abstract
        raise NotImplementedError

    def gains(self, p, channels) -> np.ndarray | None:
        """Output gain per channel (None: all 1)."""
        return None

    @property
    def label(self) -> str:
        return f"{self.physics}@{self.location}"


def _entry_fields(entry, start: dict):
    """(names, units, lower, upper, start) of a catalogue entry's parameters named in ``start``."""
    params = [entry.parameter(n) for n in start]
    return (tuple(start), tuple(p.unit for p in params), np.array([p.lower for p in params]),
            np.array([p.upper for p in params]), np.array([float(v) for v in start.values()]))


class AffineHypothesis(Hypothesis):
    """Entry whose parameters enter the unprojected matrices linearly (see module docstring)."""

    def __init__(self, physics, location, entry, build: Callable, start: dict, steps: dict, **where):
        super().__init__(physics, location, *_entry_fields(entry, start), **where)
        from ..modal import linearize

        def lin_at(values):
            model = build()
            entry.apply(model, location, **values)
            model.assemble()
            return linearize(model)

        self.base = lin_at(dict(start))
        self.d_m, self.d_c, self.d_k = [], [], []
        for name in start:
            values = dict(start)
            values[name] = start[name] + steps[name]
            other = lin_at(values)
            if other.full_mass.shape != self.base.full_mass.shape:
                raise RuntimeError(f"{physics}: the model's coordinates change with {name}")
            s = steps[name]
            self.d_m.append((other.full_mass - self.base.full_mass) / s)
            self.d_c.append((other.full_damping - self.base.full_damping) / s)
            self.d_k.append((other.full_stiffness - self.base.full_stiffness) / s)

    def system(self, p):
        dp = np.asarray(p, dtype=float) - self.start
        m, c, k = self.base.full_mass.copy(), self.base.full_damping.copy(), self.base.full_stiffness.copy()
        for i, v in enumerate(dp):
            if v != 0.0:
                m += v * self.d_m[i]
                c += v * self.d_c[i]
                k += v * self.d_k[i]
        return project(m, c, k, self.base)


class AddedMassHypothesis(Hypothesis):
    """A rigid point mass at a marker: ``M0 + m P^T P``."""

    def __init__(
        self,
        location,
        nominal: LinearSystem,
        displacement_map: np.ndarray,
        bounds=(0.01, 500.0),
        start=1.0,
        **where,
    ):
        super().__init__(
            "added_mass",
            location,
            ("mass_kg",),
            ("kg",),
            np.array([bounds[0]]),
            np.array([bounds[1]]),
            np.array([start]),
            **where,
        )
        self.nominal = nominal
        self.ptp = displacement_map.T @ displacement_map

    def system(self, p):
        return project(
            self.nominal.full_mass + float(p[0]) * self.ptp,
            self.nominal.full_damping,
            self.nominal.full_stiffness,
            self.nominal,
        )


class ModalDampingHypothesis(Hypothesis):
    """The damping of one flexible body's modes scaled by ``factor``."""

    def __init__(
        self, location, nominal: LinearSystem, body_indices: np.ndarray, bounds=(0.1, 10.0), **where
    ):
        super().__init__(
            "modal_damping",
            location,
            ("factor",),
            ("1",),
            np.array([bounds[0]]),
            np.array([bounds[1]]),
            np.array([1.0]),
            **where,
        )
        self.nominal = nominal
        c_body = np.zeros_like(nominal.full_damping)
        idx = np.asarray(body_indices, dtype=int)
        c_body[np.ix_(idx, idx)] = nominal.full_damping[np.ix_(idx, idx)]
        self.c_body = c_body

    def system(self, p):
        return project(
            self.nominal.full_mass,
            self.nominal.full_damping + (float(p[0]) - 1.0) * self.c_body,
            self.nominal.full_stiffness,
            self.nominal,
        )


class SensorGainHypothesis(Hypothesis):
    """One channel's true sensitivity differs from the stated one by ``gain``."""

    def __init__(self, channel, nominal: LinearSystem, bounds=(0.5, 2.0), **where):
        super().__init__(
            "sensor_gain",
            channel,
            ("gain",),
            ("1",),
            np.array([bounds[0]]),
            np.array([bounds[1]]),
            np.array([1.0]),
            **where,
        )
        self.nominal = nominal

    def system(self, p):
        return self.nominal

    def gains(self, p, channels):
        g = np.ones(len(channels))
        g[list(channels).index(self.location)] = float(p[0])
        return g


def log_bounds(h: Hypothesis):
    """Bounds in the fitting variable: log for non-negative parameters (a zero lower bound
    becomes ``upper * 1e-6``), linear otherwise.
    """
    pos = (h.lower >= 0) & (h.upper > 0)
    lower = np.where(pos & (h.lower <= 0), h.upper * 1e-6, h.lower)
    lo = np.where(pos, np.log(np.maximum(lower, 1e-300)), h.lower)
    hi = np.where(pos, np.log(np.maximum(h.upper, 1e-300)), h.upper)
    return pos, lo, hi


def to_params(h: Hypothesis, x):
    pos, _, _ = log_bounds(h)
    x = np.asarray(x, dtype=float)
    out = x.copy()
    out[pos] = np.exp(x[pos])
    return out


def to_x(h: Hypothesis, p):
    pos, _, _ = log_bounds(h)
    p = np.asarray(p, dtype=float)
    return np.where(pos, np.log(np.maximum(p, 1e-300)), p)


@dataclass
class NonlinearSystem:
    """A linearised system plus local residual force elements (simulated in time, not by FRF)."""

    lin: LinearSystem
    gather: np.ndarray
    laws: list
    substeps: int = 4


class LocalElementHypothesis(Hypothesis):
    """A catalogue entry that adds local nonlinear elements (e.g. ``bushing_stiffening``).

    The entry is applied once (its linear items do not depend on the fitted parameters);
    the fitted parameters only change the force laws, built by ``make_laws(p)``.
    """

    def __init__(self, physics, location, entry, build: Callable, start: dict, make_laws: Callable, **where):
        super().__init__(physics, location, *_entry_fields(entry, start), **where)
        from ..modal import linearize
        from ..physics.nonlinear import gather_vectors

        model = build()
        entry.apply(model, location, **start)
        model.assemble()
        self.lin = linearize(model)
        self.elements = list(model.local_nonlinearities)
        self.gather = gather_vectors(model, self.elements)
        self.make_laws = make_laws

    def system(self, p):
        """The linear tangent system with the element laws at ``p``."""
        laws = self.make_laws(np.asarray(p, dtype=float), self.elements)
        return NonlinearSystem(self.lin, self.gather, laws)
