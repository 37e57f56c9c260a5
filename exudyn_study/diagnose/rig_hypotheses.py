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
- :class:`PointResonatorHypothesis`: a mass on a spring-damper at a point (``tuned_mass_damper``):
  three coordinates appended to the nominal ones (no build at all);
- :class:`GroundElementHypothesis`: a spring-damper from a point to ground, ``K0 + k P^T P``,
  ``C0 + c P^T P`` (the generic local element, carried as ``ground_spring_damper``);
- :class:`SensorGainHypothesis`: the nominal system, one channel scaled;
- :class:`SensorFaultHypothesis`: the nominal system, one acquisition fault on its channels
  (:class:`~exudyn_study.physics.sensor_faults.SensorFault`: polarity, swap, wrong axis, dead,
  clipped, delayed), carried as an :class:`OutputChain`;
- :class:`SloshingHypothesis`: the ``sloshing`` entry at a fixed slosh frequency, exact in its
  mass, damping ratio and lateral damping factor (four builds);
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

from exudyn_study.linear.system import LinearSystem

__all__ = [
    "Hypothesis",
    "HeldHypothesis",
    "ConnectorHypothesis",
    "LocalElementHypothesis",
    "NonlinearSystem",
    "CompositeHypothesis",
    "AffineHypothesis",
    "AddedMassHypothesis",
    "PointResonatorHypothesis",
    "GroundElementHypothesis",
    "ModalDampingHypothesis",
    "SensorGainHypothesis",
    "SensorFaultHypothesis",
    "OutputChain",
    "apply_output",
    "apply_output_frf",
    "SloshingHypothesis",
    "project",
]


def project(full_m, full_c, full_k, base: LinearSystem) -> LinearSystem:
    """Return the constrained system of full matrices with ``base``'s null space, drive shape and sensors.

    Parameters
    ----------
    full_m, full_c, full_k : numpy.ndarray
        Unprojected mass (kg), damping (N s/m) and stiffness (N/m) matrices, shape (n_q, n_q), in the
        coordinates of ``base``.
    base : LinearSystem
        System whose null space, drive shape, sensor map, sensor names and metadata the result takes.

    Returns
    -------
    LinearSystem
        The constrained (symmetrised) system with the full matrices kept as ``full_mass`` etc.
    """
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
    """Base: ``physics`` at ``location`` with parameters (names, units, bounds, start values).

    Parameters
    ----------
    physics : str
        Name of the catalogue entry (or the diagnosis's own physics, such as ``'local_element'``).
    location : str or None
        Where the entry acts: a catalogue location, a marker, a channel, or None for a global entry.
    names : tuple of str
        Names of the fitted parameters.
    units : tuple of str
        Unit of each parameter (``'1'`` for a dimensionless one).
    lower, upper : numpy.ndarray
        Lower and upper bound of each parameter, shape (n_params,).
    start : numpy.ndarray
        Start value of each parameter, shape (n_params,); screening may move it.
    component : str or None, optional
        Rig component the location belongs to (None: not tied to one).
    sensors : tuple of str, optional
        Channels near the location (empty: none named).
    interface : str or None, optional
        Interface of ``component`` the location lies on (None: none).
    fixed : dict, optional
        Entry values carried with the finding besides the fitted ones (e.g. a fixed band).
    apply_location : str or None, optional
        The entry's ``location`` argument when carried (None: ``location``).
    carry : {'model', 'gains'}, optional
        ``'model'``: the entry is applied to the next round's model; ``'gains'``: only output gains.
    may_vanish : tuple of str, optional
        Parameters that may come out unidentifiable without rejecting the candidate, as long as one
        parameter is identifiable.
    screen_grid : tuple or None, optional
        Screening grid of a one-parameter candidate (None: scored by a short fit).
    neutral : dict or None, optional
        Parameter values at which the candidate leaves the current model's response unchanged (None:
        the member cannot be taken out of a joint fit).
    one_per_component : bool, optional
        Whether a joint fit takes at most one candidate of this physics per component (default True).
    prior : dict, optional
        Prior start values by parameter name, a joint fit's second start (empty: taken from ``start``).
    """

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
    #: parameter values at which the candidate leaves the current model's response unchanged (a
    #: joint at its stiffest, a damping factor of one); a joint fit tests each member against the
    #: others refitted with it there (None: the member cannot be taken out)
    neutral: dict | None = None
    #: a joint fit takes at most one candidate of this physics per component (two joints of one
    #: component trade off against each other); False: each of its locations may join (the frame's two
    #: rear supports, which a symmetric structure needs together)
    one_per_component: bool = True
    #: prior start values (the candidate's start before screening moves ``start``): a joint fit's second
    #: start (RigDiagnosisSettings.composite_prior_start)
    prior: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.prior:
            self.prior = {n: float(v) for n, v in zip(self.names, np.atleast_1d(self.start), strict=False)}

    def system(self, p) -> LinearSystem:  # pragma: no cover - abstract
        """Return the candidate's system at parameters ``p`` (a LinearSystem or NonlinearSystem).

        Parameters
        ----------
        p : array_like
            Parameter values, shape (n_params,), in the order of ``names``.

        Returns
        -------
        LinearSystem or NonlinearSystem
            The candidate's system at ``p``.

        Raises
        ------
        NotImplementedError
            Always: each subclass defines its system.
        """
        raise NotImplementedError

    @property
    def kind_linear(self) -> bool:
        """Whether the candidate's systems are linear (cheap to evaluate)."""
        return not isinstance(self, LocalElementHypothesis)

    def carried(self, p) -> tuple:
        """(catalogue entry, location, values) that put the finding at ``p`` into a model.

        Parameters
        ----------
        p : array_like
            Fitted parameter values, shape (n_params,), in the order of ``names``.

        Returns
        -------
        tuple
            ``(physics, location, values)``: the catalogue entry's name, its location and its parameter
            values (the fitted ones mapped by :meth:`entry_values`, plus ``fixed``).
        """
        values = self.entry_values({n: float(v) for n, v in zip(self.names, p, strict=True)})
        values.update(self.fixed)
        return self.physics, self.apply_location if self.apply_location is not None else self.location, values

    def entry_values(self, values: dict) -> dict:
        """Return the catalogue entry's parameter values from the fitted ones (default: the same names).

        Parameters
        ----------
        values : dict
            Fitted parameter values by name.

        Returns
        -------
        dict
            The catalogue entry's parameter values by name.
        """
        return dict(values)

    def linearisation_values(self, values: dict, free) -> dict:
        """Return where a joint fit's composite may linearise this member instead of at ``values``.

        The composite is exact (affine, or bilinear in a connector's damping) only where the
        member's model is that same affine function on both sides of its linearisation point;
        a member whose entry switches there (a damping time of zero, a support carried as rigid)
        moves the point (``free``: the names the composite fits; held ones stay). Default: ``values``.

        Parameters
        ----------
        values : dict
            The member's parameter values by name (its start in the composite).
        free : collection of str
            Names of the member's parameters the composite fits.

        Returns
        -------
        dict
            Parameter values by name at which the composite linearises the member.
        """
        return dict(values)

    def fit_values(self, values: dict) -> np.ndarray:
        """Return the fitted parameter vector from entry values (the inverse of :meth:`entry_values`).

        Parameters
        ----------
        values : dict
            Entry values by name (must hold every name in ``names``).

        Returns
        -------
        numpy.ndarray
            Fitted parameter vector, shape (n_params,).
        """
        return np.array([float(values[n]) for n in self.names])

    def gains(self, p, channels) -> np.ndarray | OutputChain | None:
        """Output gain per channel, or an :class:`OutputChain` of acquisition faults (None: all 1).

        Parameters
        ----------
        p : array_like
            Parameter values, shape (n_params,).
        channels : sequence of str
            Names of the simulated channels, in row order.

        Returns
        -------
        numpy.ndarray or OutputChain or None
            Gain per channel (shape (n_channels,)), a chain of acquisition faults, or None for unit gains.
        """
        return None

    @property
    def label(self) -> str:
        """``physics@location``, or ``physics`` for an entry with no location (e.g. the drive linkage)."""
        return self.physics if self.location is None else f"{self.physics}@{self.location}"


