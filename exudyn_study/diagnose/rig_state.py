"""The data the stages of the rig diagnosis pass to each other (frozen dataclasses).

- :class:`RigProblem`: what does not change during a diagnosis (recordings, evaluators, settings);
- :class:`ModelState`: the current model (nominal plus the findings carried into it);
- :class:`Comparison`: the current model against the recordings (compare; defined in
  :mod:`~exudyn_study.diagnose.rig_compare`);
- :class:`Location`: where and in which band the mismatch is (locate);
- :class:`Screening`: this round's candidates and their scores (screen);
- :class:`RoundFits`: the fits of one round (fit);
- :class:`Proof`: a round's findings on the held-out recordings (prove);
- :class:`Progress`: the findings so far.

Package-internal API of :mod:`exudyn_study.diagnose`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.diagnose.rig_compare import Comparison
from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

__all__ = [
    "RigProblem",
    "ModelState",
    "Comparison",
    "Location",
    "Screening",
    "RoundFits",
    "Proof",
    "Progress",
    "build_with_findings",
    "assembled_state",
    "model_state",
    "carry",
]


@dataclass(frozen=True)
class RigProblem:
    """What one diagnosis works on: the nominal model's builder, the recordings and their evaluators.

    Attributes
    ----------
    variant : int
        Model variant (1-3).
    build : callable
        ``build() -> Model``: a fresh nominal model (not assembled).
    settings : RigDiagnosisSettings
    say : callable
        Progress text.
    t_start : float
        ``time.perf_counter()`` at the start of the diagnosis (s).
    train, holdout : tuple of (str, Recording)
        The named training and held-out recordings as given.
    sensor_names : tuple of str
        The model's sensors (simulation output order).
    channels : tuple of str
        The recordings' response channels (residual order).
    train_recs, hold_recs : list of RigRecording
        Prepared training and held-out recordings.
    ev_train, ev_train_nonlinear, ev_hold, ev_hold_fast, ev_screen, ev_spectral
        Evaluators (:mod:`~exudyn_study.diagnose.rig_evaluate`): exact on the training records, exact on
        the shorter records of nonlinear fits, exact and by convolution on the held-out records, by
        convolution on the screening record, on log transmissibilities.
    ev_distortion, ev_distortion_hold : DistortionEvaluator or None
        The level-dependent share of one drive at two training levels, and at a weaker training and a
        stronger held-out level (None without such a pair).
    p_cell : float
        Significance level per recording.
    distortion : tuple or None
        The model-free nonlinear share per channel and its stronger recording
        (:func:`~exudyn_study.diagnose.rig_locate.distortion_shares`).
    wanted : frozenset of str or None
        Catalogue entries to consider (None: all registered).
    damage_cache : dict
        Pseudo damages counted so far (:func:`~exudyn_study.diagnose.rig_prove.channel_damage`).
    pool : EvaluationPool or None
        Workers for the fits' finite differences (:mod:`~exudyn_study.diagnose.rig_pool`; None: the
        diagnosis's own process).
    """

    variant: int
    build: Callable
    settings: RigDiagnosisSettings
    say: Callable
    t_start: float
    train: tuple
    holdout: tuple
    sensor_names: tuple
    channels: tuple
    train_recs: list
    hold_recs: list
    ev_train: object
    ev_train_nonlinear: object
    ev_hold: object
    ev_hold_fast: object
    ev_screen: object
    ev_spectral: object
    ev_distortion: object
    ev_distortion_hold: object
    p_cell: float
    distortion: tuple | None
    wanted: frozenset | None
    damage_cache: dict = field(default_factory=dict, compare=False, repr=False)
    pool: object = field(default=None, compare=False, repr=False)

    @property
    def evaluators(self) -> tuple:
        """The evaluators whose simulations carry the current model's nonlinear correction."""
        return (self.ev_train, self.ev_train_nonlinear, self.ev_hold, self.ev_screen, self.ev_hold_fast)

    def wants(self, physics: str) -> bool:
        """Whether catalogue entry ``physics`` is to be considered.

        Parameters
        ----------
        physics : str
            Name of the catalogue entry.

        Returns
        -------
        bool
            True if the entry is in the catalogue and wanted (or nothing is singled out).
        """
        from exudyn_study.physics.catalogue import CATALOGUE

        return (self.wanted is None or physics in self.wanted) and physics in CATALOGUE


def build_with_findings(build: Callable, accepted: tuple):
    """Return ``build()`` with the catalogue entries ``accepted`` ((name, location, values), ...) applied.

    Parameters
    ----------
    build : callable
        ``build() -> Model``: a fresh nominal model (not assembled).
    accepted : tuple of tuple
        Catalogue entries to apply, in order: ``(entry name, location, parameter values)``.

    Returns
    -------
    Model
        The model with the entries applied (not assembled).
    """
    from exudyn_study.physics.catalogue import entry

    model = build()
    for name, loc, values in accepted:
        entry(name).apply(model, loc, **values)
    return model


