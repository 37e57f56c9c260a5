"""Settings of the rig diagnosis (:func:`exudyn_study.diagnose.rig.diagnose_rig`).

One frozen dataclass; a variant is made with :func:`dataclasses.replace`::

    st = dataclasses.replace(RigDiagnosisSettings(), train_duration_s=12.0, max_findings=1)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from exudyn_study.errors import InputError

__all__ = ["RigDiagnosisSettings"]


@dataclass(frozen=True)
class RigDiagnosisSettings:
    """Knobs of the rig diagnosis (the defaults are what the benchmarks use).

    Attributes
    ----------
    train_duration_s : float
        Training seconds per recording used for fitting (s).
    screen_duration_s : float
        Seconds of the first training recording used for screening (s).
    screen_nfev : int
        Function evaluations of the short screening fit of a candidate with several parameters.
    min_screen_share : float
        A candidate is fitted only if it screened at >= this share of the best score.
    n_fit : int
        Candidates fitted in full after screening, per round.
    max_batch : int
        Acceptable linear fits at different components taken in one round.
    spectral_above_error : float
        A round whose model misses the training response by more than this relative error fits and
        judges its candidates on log transmissibilities (resonances misplaced: a time-domain fit would
        switch the response off) and polishes the accepted ones in time.
    composite_prior_start : bool
        A joint fit is started twice: at the members' screening optima, and with the best-screened
        physics at its prior start (``Hypothesis.prior``); the lower training residual wins.
    composite_all_prior_start : bool
        And a third time with every member at its prior start (needs ``composite_prior_start``). On the
        ``thesis`` truth the other two starts leave round 1 in a basin where the pad is not found; this
        one reaches the truth's basin.
    polish_nfev : int
        Function evaluations of the time-domain polish of a fit made on log transmissibilities.
    composite_max : int
        In a spectral round where no candidate explains enough alone, at most this many best-screened
        linear candidates (at different places) are fitted together (with both tanks' water and the rear
        supports' fore-aft stiffness among the candidates, 8 let the water take the pad's place on the
        ``thesis`` truth).
    fit_nfev_composite : int
        Function evaluations of a joint fit (per start).
    composite_damping : bool
        The joint fit's connectors (joints, pad) fit their damping times too (exact, bilinear).
    member_nfev : int
        Function evaluations of the refits that take a member out of a joint fit (chord steps with the
        joint fit's Jacobian: one evaluation each).
    min_member_gain : float
        A member of a joint fit must cut the held-out error of each held-out recording by this share
        (against the others refitted without it) and lower the training AIC.
    fit_nfev : int
        Function evaluations of a full fit of one linear candidate.
    n_fit_simulated : int
        Of the ``n_fit``, at most this many simulated in time (nonlinear candidates).
    fit_nfev_simulated : int
        Function evaluations of a nonlinear (time-simulated) fit.
    train_duration_nonlinear_s : float
        Training seconds per recording of a nonlinear fit (s).
    min_improvement : float
        A finding must cut the training error by this share.
    min_screen_improvement : float
        A linear candidate is fitted in full only if its screening share implies this cut of the
        training error (``1 - sqrt(1 - share)``). A full fit refines the screen's optimum; it has not been
        seen to add more than 0.04 to the cut the screen implies, so a third of ``min_improvement``
        leaves a wide margin and spares the fits of a round that can find nothing.
    min_response_ratio : float
        ... and its model must still respond: a fit whose simulated band-limited rms is a smaller share
        of the measured one (median over channels) only switches the response off.
    max_findings : int
        Rounds of locate-screen-fit at most.
    time_budget_s : float
        No new round starts once it would end after this wall time (s).
    max_relative_std : float
        A parameter is identifiable if its relative standard deviation is below this (and it is not
        at a bound).
    drift_check : bool
        With two or more training recordings, a linear candidate's parameters are fitted on each
        training recording alone (from the pooled fit); it is rejected (in a round) or flagged (in the
        final joint refit) if two recordings' estimates of an identifiable parameter differ by more
        than ``drift_sigma`` combined standard deviations and by more than ``drift_rel_tol``.
    drift_sigma : float
        See ``drift_check`` (standard deviations).
    drift_rel_tol : float
        See ``drift_check`` (relative; in the log of a positive parameter).
    drift_nfev : int
        Function evaluations of each per-recording fit of the drift check.
    final_refit : bool
        After the rounds, the linear findings carried into the model are refitted together and judged
        again; the refit is kept if it lowers the training residual and does not raise the held-out
        error. If the free refit is not kept, it is tried once more with the parameters that ended at a
        bound in their rounds held there.
    final_nfev : int
        Function evaluations of that final joint refit.
    final_refit_short : bool
        The final joint refit in the time domain fits on the training records of the nonlinear fits
        when they are the shorter (``train_duration_nonlinear_s``: each evaluation that much cheaper, one
        per parameter and step) and is kept only if the full training records' error and the held-out
        error do not rise; False: it fits on the full training records (``train_duration_s``).
    nonlinear_holdout_tolerance : float
        A nonlinear finding fitted on the level-dependent share is proven on that share at a held-out
        level (it must explain ``min_improvement`` of it there); the held-out error may then grow by
        this share at most (the linear findings fitted before it took up the hardening's mean at the
        training levels).
    min_effect : float
        A channel x band cell counts as mismatch only if its residual is at least this share of the
        response.
    p_value : float
        Family-wise significance level of the residual's coherence with the drive (split over the
        recordings).
    max_channels_worse : float
        A round's findings may make at most this share of the held-out channels (over all held-out
        recordings) materially worse; a mean over channels can halve while most of them get worse
        when a few large ones dominate it. Not asked of a round whose model is far off (training
        error above ``spectral_above_error``): one of several interacting effects moves channels that
        only the others put right; that round is proven on the mean held-out error.
    channel_worse_tolerance : float
        A held-out channel counts as materially worse when its relative error grows by more than
        this share of its error before the round and by more than ``channel_worse_floor``.
    channel_worse_floor : float
        Growth of a channel's relative error below which it never counts as worse (the spread
        of a right model's error on noise).
    place_screen : bool
        Each round screens a point mass and a spring-damper to ground at every place of the flexible
        bodies (one mesh node per ``place_spacing_m`` cube) by a low-rank update of the current model
        (:mod:`~exudyn_study.diagnose.rig_places`); the best places join the candidates.
    place_spacing_m : float
        Spacing of those places (m).
    workers : int
        Local worker processes for the fits' residual evaluations (the finite-difference Jacobians:
        one evaluation per parameter; :mod:`~exudyn_study.diagnose.rig_pool`); 1: all in the
        diagnosis's process. The result does not depend on it.
    scheduler : str or None
        Address of a running Dask scheduler (``tcp://host:port``) to run those evaluations on instead
        (``workers`` is then ignored); None: local.
    """

    train_duration_s: float = 40.0
    screen_duration_s: float = 12.0
    screen_nfev: int = 6
    min_screen_share: float = 0.2
    n_fit: int = 4
    max_batch: int = 3
    spectral_above_error: float = 0.7
    composite_prior_start: bool = True
    composite_all_prior_start: bool = True
    polish_nfev: int = 8
    composite_max: int = 10
    fit_nfev_composite: int = 40
    composite_damping: bool = True
    member_nfev: int = 15
    min_member_gain: float = 0.02
    fit_nfev: int = 30
    n_fit_simulated: int = 2
    fit_nfev_simulated: int = 15
    train_duration_nonlinear_s: float = 15.0
    min_improvement: float = 0.3
    min_screen_improvement: float = 0.1
    min_response_ratio: float = 0.3
    max_findings: int = 8
    time_budget_s: float = 540.0
    max_relative_std: float = 0.3
    drift_check: bool = True
    drift_sigma: float = 3.0
    drift_rel_tol: float = 0.25
    drift_nfev: int = 10
    final_refit: bool = True
    final_nfev: int = 20
    final_refit_short: bool = True
    nonlinear_holdout_tolerance: float = 0.05
    min_effect: float = 0.005
    p_value: float = 1e-3
    max_channels_worse: float = 0.1
    channel_worse_tolerance: float = 0.1
    channel_worse_floor: float = 0.02
    place_screen: bool = True
    place_spacing_m: float = 0.15
    workers: int = 1
    scheduler: str | None = None

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or f.name == "scheduler":
                continue
            if not (isinstance(v, (int, float)) and not math.isnan(v) and v >= 0):
                raise InputError(f"RigDiagnosisSettings.{f.name} = {v!r}: expected a number >= 0")
        if self.scheduler is not None and not isinstance(self.scheduler, str):
            raise InputError(
                f"RigDiagnosisSettings.scheduler = {self.scheduler!r}: expected a Dask scheduler address "
                "such as tcp://127.0.0.1:8786, or None"
            )
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or self.workers < 1:
            raise InputError(f"RigDiagnosisSettings.workers = {self.workers!r}: expected an integer >= 1")
        shares = ("min_screen_share", "min_improvement", "min_screen_improvement", "p_value")
        shares += ("max_channels_worse",)
        for name in shares:
            if getattr(self, name) > 1:
                raise InputError(
                    f"RigDiagnosisSettings.{name} = {getattr(self, name)!r}: expected a share in [0, 1]"
                )
