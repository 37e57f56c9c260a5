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
- :class:`SensorGainHypothesis`: the nominal system, one channel scaled;
- :class:`ConnectorHypothesis`: an entry that adds or changes one connector (a joint's
  6-DOF spring-damper): built once, then the connector's stiffness and damping are set on
  the assembled model and re-linearised (one Exudyn build, not one per parameter);
- :class:`LocalElementHypothesis`: an entry with local nonlinear elements (simulated in
  time, :class:`NonlinearSystem`); its linear part may be affine in a parameter too.

Every hypothesis knows how it is carried into the next round's model once it is a finding
(:meth:`Hypothesis.carried`): the catalogue entry applied at ``apply_location`` with its
fitted values plus ``fixed`` ones, or (``carry='gains'``) only as output gains.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..modal import LinearSystem

__all__ = [
    "Hypothesis",
    "ConnectorHypothesis",
    "LocalElementHypothesis",
    "NonlinearSystem",
    "AffineHypothesis",
    "AddedMassHypothesis",
    "ModalDampingHypothesis",
    "SensorGainHypothesis",
    "project",
]


def project(full_m, full_c, full_k, base: LinearSystem) -> LinearSystem:
    """Return the constrained system of full matrices with ``base``'s null space, drive shape and sensors."""
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
    #: entry values carried with the finding besides the fitted ones (e.g. a fixed band)
    fixed: dict = field(default_factory=dict)
    #: the entry's ``location`` argument when carried (default: ``location``)
    apply_location: str | None = None
    #: 'model' (the entry is applied to the next round's model) or 'gains' (output gains only)
    carry: str = "model"
    #: parameters that may come out unidentifiable without rejecting the candidate, as long as
    #: one parameter is identifiable (their effect is then negligible, e.g. a joint's damping
    #: time when the joint adds no damping, or its stiffness beyond what the data resolve)
    may_vanish: tuple = ()
    #: screening grid of a one-parameter candidate (None: scored by a short fit)
    screen_grid: tuple | None = None

    def system(self, p) -> LinearSystem:  # pragma: no cover - abstract
        """Return the candidate's system at parameters ``p`` (a LinearSystem or NonlinearSystem)."""
        raise NotImplementedError

    @property
    def kind_linear(self) -> bool:
        """Whether the candidate's systems are linear (cheap to evaluate)."""
        return not isinstance(self, LocalElementHypothesis)

    def carried(self, p) -> tuple:
        """(catalogue entry, location, values) that put the finding at ``p`` into a model."""
        values = {n: float(v) for n, v in zip(self.names, p, strict=True)}
        values.update(self.fixed)
        return self.physics, self.apply_location if self.apply_location is not None else self.location, values

    def gains(self, p, channels) -> np.ndarray | None:
        """Output gain per channel (None: all 1)."""
        return None

    @property
    def label(self) -> str:
        return f"{self.physics}@{self.location}"


def _entry_fields(entry, start: dict):
    """(names, units, lower, upper, start) of a catalogue entry's parameters named in ``start``."""
    params = [entry.parameter(n) for n in start]
    return (
        tuple(start),
        tuple(p.unit for p in params),
        np.array([p.lower for p in params]),
        np.array([p.upper for p in params]),
        np.array([float(v) for v in start.values()]),
    )


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
        self.p0 = self.start.copy()  # where ``base`` was linearised (``start`` may move in screening)
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
        dp = np.asarray(p, dtype=float) - self.p0
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


def model_system(model):
    """Return the assembled ``model`` as the diagnosis simulates it.

    Its linearisation, plus its local nonlinear elements (:class:`NonlinearSystem`) if it has any.
    """
    from ..modal import linearize
    from ..physics.nonlinear import gather_vectors

    if not model.assembled:
        model.assemble()
    lin = linearize(model)
    elements = list(getattr(model, "local_nonlinearities", ()))
    if not elements:
        return lin
    return NonlinearSystem(lin, gather_vectors(model, elements), [el.law for el in elements])


class _Relinearised:
    """One assembled model whose connector items are changed in place and re-linearised.

    The unprojected linearised matrices of a connector (spring-damper) are linear in its
    stiffness and damping entries, so two linearisations give an exact derivative; the
    constraints (null space, drive shape) do not depend on them.
    """

    def __init__(self, model):
        from ..modal import linearize

        self.model = model
        self.base = linearize(model)

    def derivative(self, item: int, name: str, base_value, changed_value, scale: float):
        """(dM, dC, dK) of setting parameter ``name`` of ``item`` from base to changed, per ``scale``."""
        from ..modal import linearize

        mbs = self.model.mbs
        mbs.SetObjectParameter(item, name, changed_value)
        try:
            other = linearize(self.model)
        finally:
            mbs.SetObjectParameter(item, name, base_value)
        return tuple(
            (b - a) / scale
            for a, b in (
                (self.base.full_mass, other.full_mass),
                (self.base.full_damping, other.full_damping),
                (self.base.full_stiffness, other.full_stiffness),
            )
        )