@dataclass(frozen=True)
class ModelState:
    """The current model: the nominal one with the findings carried into it.

    Attributes
    ----------
    accepted : tuple of (str, str, dict)
        Catalogue entries applied to the model, in order: (entry name, location, parameters).
    model : exudyn_study.model.Model
        The assembled model.
    locations : tuple of str
        Point locations (sensors, then frame interfaces).
    markers : dict
        location -> (Exudyn marker, global position).
    system : LinearSystem or NonlinearSystem
        Its linearisation (with its local nonlinear elements, if any).
    gains : numpy.ndarray or OutputChain
        Output gain per channel (sensor findings), shape (n_channels,), or the chain of the
        acquisition faults found (:class:`~exudyn_study.diagnose.rig_hypotheses.OutputChain`).
    """

    accepted: tuple
    model: object
    locations: tuple
    markers: dict
    system: object
    gains: np.ndarray

    @property
    def lin(self):
        """The linear system (the linear tangent of a nonlinear one)."""
        return getattr(self.system, "lin", self.system)

    def builder(self, problem: RigProblem) -> Callable:
        """``build() -> Model``: a fresh, not assembled copy of this model.

        Parameters
        ----------
        problem : RigProblem
            The diagnosis (its nominal ``build``).

        Returns
        -------
        callable
            ``build() -> Model`` with this state's findings applied.
        """
        return functools.partial(build_with_findings, problem.build, tuple(self.accepted))


def assembled_state(build: Callable, accepted: tuple, gains: np.ndarray) -> ModelState:
    """Build ``build()`` with the findings ``accepted``, assemble it and linearise it.

    Parameters
    ----------
    build : callable
        ``build() -> Model``: a fresh nominal model (not assembled).
    accepted : tuple of tuple
        Catalogue entries to apply, in order: ``(entry name, location, parameter values)``.
    gains : numpy.ndarray or OutputChain or None
        Output gain per channel, or the chain of acquisition faults found (None: all one).

    Returns
    -------
    ModelState
        The assembled model, its point locations and markers, and its system.
    """
    from exudyn_study.diagnose.rig_hypotheses import model_system
    from exudyn_study.physics.entries import location_point

    model = build_with_findings(build, tuple(accepted))
    sensor_names = tuple(model.sensors)
    interfaces = sorted(k for k in model.interfaces if not k.startswith("rear_foundation"))
    locations = list(sensor_names) + interfaces
    markers = {loc: location_point(model, loc) for loc in locations}
    model.assemble()
    return ModelState(tuple(accepted), model, tuple(locations), markers, model_system(model), gains)


def model_state(problem: RigProblem, accepted: tuple, gains: np.ndarray) -> ModelState:
    """Return the model with the findings ``accepted``; the evaluators get its nonlinear correction.

    Parameters
    ----------
    problem : RigProblem
        The diagnosis (its nominal ``build`` and its evaluators).
    accepted : tuple of tuple
        Catalogue entries to apply, in order: ``(entry name, location, parameter values)``.
    gains : numpy.ndarray or OutputChain or None
        Output gain per channel, or the chain of acquisition faults found (None: all one).

    Returns
    -------
    ModelState
        The current model.
    """
    from exudyn_study.diagnose.rig_evaluate import set_offsets

    state = assembled_state(problem.build, accepted, gains)
    set_offsets(problem.evaluators, state.system)
    return state


def carry(problem: RigProblem, before: ModelState, members) -> ModelState:
    """Return the model of ``before`` with the fits ``members`` carried into it (gains or catalogue entries).

    A sensor finding (``carry == 'gains'``) changes the output gains (its gains include those
    before it); any other is applied as a catalogue entry and the model rebuilt. Without new
    entries the system of ``before`` is kept.

    Parameters
    ----------
    problem : RigProblem
        The diagnosis (builder, channels, evaluators).
    before : ModelState
        The model before the fits.
    members : iterable of dict
        Fit records (``h``: the hypothesis, ``p``: its values) to carry.

    Returns
    -------
    ModelState
        The model with the fits carried into it.
    """
    from dataclasses import replace

    from exudyn_study.diagnose.rig_evaluate import combined_gains, set_offsets

    gains, accepted = before.gains, list(before.accepted)
    for f in members:
        if f["h"].carry == "gains":
            gains = combined_gains(f["h"], f["p"], problem.channels)
        else:
            accepted.append(f["h"].carried(f["p"]))
    if len(accepted) > len(before.accepted):
        return model_state(problem, tuple(accepted), gains)
    set_offsets(problem.evaluators, before.system)
    return replace(before, gains=gains)