class HeldHypothesis(Hypothesis):
    """Hypothesis ``h`` with the parameters ``held`` (index -> value) fixed: only the others are fitted.

    Parameters
    ----------
    h : Hypothesis
        Hypothesis whose parameters are partly held.
    held : dict
        Held parameters: index into ``h.names`` -> fixed value.
    """

    def __init__(self, h: Hypothesis, held: dict):
        keep = np.array([j for j in range(len(h.names)) if j not in held], dtype=int)
        super().__init__(
            h.physics,
            h.location,
            tuple(h.names[j] for j in keep),
            tuple(h.units[j] for j in keep),
            np.asarray(h.lower, dtype=float)[keep],
            np.asarray(h.upper, dtype=float)[keep],
            np.asarray(h.start, dtype=float)[keep],
            component=h.component,
            sensors=h.sensors,
            interface=h.interface,
        )
        self.h, self.keep = h, keep
        self.held = {int(j): float(v) for j, v in held.items()}
        self.base_gains = getattr(h, "base_gains", None)

    def full(self, p) -> np.ndarray:
        """Return ``h``'s full parameter vector at the free parameters ``p``.

        Parameters
        ----------
        p : array_like
            Values of the free (not held) parameters, shape (n_free,).

        Returns
        -------
        numpy.ndarray
            ``h``'s parameter vector, shape (len(h.names),), with the held values filled in.
        """
        x = np.asarray(self.h.start, dtype=float).copy()
        x[self.keep] = np.asarray(p, dtype=float)
        for j, v in self.held.items():
            x[j] = v
        return x

    def system(self, p):
        """Return ``h``'s system with the held parameters at their values.

        Parameters
        ----------
        p : array_like
            Values of the free parameters, shape (n_free,).

        Returns
        -------
        LinearSystem or NonlinearSystem
            ``h``'s system at the full parameter vector.
        """
        return self.h.system(self.full(p))

    def gains(self, p, channels):
        """Return ``h``'s output gains with the held parameters at their values.

        Parameters
        ----------
        p : array_like
            Values of the free parameters, shape (n_free,).
        channels : sequence of str
            Names of the simulated channels, in row order.

        Returns
        -------
        numpy.ndarray or OutputChain or None
            ``h``'s output gains at the full parameter vector.
        """
        return self.h.gains(self.full(p), channels)


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
    """Entry whose parameters enter the unprojected matrices linearly (see module docstring).

    Parameters
    ----------
    physics : str
        Name of the catalogue entry.
    location : str or None
        The entry's location.
    entry : catalogue entry
        The catalogue entry (applied to a model with ``entry.apply(model, location, **values)``).
    build : callable
        Returns a fresh, unassembled model of the current round (called once per linearisation).
    start : dict
        Start value of each fitted parameter by name; the base linearisation is taken there.
    steps : dict
        Step of each fitted parameter by name (in its unit) for the derivative of the matrices.
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ``fixed``, ...).

    Raises
    ------
    RuntimeError
        If the model's coordinates change with a parameter step.
    """

    def __init__(self, physics, location, entry, build: Callable, start: dict, steps: dict, **where):
        super().__init__(physics, location, *_entry_fields(entry, start), **where)
        from exudyn_study.model.linearisation import linearise

        def lin_at(values):
            model = build()
            entry.apply(model, location, **values)
            model.assemble()
            return linearise(model)

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
        """Return the candidate's linear system at parameters ``p``.

        Parameters
        ----------
        p : array_like
            Parameter values, shape (n_params,), in the order of ``names``.

        Returns
        -------
        LinearSystem
            The matrices interpolated at ``p`` and projected with the base linearisation's constraints.
        """
        dp = np.asarray(p, dtype=float) - self.p0
        m, c, k = self.base.full_mass.copy(), self.base.full_damping.copy(), self.base.full_stiffness.copy()
        for i, v in enumerate(dp):
            if v != 0.0:
                m += v * self.d_m[i]
                c += v * self.d_c[i]
                k += v * self.d_k[i]
        return project(m, c, k, self.base)