class ConnectorHypothesis(Hypothesis):
    """A bolted joint as a 6-DOF spring-damper (``joint_stiffness``), one Exudyn build.

    The entry is applied at ``start`` with no damping; the derivatives of the matrices by the
    translational and rotational stiffness and by unit translational and rotational damping
    are taken on the same assembled model (:class:`_Relinearised`). With the entry's
    stiffness-proportional damping ``C = t diag(k)``, the system at ``p = (k_t, k_r, t)`` is
    ``K0 + (k_t - k_t0) dK_t + (k_r - k_r0) dK_r`` and ``C0 + t (k_t dC_t + k_r dC_r)``,
    exact (``C`` is bilinear in ``k`` and ``t``, which a purely affine interpolation is not).
    """

    def __init__(self, physics, location, entry, build: Callable, start: dict, **where):
        super().__init__(physics, location, *_entry_fields(entry, start), **where)
        kt, kr = float(start["stiffness_n_per_m"]), float(start["rotational_stiffness_n_m_per_rad"])
        model = build()
        applied = entry.apply(model, location, **{**start, "damping_time_s": 0.0})
        model.assemble()
        rl = _Relinearised(model)
        spring = int(applied.items["spring"])
        stiff = np.diag([kt] * 3 + [kr] * 3).tolist()
        zero = np.zeros((6, 6)).tolist()
        self.base = rl.base
        self.d_kt = rl.derivative(spring, "stiffness", stiff, np.diag([2 * kt] * 3 + [kr] * 3).tolist(), kt)[
            2
        ]
        self.d_kr = rl.derivative(spring, "stiffness", stiff, np.diag([kt] * 3 + [2 * kr] * 3).tolist(), kr)[
            2
        ]
        self.d_ct = rl.derivative(spring, "damping", zero, np.diag([1.0] * 3 + [0.0] * 3).tolist(), 1.0)[1]
        self.d_cr = rl.derivative(spring, "damping", zero, np.diag([0.0] * 3 + [1.0] * 3).tolist(), 1.0)[1]
        self.k0 = (kt, kr)

    def system(self, p):
        kt, kr, t = (float(v) for v in p)
        k = self.base.full_stiffness + (kt - self.k0[0]) * self.d_kt + (kr - self.k0[1]) * self.d_kr
        c = self.base.full_damping + t * (kt * self.d_ct + kr * self.d_cr)
        return project(self.base.full_mass, c, k, self.base)


class LocalElementHypothesis(Hypothesis):
    """A catalogue entry that adds local nonlinear elements (``bushing_stiffening``, ``joint_friction``).

    The entry is applied once to the current model (which may carry earlier nonlinear
    findings: their elements keep their fitted laws); the fitted parameters change the new
    elements' force laws, built by ``make_laws(p, elements)``. If the entry also adds a
    linear tangent that depends on a parameter (``joint_friction``'s stuck spring),
    ``tangent=(item label, Exudyn parameter, value(p))`` names the connector item and its
    parameter as a function of ``p``; the tangent is linear in it (:class:`_Relinearised`).
    """

    def __init__(
        self,
        physics,
        location,
        entry,
        build: Callable,
        start: dict,
        make_laws: Callable,
        tangent: tuple | None = None,
        substeps: int = 4,
        **where,
    ):
        super().__init__(physics, location, *_entry_fields(entry, start), **where)
        from ..physics.nonlinear import gather_vectors

        model = build()
        n_old = len(model.local_nonlinearities)
        applied = entry.apply(model, location, **start)
        model.assemble()
        rl = _Relinearised(model)
        self.lin = rl.base
        elements = list(model.local_nonlinearities)
        self.old_laws = [el.law for el in elements[:n_old]]
        self.elements = elements[n_old:]
        self.gather = gather_vectors(model, elements)
        self.make_laws = make_laws
        self.substeps = substeps
        self.tangent = None
        if tangent is not None:
            label, name, value = tangent
            item = int(applied.items[label])
            v0 = np.asarray(value(self.start), dtype=float)
            scale = float(np.max(np.abs(v0)))
            self.tangent = (
                value,
                v0,
                scale,
                rl.derivative(item, name, v0.tolist(), (2 * v0).tolist(), scale),
            )

    def system(self, p):
        """Return the linear tangent system with the element laws at ``p``."""
        p = np.asarray(p, dtype=float)
        lin = self.lin
        if self.tangent is not None:
            value, v0, scale, (d_m, d_c, d_k) = self.tangent
            s = float(np.max(np.abs(np.asarray(value(p), dtype=float)))) - scale
            # the tangent's parameter is value(p) = v0 * (scale + s) / scale
            lin = project(
                lin.full_mass + s * d_m, lin.full_damping + s * d_c, lin.full_stiffness + s * d_k, lin
            )
        laws = self.old_laws + list(self.make_laws(p, self.elements))
        return NonlinearSystem(lin, self.gather, laws, self.substeps)