@dataclass(frozen=True)
class Location:
    """Where the mismatch is.

    Attributes
    ----------
    located : tuple of str
        Sensors with significant mismatch, strongest first.
    band_hz : tuple of float
        The band of the significant cells (Hz).
    level_dependent : bool
        Whether the mismatch grows with the drive level.
    nonlinear_sensors : tuple of str
        Located sensors with a local level-dependent share, strongest first.
    """

    located: tuple
    band_hz: tuple
    level_dependent: bool
    nonlinear_sensors: tuple


@dataclass(frozen=True)
class Screening:
    """One round's candidates and their screening scores.

    Attributes
    ----------
    ctx : CandidateContext
        What the factories got.
    hyps : tuple of Hypothesis
        The screened candidates (their ``start`` is the screening optimum).
    scores : tuple of float
        Share of the residual each explains at its screening optimum.
    order : tuple of int
        Indices into ``hyps`` worth fitting, best first.
    deferred : tuple of RigCandidate
        Simulated candidates judged on the level-dependent share if no linear one fits.
    spectral : bool
        Whether this round fits on log transmissibilities.
    ev_fit : evaluator
        The evaluator the round fits on.
    rss0, rss0_time : float
        The current model's residual on ``ev_fit`` and on the training time histories.
    ev_time : evaluator
        The exact evaluator of the training time histories.
    walks : dict
        The round's place refinements (:func:`~exudyn_study.diagnose.rig_refine.refine_places`): where
        a walk through a node ended, by ``(kind, place)``, so that walks meeting there fit once.
    """

    ctx: object
    hyps: tuple
    scores: tuple
    order: tuple
    deferred: tuple
    spectral: bool
    ev_fit: object
    rss0: float
    rss0_time: float
    ev_time: object = None
    walks: dict = field(default_factory=dict, compare=False, repr=False)

    def judged_on(self, h) -> tuple:
        """Return ``(evaluator, rss0, spectral)`` that hypothesis ``h`` is fitted and judged on.

        An acquisition fault (``carry == 'gains'``) changes only the recorded channels, not where
        the resonances are, and a polarity or a delay is invisible in log magnitudes: it is judged
        on the time histories even in a spectral round.

        Parameters
        ----------
        h : Hypothesis
            The hypothesis (its ``carry``).
        """
        if self.spectral and h.carry == "gains":
            return self.ev_time, self.rss0_time, False
        return self.ev_fit, self.rss0, self.spectral


@dataclass(frozen=True)
class RoundFits:
    """The fits of one round.

    Attributes
    ----------
    fitted : tuple of dict
        Every fit record (hypothesis ``h``, values ``p``, ``std``, ``rss``, ``aic``, ``rejected``, ...).
    ok : tuple of dict
        The acceptable ones.
    together : bool
        Whether ``ok`` are the members of one joint fit.
    nonlinear_s : float or None
        Wall time of the nonlinear candidates' screening and fits (s).
    """

    fitted: tuple
    ok: tuple
    together: bool = False
    nonlinear_s: float | None = None


@dataclass(frozen=True)
class Proof:
    """A round's findings judged on the held-out recordings.

    Attributes
    ----------
    fit : dict
        The finding's ``fit`` block of the JSON (training and held-out errors before and after, per
        channel, relative pseudo damage).
    accepted : bool
        Whether the findings are accepted.
    reason : str
        Why not (empty when accepted).
    """

    fit: dict
    accepted: bool
    reason: str = ""


@dataclass(frozen=True)
class Progress:
    """The findings so far.

    Attributes
    ----------
    findings : tuple of Finding
    records : tuple of dict
        Per finding: its hypothesis ``h``, ``finding`` (index), ``accepted`` (index into
        :attr:`ModelState.accepted`; None for a sensor finding), ``lin_before``/``lin_after``, ``located``,
        ``at_bound`` and ``flags`` (the round's doubts, kept through the final refit).
    refitted : tuple of str or None
        Labels of the linear findings last refitted together.
    """

    findings: tuple = ()
    records: tuple = ()
    refitted: tuple | None = None

    def done(self, state: ModelState) -> set:
        """(physics, location) of the findings made: not offered again.

        Parameters
        ----------
        state : ModelState
            The current model (its carried catalogue entries).

        Returns
        -------
        set of tuple
            ``(physics, location)`` pairs; a sensor finding under each way its location is written.
        """
        done = {(name, loc) for name, loc, _ in state.accepted}
        for f in self.findings:
            if f.physics.startswith("sensor_"):  # carried as output gains: named by their channels
                sensors = f.location["sensors"]
                done |= {(f.physics, sensors[0]), (f.physics, "/".join(sensors))}
                done.add((f.physics, ">".join(sensors)))
        return done