class SloshingHypothesis(Hypothesis):
    """``sloshing`` in one tank at a fixed slosh frequency, exact in mass, damping ratio and lateral factor.

    With the frequency ``f_s`` fixed, the slosh body's mass, its compensation and its spring
    (``k = m (2 pi f_s)^2``) are linear in the slosh mass, and its dampers (``c = 2 zeta m 2 pi f_s``
    along the tank, ``lateral_damping_factor`` times that across it) are ``c (U_x + factor U_y)``
    with unit dampers ``U_x``, ``U_y``. Four Exudyn builds (the start without damping, twice the
    mass, the damper along, the damper across) give ``M``, ``K`` and ``C`` exactly at any
    parameters. The frequency is a fixed value (``fixed``), not fitted: below the analysed band
    only the water's mass and the damper between tank and water show in the response.

    Parameters
    ----------
    location : str
        The tank (the ``sloshing`` entry's location).
    entry : catalogue entry
        The ``sloshing`` catalogue entry.
    build : callable
        Returns a fresh, unassembled model of the current round (called four times).
    frequency_hz : float
        Fixed slosh frequency ``f_s`` (Hz), carried in ``fixed``.
    start : dict
        Start value of each fitted parameter by name (``slosh_mass_kg``, ``slosh_damping_ratio``,
        ``lateral_damping_factor``).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ``fixed``, ...).

    Raises
    ------
    RuntimeError
        If the model's coordinates change with the parameters.
    """

    #: damping ratio at which the unit dampers are taken (numerical differentiation: a realistic damper)
    UNIT_ZETA = 0.5

    def __init__(self, location, entry, build: Callable, frequency_hz: float, start: dict, **where):
        super().__init__("sloshing", location, *_entry_fields(entry, start), **where)
        from exudyn_study.model.linearisation import linearise

        self.fixed = {"slosh_frequency_hz": float(frequency_hz), **self.fixed}
        self.omega = 2.0 * np.pi * float(frequency_hz)
        self.m0 = float(start["slosh_mass_kg"])

        def lin_at(mass, zeta, factor):
            model = build()
            entry.apply(model, location, slosh_frequency_hz=float(frequency_hz), slosh_mass_kg=mass,
                        slosh_damping_ratio=zeta, lateral_damping_factor=factor)
            model.assemble()
            return linearise(model)

        self.base = lin_at(self.m0, 0.0, 0.0)
        heavier = lin_at(2.0 * self.m0, 0.0, 0.0)
        along = lin_at(self.m0, self.UNIT_ZETA, 0.0)
        across = lin_at(self.m0, self.UNIT_ZETA, 1.0)
        for other in (heavier, along, across):
            if other.full_mass.shape != self.base.full_mass.shape:
                raise RuntimeError("sloshing: the model's coordinates change with the parameters")
        self.d_m = (heavier.full_mass - self.base.full_mass) / self.m0
        self.d_k = (heavier.full_stiffness - self.base.full_stiffness) / self.m0
        self.unit_x, self.unit_y = self.unit_dampers(
            self.base.full_damping, along.full_damping, across.full_damping, self.m0
        )

    def unit_dampers(self, c_none, c_along, c_both, mass: float) -> tuple:
        """Return the unit dampers ``(U_x, U_y)`` of three full damping matrices.

        They are taken without the slosh dampers, with the one along the tank and with both (at
        :attr:`UNIT_ZETA`, lateral factor 0 and 1, slosh mass ``mass``).

        Parameters
        ----------
        c_none : numpy.ndarray
            Full damping matrix without the slosh dampers, shape (n_q, n_q).
        c_along : numpy.ndarray
            Full damping matrix with the damper along the tank (lateral factor 0), shape (n_q, n_q).
        c_both : numpy.ndarray
            Full damping matrix with both dampers (lateral factor 1), shape (n_q, n_q).
        mass : float
            Slosh mass (kg) at which the three matrices are taken.

        Returns
        -------
        tuple of numpy.ndarray
            ``(U_x, U_y)``: the damping matrices per N s/m of the damper along and across the tank.
        """
        c1 = self.damper_n_s_per_m({"slosh_damping_ratio": self.UNIT_ZETA, "slosh_mass_kg": mass})
        return (c_along - c_none) / c1, (c_both - c_along) / c1

    def damper_n_s_per_m(self, values: dict) -> float:
        """Return the slosh damper along the tank, ``2 zeta m 2 pi f_s`` (N s/m), at entry ``values``.

        Parameters
        ----------
        values : dict
            Entry values with ``slosh_damping_ratio`` and ``slosh_mass_kg`` (kg).

        Returns
        -------
        float
            The damper along the tank (N s/m).
        """
        return 2.0 * float(values["slosh_damping_ratio"]) * float(values["slosh_mass_kg"]) * self.omega

    def damping_matrix(self, values: dict, unit_x, unit_y):
        """Return the slosh dampers' full damping matrix at entry ``values``: ``c (U_x + factor U_y)``.

        Parameters
        ----------
        values : dict
            Entry values with ``slosh_damping_ratio``, ``slosh_mass_kg`` (kg) and ``lateral_damping_factor``.
        unit_x, unit_y : numpy.ndarray
            Unit dampers along and across the tank, shape (n_q, n_q) (see :meth:`unit_dampers`).

        Returns
        -------
        numpy.ndarray
            Full damping matrix of the slosh dampers (N s/m), shape (n_q, n_q).
        """
        return self.damper_n_s_per_m(values) * (unit_x + float(values["lateral_damping_factor"]) * unit_y)

    def system(self, p):
        """Return the constrained system at ``p`` (mass kg, damping ratio, lateral damping factor).

        Parameters
        ----------
        p : array_like
            Parameter values in the order of ``names``.

        Returns
        -------
        LinearSystem
            The constrained system with the slosh body at ``p``.
        """
        values = dict(zip(self.names, np.asarray(p, dtype=float), strict=True))
        dm = values["slosh_mass_kg"] - self.m0
        m = self.base.full_mass + dm * self.d_m
        k = self.base.full_stiffness + dm * self.d_k
        c = self.base.full_damping + self.damping_matrix(values, self.unit_x, self.unit_y)
        return project(m, c, k, self.base)


class _PointMatrices:
    """A point candidate pickled without the dense matrices it derives from its displacement map.

    A point candidate's system adds ``P^T P`` (``P`` the point's (3, n_q) displacement map) to the
    nominal matrices; that product, and a resonator's padded matrices, are (n_q, n_q) each and the
    same for every parameter set. A worker receiving the candidate (a screen or a fit on the
    evaluation pool) rebuilds them from ``P`` and the nominal system it receives once for all
    candidates, so a candidate sent costs its (3, n_q) map, not several dense matrices.
    """

    _derived: tuple = ()

    def _derive(self) -> None:
        raise NotImplementedError

    def __getstate__(self):
        state = dict(self.__dict__)
        for name in self._derived:
            state.pop(name, None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._derive()


class AddedMassHypothesis(_PointMatrices, Hypothesis):
    """A rigid point mass at a marker: ``M0 + m P^T P``.

    Parameters
    ----------
    location : str
        Marker the mass is attached to.
    nominal : LinearSystem
        Current model's linearisation.
    displacement_map : numpy.ndarray
        Marker's displacement map ``P`` onto the full coordinates, shape (3, n_q).
    bounds : tuple of float, optional
        Lower and upper bound of the mass (kg); default (0.01, 500).
    start : float, optional
        Start mass (kg); default 1.
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

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
        self.p_map = np.asarray(displacement_map, dtype=float)
        self._derive()

    _derived = ("ptp",)

    def _derive(self) -> None:
        self.ptp = self.p_map.T @ self.p_map

    def system(self, p):
        """Return the candidate's linear system at parameters ``p``.

        Parameters
        ----------
        p : array_like
            ``(mass_kg,)``: the added mass (kg).

        Returns
        -------
        LinearSystem
            The nominal system with the point mass added.
        """
        return project(
            self.nominal.full_mass + float(p[0]) * self.ptp,
            self.nominal.full_damping,
            self.nominal.full_stiffness,
            self.nominal,
        )


class PointResonatorHypothesis(_PointMatrices, Hypothesis):
    """A mass ``m`` on an isotropic spring-damper (``k = m (2 pi f)^2``, ``c = 2 zeta m 2 pi f``) at a point.

    The resonator's three coordinates ``s`` are appended to the nominal ones: ``M = diag(M0, m I)``,
    ``K = K0 + k [P^T P, -P^T; -P, I]`` (``C`` alike), ``P`` the point's displacement map; the null
    space gets an identity block (the resonator is free) and the drive shape ``s = P r`` (statically
    the mass follows the point). Parameters are the ``tuned_mass_damper`` entry's.

    Parameters
    ----------
    location : str
        Point (marker) the resonator is attached to.
    nominal : LinearSystem
        Current model's linearisation.
    displacement_map : numpy.ndarray
        Point's displacement map ``P`` onto the full coordinates, shape (3, n_q).
    start : dict
        Start values by name of the ``tuned_mass_damper`` entry's parameters (mass kg, frequency Hz,
        damping ratio).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

    def __init__(self, location, nominal: LinearSystem, displacement_map: np.ndarray, start: dict, **where):
        from exudyn_study.physics.catalogue import entry

        e = entry("tuned_mass_damper")
        super().__init__("tuned_mass_damper", location, *_entry_fields(e, start), **where)
        self.nominal = nominal
        self.p_map = np.asarray(displacement_map, dtype=float)
        self._derive()

    _derived = ("couple", "mass_block", "base")

    def _derive(self) -> None:
        nominal, p_map = self.nominal, self.p_map
        n_q = nominal.full_mass.shape[0]
        self.couple = np.block([[p_map.T @ p_map, -p_map.T], [-p_map, np.eye(3)]])
        self.mass_block = np.zeros((n_q + 3, n_q + 3))
        self.mass_block[n_q:, n_q:] = np.eye(3)
        null = nominal.nullspace
        grow = np.zeros((null.shape[0] + 3, n_q + 3))
        grow[: null.shape[0], :n_q] = null
        grow[null.shape[0] :, n_q:] = np.eye(3)
        self.base = LinearSystem(
            mass=nominal.mass,
            damping=nominal.damping,
            stiffness=nominal.stiffness,
            nullspace=grow,
            drive_shape=np.concatenate([nominal.drive_shape, p_map @ nominal.drive_shape]),
            b0=nominal.b0,
            b1=nominal.b1,
            b2=nominal.b2,
            sensor_map=np.hstack([nominal.sensor_map, np.zeros((nominal.sensor_map.shape[0], 3))]),
            sensor_names=nominal.sensor_names,
            metadata=nominal.metadata,
            full_mass=np.pad(nominal.full_mass, ((0, 3), (0, 3))),
            full_damping=np.pad(nominal.full_damping, ((0, 3), (0, 3))),
            full_stiffness=np.pad(nominal.full_stiffness, ((0, 3), (0, 3))),
        )

    def system(self, p):
        """Return the system with the resonator at ``p`` = (mass_kg, frequency_hz, damping_ratio).

        Parameters
        ----------
        p : array_like
            ``(mass_kg, frequency_hz, damping_ratio)`` of the resonator (kg, Hz, 1).

        Returns
        -------
        LinearSystem
            The nominal system extended by the resonator's three coordinates.
        """
        m, f, zeta = (float(v) for v in p)
        omega = 2.0 * np.pi * f
        b = self.base
        return project(
            b.full_mass + m * self.mass_block,
            b.full_damping + 2.0 * zeta * m * omega * self.couple,
            b.full_stiffness + m * omega**2 * self.couple,
            b,
        )


class GroundElementHypothesis(_PointMatrices, Hypothesis):
    """A local dynamic stiffness to ground at a point: ``K0 + k P^T P``, ``C0 + c P^T P`` (isotropic).

    The diagnosis's generic local element (physics ``'local_element'``), carried into the model as
    the ``ground_spring_damper`` entry.

    Parameters
    ----------
    location : str
        Point (marker) the element acts at.
    nominal : LinearSystem
        Current model's linearisation.
    displacement_map : numpy.ndarray
        Point's displacement map ``P`` onto the full coordinates, shape (3, n_q).
    start : dict
        Start values by name of the ``ground_spring_damper`` entry's parameters (stiffness N/m,
        damping N s/m).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

    def __init__(self, location, nominal: LinearSystem, displacement_map: np.ndarray, start: dict, **where):
        from exudyn_study.physics.catalogue import entry

        super().__init__(
            "local_element",
            location,
            *_entry_fields(entry("ground_spring_damper"), start),
            may_vanish=("stiffness_n_per_m", "damping_n_s_per_m"),
            **where,
        )
        self.nominal = nominal
        self.p_map = np.asarray(displacement_map, dtype=float)
        self._derive()

    _derived = ("ptp",)

    def _derive(self) -> None:
        self.ptp = self.p_map.T @ self.p_map

    def carried(self, p) -> tuple:
        """Return the ``ground_spring_damper`` entry at this place with the fitted values.

        Parameters
        ----------
        p : array_like
            Fitted ``(stiffness_n_per_m, damping_n_s_per_m)``.

        Returns
        -------
        tuple
            ``('ground_spring_damper', location, values)``.
        """
        values = {n: float(v) for n, v in zip(self.names, p, strict=True)}
        return "ground_spring_damper", self.apply_location or self.location, values

    def system(self, p):
        """Return the nominal system with the spring-damper to ground at ``p`` = (k, c).

        Parameters
        ----------
        p : array_like
            ``(k, c)``: stiffness (N/m) and damping (N s/m) to ground.

        Returns
        -------
        LinearSystem
            The nominal system with the spring-damper to ground.
        """
        k, c = (float(v) for v in p)
        return project(
            self.nominal.full_mass,
            self.nominal.full_damping + c * self.ptp,
            self.nominal.full_stiffness + k * self.ptp,
            self.nominal,
        )


class ModalDampingHypothesis(Hypothesis):
    """The damping of one flexible body's modes scaled by ``factor``.

    Parameters
    ----------
    location : str
        The flexible body whose damping is scaled.
    nominal : LinearSystem
        Current model's linearisation.
    body_indices : numpy.ndarray
        Indices of the body's coordinates in the full coordinates, shape (n_body,).
    bounds : tuple of float, optional
        Lower and upper bound of the factor; default (0.1, 10).
    frequencies_hz : array_like or None, optional
        Free-free frequency of the body mode at each of ``body_indices`` (None: not known; the
        factor cannot then be fitted per band of modes, :class:`ModalDampingBandsHypothesis`).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

    def __init__(
        self,
        location,
        nominal: LinearSystem,
        body_indices: np.ndarray,
        bounds=(0.1, 10.0),
        frequencies_hz=None,
        **where,
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
        self.body_indices = idx
        self.frequencies_hz = None if frequencies_hz is None else np.asarray(frequencies_hz, dtype=float)

    def system(self, p):
        """Return the candidate's linear system at parameters ``p``.

        Parameters
        ----------
        p : array_like
            ``(factor,)``: the body's damping factor (1: nominal).

        Returns
        -------
        LinearSystem
            The nominal system with the body's damping block scaled.
        """
        return project(
            self.nominal.full_mass,
            self.nominal.full_damping + (float(p[0]) - 1.0) * self.c_body,
            self.nominal.full_stiffness,
            self.nominal,
        )


class ModalDampingBandsHypothesis(Hypothesis):
    """The damping of one flexible body's modes scaled by one factor per group of its modes.

    The test of a :class:`ModalDampingHypothesis`: a body-wide change of damping scales the
    groups alike, a local damper (its added damping of each mode goes with the mode's motion
    squared at one place) does not. With all factors equal this is the single-factor hypothesis:
    the body's damping block ``C`` becomes ``S C S`` with ``S = diag(sqrt(factor of each
    coordinate's group))``, which keeps ``C`` positive semi-definite when the modes are coupled.

    Parameters
    ----------
    h : ModalDampingHypothesis
        The single-factor hypothesis (its body, nominal system and coordinates).
    groups : sequence of array_like
        Positions in ``h.body_indices`` of each group's modes (together, every position once).
    bands_hz : sequence of tuple
        ``(lowest, highest)`` free-free frequency of each group's modes (reported with the factors).
    """

    def __init__(self, h: ModalDampingHypothesis, groups, bands_hz):
        n = len(groups)
        start = float(np.atleast_1d(h.start)[0])
        super().__init__(
            "modal_damping_bands",
            h.location,
            tuple(f"factor_{k + 1}" for k in range(n)),
            ("1",) * n,
            np.full(n, float(h.lower[0])),
            np.full(n, float(h.upper[0])),
            np.full(n, start),
            component=h.component,
            sensors=h.sensors,
        )
        self.base_gains = getattr(h, "base_gains", None)
        self.nominal = h.nominal
        self.body_indices = h.body_indices
        self.groups = [np.asarray(g, dtype=int) for g in groups]
        self.bands_hz = [tuple(float(x) for x in b) for b in bands_hz]

    def system(self, p):
        """Return the candidate's linear system at parameters ``p``.

        Parameters
        ----------
        p : array_like
            One factor per group (all 1: nominal).

        Returns
        -------
        LinearSystem
            The nominal system with the body's damping block scaled group by group.
        """
        scale = np.ones(self.body_indices.size)
        for g, f in zip(self.groups, np.atleast_1d(p), strict=True):
            scale[g] = np.sqrt(float(f))
        idx = self.body_indices
        c = np.array(self.nominal.full_damping, dtype=float, copy=True)
        block = c[np.ix_(idx, idx)]
        c[np.ix_(idx, idx)] = scale[:, None] * block * scale[None, :]
        return project(self.nominal.full_mass, c, self.nominal.full_stiffness, self.nominal)


class SensorGainHypothesis(Hypothesis):
    """One channel's true sensitivity differs from the stated one by ``gain``.

    Parameters
    ----------
    channel : str
        The channel whose gain is fitted (the hypothesis's ``location``).
    nominal : LinearSystem
        Current model's linearisation (returned unchanged by :meth:`system`).
    bounds : tuple of float, optional
        Lower and upper bound of the gain; default (0.5, 2).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

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
        """Return the nominal system (a gain changes only the recorded channel).

        Parameters
        ----------
        p : array_like
            ``(gain,)`` (unused: the gain does not change the system).

        Returns
        -------
        LinearSystem
            The nominal system.
        """
        return self.nominal

    def gains(self, p, channels):
        """Return the output gain per channel: ``p[0]`` at the hypothesis's channel, one elsewhere.

        Parameters
        ----------
        p : array_like
            ``(gain,)``: the channel's gain.
        channels : sequence of str
            Names of the simulated channels, in row order (must contain the hypothesis's channel).

        Returns
        -------
        numpy.ndarray
            Gain per channel, shape (n_channels,).
        """
        g = np.ones(len(channels))
        g[list(channels).index(self.location)] = float(p[0])
        return g


@dataclass(frozen=True)
class OutputChain:
    """What the acquisition does to the simulated channels: stages applied in order.

    A stage is an output gain per channel (an array, shape (n_channels,)) or a
    :class:`~exudyn_study.physics.sensor_faults.SensorFault`.

    Parameters
    ----------
    stages : tuple, optional
        Stages applied in order: gain vectors (shape (n_channels,)) or sensor faults (default: none).
    """

    stages: tuple = ()

    @staticmethod
    def of(g) -> OutputChain:
        """Return ``g`` (a gain vector, a chain or None) as a chain.

        Parameters
        ----------
        g : numpy.ndarray or OutputChain or None
            A gain per channel, a chain, or None (no stage).

        Returns
        -------
        OutputChain
            ``g`` itself if it is a chain, else a chain of its one stage (or of none).
        """
        if g is None:
            return OutputChain()
        return g if isinstance(g, OutputChain) else OutputChain((np.asarray(g, dtype=float),))

    def then(self, g) -> OutputChain:
        """Return this chain followed by ``g`` (a gain vector, a chain or None).

        Parameters
        ----------
        g : numpy.ndarray or OutputChain or None
            Stages to append: a gain per channel, a chain, or None (none).

        Returns
        -------
        OutputChain
            A new chain with the stages of ``g`` after this chain's.
        """
        return OutputChain(self.stages + OutputChain.of(g).stages)

    def apply(self, y: np.ndarray, channels, rate_hz: float) -> np.ndarray:
        """Return the channels ``y`` (n_channels, n_samples; rows ``channels``) through the chain.

        Parameters
        ----------
        y : numpy.ndarray
            Simulated channels, shape (n_channels, n_samples).
        channels : sequence of str
            Channel name of each row of ``y``.
        rate_hz : float
            Sample rate (Hz) of ``y``.

        Returns
        -------
        numpy.ndarray
            The channels as recorded, shape (n_channels, n_samples).
        """
        for stage in self.stages:
            y = y * stage[:, None] if isinstance(stage, np.ndarray) else stage.apply(y, channels, rate_hz)
        return y

    def apply_frf(self, h: np.ndarray, channels, freq_hz) -> np.ndarray:
        """Return the FRFs ``h`` (n_channels, n_freq) through the chain's linear stages.

        Parameters
        ----------
        h : numpy.ndarray
            Simulated FRFs, shape (n_channels, n_freq).
        channels : sequence of str
            Channel name of each row of ``h``.
        freq_hz : numpy.ndarray
            Frequencies (Hz) of the columns of ``h``, shape (n_freq,).

        Returns
        -------
        numpy.ndarray
            The FRFs as recorded, shape (n_channels, n_freq).
        """
        for stage in self.stages:
            h = h * stage[:, None] if isinstance(stage, np.ndarray) else stage.apply_frf(h, channels, freq_hz)
        return h


def apply_output(y: np.ndarray, gains, channels, rate_hz: float) -> np.ndarray:
    """Return the simulated channels ``y`` (n_channels, n_samples) with output ``gains`` (vector or chain).

    Parameters
    ----------
    y : numpy.ndarray
        Simulated channels, shape (n_channels, n_samples).
    gains : numpy.ndarray or OutputChain or None
        Gain per channel (shape (n_channels,)), a chain of acquisition stages, or None (unchanged).
    channels : sequence of str
        Channel name of each row of ``y``.
    rate_hz : float
        Sample rate (Hz) of ``y``.

    Returns
    -------
    numpy.ndarray
        The channels as recorded, shape (n_channels, n_samples).
    """
    if gains is None:
        return y
    if isinstance(gains, OutputChain):
        return gains.apply(y, channels, rate_hz)
    return y * gains[:, None]


def apply_output_frf(h: np.ndarray, gains, channels, freq_hz) -> np.ndarray:
    """Return the FRFs ``h`` (n_channels, n_freq) with output ``gains`` (vector or chain).

    Parameters
    ----------
    h : numpy.ndarray
        Simulated FRFs, shape (n_channels, n_freq).
    gains : numpy.ndarray or OutputChain or None
        Gain per channel (shape (n_channels,)), a chain of acquisition stages, or None (unchanged).
    channels : sequence of str
        Channel name of each row of ``h``.
    freq_hz : numpy.ndarray
        Frequencies (Hz) of the columns of ``h``, shape (n_freq,).

    Returns
    -------
    numpy.ndarray
        The FRFs as recorded, shape (n_channels, n_freq).
    """
    if gains is None:
        return h
    if isinstance(gains, OutputChain):
        return gains.apply_frf(h, channels, freq_hz)
    return h * gains[:, None]


class SensorFaultHypothesis(Hypothesis):
    """An acquisition fault of catalogue entry ``physics`` (``sensor_polarity``, ``sensor_swap``, ...).

    ``location`` is the entry's: a channel, ``'A/B'`` (swap) or ``'A>B'`` (wrong axis). The system
    is ``nominal``; the fault acts on the simulated channels (:meth:`gains`).

    Parameters
    ----------
    physics : str
        Catalogue entry of the fault (``sensor_polarity``, ``sensor_swap``, ...).
    location : str
        The entry's location: a channel, ``'A/B'`` (swap) or ``'A>B'`` (wrong axis).
    nominal : LinearSystem
        Current model's linearisation (returned unchanged by :meth:`system`).
    start : dict or None, optional
        Start values by parameter name (None or missing names: the entry's defaults).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

    def __init__(
        self, physics: str, location: str, nominal: LinearSystem, start: dict | None = None, **where
    ):
        from exudyn_study.physics.catalogue import entry
        from exudyn_study.physics.sensor_faults import FAULT_KINDS

        kinds = {v: k for k, v in FAULT_KINDS.items()}
        e = entry(physics)
        params = e.parameters
        start = start or {}
        super().__init__(
            physics,
            location,
            tuple(p.name for p in params),
            tuple(p.unit for p in params),
            np.array([p.lower for p in params], dtype=float),
            np.array([p.upper for p in params], dtype=float),
            np.array([float(start.get(p.name, p.default)) for p in params], dtype=float),
            carry="gains",
            **where,
        )
        self.kind = kinds[physics]
        sep = "/" if self.kind == "swap" else ">" if self.kind == "axis" else None
        self.channel, self.other = location.split(sep) if sep else (location, None)
        self.nominal = nominal

    def system(self, p):
        """Return the nominal system (a fault changes only the recorded channels).

        Parameters
        ----------
        p : array_like
            The fault's parameter values (unused: a fault does not change the system).

        Returns
        -------
        LinearSystem
            The nominal system.
        """
        return self.nominal

    def gains(self, p, channels):
        """Return the fault at ``p`` as an :class:`OutputChain`.

        Parameters
        ----------
        p : array_like
            The fault's parameter values (its first one is the fault's value; none: 1).
        channels : sequence of str
            Names of the simulated channels, in row order (unused here: the fault names its channels).

        Returns
        -------
        OutputChain
            A chain of the one sensor fault.
        """
        from exudyn_study.physics.sensor_faults import SensorFault

        value = float(p[0]) if len(self.names) else 1.0
        return OutputChain((SensorFault(self.kind, self.channel, self.other, value),))


def log_bounds(h: Hypothesis):
    """Return bounds in the fitting variable: log for non-negative parameters, linear otherwise.

    A zero lower bound becomes ``upper * 1e-6``.
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
    """A linearised system plus local residual force elements (simulated in time, not by FRF).

    Parameters
    ----------
    lin : LinearSystem
        Linearisation (the linear tangent) of the model.
    gather : numpy.ndarray
        Gather vectors of the local elements onto the full coordinates.
    laws : list
        Force law of each local element, in the order of ``gather``.
    substeps : int, optional
        Integration substeps per sample of the time simulation (default 4).
    """

    lin: LinearSystem
    gather: np.ndarray
    laws: list
    substeps: int = 4


def model_system(model):
    """Return the assembled ``model`` as the diagnosis simulates it.

    Its linearisation, plus its local nonlinear elements (:class:`NonlinearSystem`) if it has any.
    """
    from exudyn_study.linear.nonlinear import gather_vectors
    from exudyn_study.model.linearisation import linearise

    if not model.assembled:
        model.assemble()
    lin = linearise(model)
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
        from exudyn_study.model.linearisation import linearise

        self.model = model
        self.base = linearise(model)

    def derivative(self, item: int, name: str, base_value, changed_value, scale: float):
        """(dM, dC, dK) of setting parameter ``name`` of ``item`` from base to changed, per ``scale``."""
        from exudyn_study.model.linearisation import linearise

        mbs = self.model.mbs
        mbs.SetObjectParameter(item, name, changed_value)
        try:
            other = linearise(self.model)
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


def joint_basis(model) -> dict:
    """Stiffness basis of ``joint_stiffness``: translational and rotational diagonal (per unit value)."""
    return {
        "stiffness_n_per_m": np.diag([1.0] * 3 + [0.0] * 3),
        "rotational_stiffness_n_m_per_rad": np.diag([0.0] * 3 + [1.0] * 3),
    }


class ConnectorHypothesis(Hypothesis):
    """An entry that adds one spring-damper (joint, pad: 6-DOF; rear support: Cartesian), one build.

    The spring's stiffness (a 6x6 matrix or a Cartesian spring's 3-vector) is ``sum_i p_i B_i`` over the
    stiffness parameters (``basis(model)`` -> {name: B_i}, default :func:`joint_basis`) and its damping
    ``t`` times it (``damping`` names ``t``, a damping time; a negative ``p_i`` adds none). The
    fitted parameters may differ from the entry's (``fields``: names, units, bounds, start, with
    :meth:`~Hypothesis.entry_values` mapping them), as long as the spring is linear in them. The
    entry is applied at ``start`` with no damping; the derivatives of the matrices by each ``p_i``
    and by damping ``B_i`` are taken on the same assembled model (:class:`_Relinearised`):
    ``K0 + sum (p_i - p_i0) dK_i`` and ``C0 + t sum p_i dC_i``, exact (``C`` is bilinear in ``p``
    and ``t``, which a purely affine interpolation is not).

    Parameters
    ----------
    physics : str
        Name of the catalogue entry.
    location : str
        The entry's location (a joint, pad or support).
    entry : catalogue entry
        The catalogue entry; ``entry.apply`` returns the applied items, among them ``'spring'``.
    build : callable
        Returns a fresh, unassembled model of the current round (called once).
    start : dict
        Start value of each parameter by name.
    basis : callable, optional
        ``basis(model) -> {name: B_i}``: stiffness per unit value of each stiffness parameter (a 6x6
        matrix or a 3-vector); default :func:`joint_basis`.
    damping : str, optional
        Name of the damping-time parameter (s); default ``'damping_time_s'``.
    fields : tuple or None, optional
        ``(names, units, lower, upper, start)`` of the fitted parameters when they differ from the
        entry's (None: the entry's parameters named in ``start``).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ...).
    """

    def __init__(
        self,
        physics,
        location,
        entry,
        build: Callable,
        start: dict,
        basis=joint_basis,
        damping: str = "damping_time_s",
        fields: tuple | None = None,
        **where,
    ):
        super().__init__(physics, location, *(fields or _entry_fields(entry, start)), **where)
        model = build()
        applied = entry.apply(model, location, **self.entry_values({**start, damping: 0.0}))
        model.assemble()
        rl = _Relinearised(model)
        spring = int(applied.items["spring"])
        unit = basis(model)
        self.stiff_names = tuple(unit)
        self.damping_index = self.names.index(damping)
        p0 = np.array([float(start[n]) for n in self.stiff_names])
        k_start = sum(v * unit[n] for n, v in zip(self.stiff_names, p0, strict=True))
        zero = np.zeros_like(k_start).tolist()  # a 6x6 matrix (joint) or a 3-vector (Cartesian spring)
        self.base = rl.base
        self.p0 = p0
        self.d_k, self.d_c = [], []
        for n, v in zip(self.stiff_names, p0, strict=True):
            step = v if v > 0 else 1.0
            self.d_k.append(
                rl.derivative(
                    spring, "stiffness", k_start.tolist(), (k_start + step * unit[n]).tolist(), step
                )[2]
            )
            # damping at that of a 1 ms damping time (the linearisation differentiates
            # numerically: a unit damping would drown in its noise)
            c = 1e-3 * step
            self.d_c.append(rl.derivative(spring, "damping", zero, (c * unit[n]).tolist(), c)[1])
        self.stiff_index = [self.names.index(n) for n in self.stiff_names]

    #: damping time (s) at which a joint fit's composite linearises a member whose damping time it fits:
    #: its damping ``t sum_i k_i D_i`` is bilinear, which the composite takes exactly from a positive
    #: damping time only (at zero the stiffness steps carry no damping; from 1e-8 s on it was exact to
    #: 1e-12 on the mini Model 3, so any positive value serves)
    LINEARISATION_DAMPING_TIME_S = 1e-3

    def linearisation_values(self, values: dict, free) -> dict:
        """Return ``values`` with a fitted damping time at :attr:`LINEARISATION_DAMPING_TIME_S`.

        Parameters
        ----------
        values : dict
            The member's parameter values by name.
        free : collection of str
            Names of the member's parameters the composite fits.

        Returns
        -------
        dict
            ``values`` with the damping time at :attr:`LINEARISATION_DAMPING_TIME_S` (s) if it is free.
        """
        out = dict(values)
        name = self.names[self.damping_index]
        if name in free:
            out[name] = self.LINEARISATION_DAMPING_TIME_S
        return out

    def system(self, p):
        """Return the constrained system at ``p`` (stiffness parameters and damping time).

        Parameters
        ----------
        p : array_like
            Parameter values in the order of ``names`` (stiffnesses and damping time in s).

        Returns
        -------
        LinearSystem
            The constrained system with the connector at ``p``.
        """
        p = np.asarray(p, dtype=float)
        ks, t = p[self.stiff_index], float(p[self.damping_index])
        k = self.base.full_stiffness.copy()
        c = self.base.full_damping.copy()
        for v, v0, d_k, d_c in zip(ks, self.p0, self.d_k, self.d_c, strict=True):
            k += (v - v0) * d_k
            c += t * max(v, 0.0) * d_c  # a negative stiffness change takes no damping off
        return project(self.base.full_mass, c, k, self.base)


class LocalElementHypothesis(Hypothesis):
    """A catalogue entry that adds local nonlinear elements (``bushing_stiffening``, ``joint_friction``).

    The entry is applied once to the current model (which may carry earlier nonlinear
    findings: their elements keep their fitted laws); the fitted parameters change the new
    elements' force laws, built by ``make_laws(p, elements)``. If the entry also adds a
    linear tangent that depends on a parameter (``joint_friction``'s stuck spring),
    ``tangent=(item label, Exudyn parameter, value(p))`` names the connector item and its
    parameter as a function of ``p``; the tangent is linear in it (:class:`_Relinearised`).

    Parameters
    ----------
    physics : str
        Name of the catalogue entry (``bushing_stiffening``, ``joint_friction``, ...).
    location : str
        The entry's location.
    entry : catalogue entry
        The catalogue entry that adds the local nonlinear elements.
    build : callable
        Returns a fresh, unassembled model of the current round (called once).
    start : dict
        Start value of each fitted parameter by name.
    make_laws : callable
        ``make_laws(p, elements)``: the new elements' force laws at parameters ``p``.
    tangent : tuple or None, optional
        ``(item label, Exudyn parameter, value(p))`` of a linear tangent that depends on a parameter
        (None: the tangent is fixed).
    substeps : int, optional
        Integration substeps per sample of the time simulation (default 4).
    **where
        Further :class:`Hypothesis` fields (``component``, ``sensors``, ``fixed``, ...).
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
        from exudyn_study.linear.nonlinear import gather_vectors

        model = build()
        n_old = len(model.local_nonlinearities)
        applied = entry.apply(model, location, **start, **self.fixed)
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
        """Return the linear tangent system with the element laws at ``p``.

        Parameters
        ----------
        p : array_like
            Parameter values in the order of ``names``.

        Returns
        -------
        NonlinearSystem
            The linear tangent and the local elements' laws at ``p``.
        """
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


class CompositeHypothesis(Hypothesis):
    """Several linear candidates fitted together.

    For effects that interact: a compliant drive linkage and compliant tank mounts shift each
    other's modes, so neither explains much alone. All members' catalogue entries are applied
    to one model at their start values; each free parameter's derivative of the unprojected
    matrices is taken by one more build with that parameter stepped (the entries are affine
    in their free parameters, the others held; a connector's damping ``t diag(k)`` is
    bilinear in its damping time and stiffnesses and taken exactly, see :meth:`system`).
    ``free`` names each member's fitted parameters (default all). The model is linearised at the
    starts except where a member's entry switches (:meth:`Hypothesis.linearisation_values`: a fitted
    damping time of zero, a rear support carried as rigid), so the composite is the same wherever
    it is built.

    Parameters
    ----------
    members : iterable of Hypothesis
        The linear candidates fitted together.
    build : callable
        Returns a fresh, unassembled model of the current round (called once per free parameter and more).
    free : dict or None, optional
        Member index -> names of its fitted parameters (None or a missing index: all of them).

    Raises
    ------
    RuntimeError
        If the model's coordinates change with a parameter step.
    """

    def __init__(self, members, build: Callable, free: dict | None = None):
        from exudyn_study.physics.catalogue import entry as catalogue_entry

        self.members = list(members)
        specs = []  # (member index, parameter name)
        for i, h in enumerate(self.members):
            names = (free or {}).get(i, h.names)
            specs += [(i, n) for n in names]
        self.specs = specs
        starts = [dict(zip(h.names, (float(v) for v in h.start), strict=True)) for h in self.members]
        lower = np.array([self.members[i].lower[self.members[i].names.index(n)] for i, n in specs])
        upper = np.array([self.members[i].upper[self.members[i].names.index(n)] for i, n in specs])
        start = np.array([starts[i][n] for i, n in specs])
        super().__init__(
            "+".join(h.physics for h in self.members),
            ",".join(str(h.location) for h in self.members),
            tuple(f"{self.members[i].label}:{n}" for i, n in specs),
            tuple(self.members[i].units[self.members[i].names.index(n)] for i, n in specs),
            lower,
            upper,
            np.clip(start, lower, upper),
        )
        self.starts = starts
        # where the model is linearised: the starts, moved where a member's entry switches (its
        # linearisation_values); the held parameters stay, so member_values(p0) are these
        at = [
            h.linearisation_values(s, {n for j, n in specs if j == i})
            for i, (h, s) in enumerate(zip(self.members, starts, strict=True))
        ]
        lin_point = np.array([at[i][n] for i, n in specs])
        from exudyn_study.model.linearisation import linearise

        def lin_at(values_per_member):
            model = build()
            for h, values in zip(self.members, values_per_member, strict=True):
                name, loc, carried = h.carried([values[n] for n in h.names])
                catalogue_entry(name).apply(model, loc, **carried)
            model.assemble()
            return linearise(model)

        self.base = lin_at(at)
        self.p0 = lin_point  # where ``base`` is linearised (``start`` is where a fit starts)
        self.d = []
        for (i, n), v0, hi in zip(specs, lin_point, upper, strict=True):
            step = 0.5 * v0 if v0 > 0 else 1e-3 * hi
            if v0 + step > hi:  # stay inside the entry's bounds (it checks them)
                step = -step
            values = [dict(s) for s in at]
            values[i][n] = v0 + step
            other = lin_at(values)
            if other.full_mass.shape != self.base.full_mass.shape:
                raise RuntimeError(f"{self.members[i].label}: the model's coordinates change with {n}")
            self.d.append(
                tuple(
                    (b - a) / step
                    for a, b in (
                        (self.base.full_mass, other.full_mass),
                        (self.base.full_damping, other.full_damping),
                        (self.base.full_stiffness, other.full_stiffness),
                    )
                )
            )

        # sloshing members: their dampers 2 zeta m omega (U_x + factor U_y) are trilinear in their parameters,
        # so the affine derivatives of C are replaced by the exact term (unit dampers in this model's
        # coordinates: three more builds per member)
        self.slosh = []
        for i, h in enumerate(self.members):
            if not isinstance(h, SloshingHypothesis):
                continue
            dampings = []
            for zeta, factor in ((0.0, 0.0), (h.UNIT_ZETA, 0.0), (h.UNIT_ZETA, 1.0)):
                values = [dict(s) for s in at]
                values[i].update(slosh_damping_ratio=zeta, lateral_damping_factor=factor)
                dampings.append(lin_at(values).full_damping)
            self.slosh.append((i, h, *h.unit_dampers(*dampings, at[i]["slosh_mass_kg"])))
            for j, (owner, _) in enumerate(specs):
                if owner == i:
                    d_m, _, d_k = self.d[j]
                    self.d[j] = (d_m, np.zeros_like(d_m), d_k)

        # members whose damping is their stiffness times a free damping time (ConnectorHypothesis):
        # spec of the time -> specs of their stiffnesses (C is bilinear there, see system; the time is
        # linearised at a positive value, ConnectorHypothesis.linearisation_values)
        self.bilinear = {}
        for i, h in enumerate(self.members):
            if isinstance(h, ConnectorHypothesis) and (i, h.names[h.damping_index]) in specs:
                j_t = specs.index((i, h.names[h.damping_index]))
                self.bilinear[j_t] = [specs.index((i, n)) for n in h.stiff_names if (i, n) in specs]

    def system(self, p):
        """Return the constrained system with every member at its part of ``p``.

        Affine in every parameter, except a connector member's damping with a free damping time
        ``t``: ``C = t sum_i k_i D_i`` is bilinear, so its change is taken exactly as
        ``(t - t0) dC/dt + (t / t0) sum_i (k_i - k_i0) dC/dk_i`` (``dC/dk_i = t0 D_i`` at the start).

        Parameters
        ----------
        p : array_like
            Composite parameter values, in the order of ``names``.

        Returns
        -------
        LinearSystem
            The constrained system with every member at its part of ``p``.
        """
        p = np.asarray(p, dtype=float)
        dp = p - self.p0
        c_scale = np.ones(p.size)
        for j_t, stiff in self.bilinear.items():
            c_scale[stiff] = p[j_t] / self.p0[j_t]
        m, c, k = self.base.full_mass.copy(), self.base.full_damping.copy(), self.base.full_stiffness.copy()
        for v, s_c, (d_m, d_c, d_k) in zip(dp, c_scale, self.d, strict=True):
            if v != 0.0:
                m += v * d_m
                c += s_c * v * d_c
                k += v * d_k
        if self.slosh:
            now, then = self.member_values(p), self.member_values(self.p0)
            for i, h, unit_x, unit_y in self.slosh:
                for sign, values in ((1.0, now[i]), (-1.0, then[i])):
                    c += sign * h.damping_matrix(dict(zip(h.names, values, strict=True)), unit_x, unit_y)
        return project(m, c, k, self.base)

    def member_values(self, p) -> list:
        """Each member's full parameter vector at composite parameters ``p`` (held ones at their start).

        Parameters
        ----------
        p : array_like
            Composite parameter values, in the order of ``names``.

        Returns
        -------
        list of numpy.ndarray
            Each member's parameter vector, in the order of its ``names``.
        """
        values = [dict(s) for s in self.starts]
        for (i, n), v in zip(self.specs, p, strict=True):
            values[i][n] = float(v)
        return [np.array([values[i][n] for n in h.names]) for i, h in enumerate(self.members)]
