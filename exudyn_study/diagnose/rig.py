"""Diagnosis on the rig: a model variant against recordings (the chassis path of ``exudyn-study diagnose``).

:func:`diagnose_rig` runs the stages of the diagnosis, one module each, passing frozen dataclasses
(:mod:`~exudyn_study.diagnose.rig_state`) between them: compare
(:mod:`~exudyn_study.diagnose.rig_compare`), locate (:mod:`~exudyn_study.diagnose.rig_locate`),
screen (:mod:`~exudyn_study.diagnose.rig_screen`), fit (:mod:`~exudyn_study.diagnose.rig_fit`,
:mod:`~exudyn_study.diagnose.rig_fit_together`), prove (:mod:`~exudyn_study.diagnose.rig_prove`),
explain (:mod:`~exudyn_study.diagnose.rig_explain`); settings in
:class:`~exudyn_study.diagnose.rig_settings.RigDiagnosisSettings`. What they do:

1. **Compare**: the model is driven by each recording's drive channel; channel x band cells whose
   residual is significantly coherent with the drive and not negligible (family-wise p < 1e-3,
   effect >= 0.5 %). None: "no missing physics found".
2. **Locate**: the located sensors strongest first, the band, level dependence; a structure-wide
   screen of a point mass and a spring-damper to ground at every place of the flexible bodies by a
   low-rank update (:mod:`~exudyn_study.diagnose.rig_places`).
3. **Screen**: every registered candidate (catalogue entry at a place:
   :mod:`~exudyn_study.diagnose.rig_hypotheses`, :mod:`~exudyn_study.diagnose.rig_candidates`),
   sensor faults included, is scored by how much of the residual it explains at its best value on
   a coarse grid or after a short fit; a nonlinear candidate only when the mismatch grows with the
   drive level.
4. **Fit**: the best candidates are fitted (bounded least squares, log parameters), rejected if
   not identifiable (relative std > 30 % or at a bound), if they explain too little (< 30 % of the
   error), switch the response off or drift between training recordings, and chosen by the Akaike
   information criterion. Far from the recordings (resonances misplaced) they are fitted on log
   transmissibilities, those that explain little alone together (from up to three starts), each
   member of that joint fit judged on its own (taken out, the others refitted, it must lose on the
   training AIC and on the held-out error). With one drive at two training levels the nonlinear
   candidates are fitted on the level-dependent share of the response (``y_strong - c y_weak``).
   Last, the generic local element stands in for physics outside the catalogue. The generic element
   gives way to a catalogue fit that explains nearly as much (within 5 %), and replaces a
   modal damping factor whose factors per band of modes disagree (a local damper, not a
   body-wide change: :mod:`~exudyn_study.diagnose.rig_global`) when it explains nearly as
   much; a point fit (a mass, a resonator, the generic element) is refitted at a better mesh
   node within 0.26 m when the fitted element explains clearly more there, node by node, the last
   steps judged on the training time histories (:mod:`~exudyn_study.diagnose.rig_refine`).
5. **Prove**: a round's findings must not raise the held-out error nor make more than
   ``max_channels_worse`` of the held-out channels materially worse; a nonlinear finding fitted on
   the level-dependent share is proven on that share at a held-out level of the same drive (it must
   explain 30 % of it there) and may raise the held-out error by 5 % at most, since the linear
   findings before it took up the hardening's mean at the training levels.
6. **Explain**: plain text, place, flags; rounds repeat on what is left (until nothing significant is
   left, the time budget is spent or no candidate explains it), the linear findings are refitted
   together at the end, and what is left is described by the sensors and band that carry it.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from exudyn_study.diagnose.rig_candidates import register_rig_candidate, unregister_rig_candidate
from exudyn_study.diagnose.rig_compare import BANDS_HZ, METRIC, compare, prepare, summary_error
from exudyn_study.diagnose.rig_evaluate import (
    DistortionEvaluator,
    Evaluator,
    SpectralEvaluator,
    decay_time,
    set_offsets,
)
from exudyn_study.diagnose.rig_explain import (
    explain,
    figures_before,
    make_finding,
    model_transmissibility,
    point_of,
    recording_label,
    unexplained_entry,
)
from exudyn_study.diagnose.rig_fit import GENERIC_MARGIN, choose_batch, fit_generic, fit_nonlinear, fit_round
from exudyn_study.diagnose.rig_fit_together import refit_findings
from exudyn_study.diagnose.rig_global import body_wide
from exudyn_study.diagnose.rig_hypotheses import OutputChain
from exudyn_study.diagnose.rig_locate import distortion_shares, is_level_dependent, level_pair, locate
from exudyn_study.diagnose.rig_pool import evaluation_pool
from exudyn_study.diagnose.rig_prove import channel_verdict, prove, relative_damage
from exudyn_study.diagnose.rig_refine import place_again, refine_places, simpler_entries
from exudyn_study.diagnose.rig_screen import screen
from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings
from exudyn_study.diagnose.rig_state import (
    Comparison,
    Location,
    ModelState,
    Progress,
    RigProblem,
    assembled_state,
    carry,
)
from exudyn_study.diagnose.schema import Diagnosis
from exudyn_study.errors import InputError
from exudyn_study.infra.blas import one_blas_thread
from exudyn_study.infra.progress import StatusProgress

__all__ = ["diagnose_rig", "RigDiagnosisSettings", "register_rig_candidate", "unregister_rig_candidate"]

log = logging.getLogger(__name__)


def _load(recs, what):
    """Return ``(name, Recording)`` pairs of recordings given as objects or paths."""
    from exudyn_study.recording.io import read_recording
    from exudyn_study.recording.types import Recording

    out = []
    for r in recs or []:
        if isinstance(r, Recording):
            out.append((str(r.metadata.get("name", f"{what}{len(out)}")), r))
        else:
            out.append((str(r), read_recording(r)))
    return out


def _check_layouts(named):
    """Raise :class:`InputError` unless all recordings have the same response channels."""
    ref_name, ref = named[0]
    ref_set = sorted(ch.name for ch in ref if ch.role == "response")
    for name, rec in named[1:]:
        names = sorted(ch.name for ch in rec if ch.role == "response")
        if names != ref_set:
            diff = sorted(set(names) ^ set(ref_set))
            raise InputError(
                f"recordings {ref_name!r} and {name!r} have different sensor layouts (differ in "
                f"{diff[:6]}); diagnose recordings of one test set-up"
            )


def _problem(
    variant, train, holdout, damping, say, bodies, sensors, candidates, st, cache_dir, t_start, pool=None
):
    """Load and check the recordings, build the nominal model; the diagnosis's :class:`RigProblem`.

    Returns
    -------
    tuple
        ``(problem, nominal)``: the problem and the nominal :class:`ModelState`.
    """
    import functools

    from exudyn_study.bodies.damping import parse_damping

    tr, ho = _load(train, "train"), _load(holdout, "holdout")
    if not tr:
        raise InputError("no training recording given (--train): the diagnosis fits on it")
    if not ho:
        raise InputError(
            "no held-out recording given (--holdout): the diagnosis proves a fit on recordings it "
            "was not fitted to; give another signal or excitation level"
        )
    _check_layouts(tr + ho)
    damping_fn = parse_damping(damping) if isinstance(damping, str) else damping
    from_cache = bodies is None
    if from_cache:  # loaded once: the diagnosis builds the model dozens of times (linearisations)
        from exudyn_study.model import model_bodies

        bodies = model_bodies(variant, cache_dir=cache_dir)
    build = functools.partial(_build_nominal, variant, damping_fn, bodies, sensors, from_cache)
    say("building the nominal model")
    nominal = assembled_state(build, (), None)
    sensor_names = tuple(nominal.model.sensors)
    train_recs = [prepare(r, sensor_names, n, st.train_duration_s) for n, r in tr]
    screen_recs = [prepare(r, sensor_names, n, st.screen_duration_s) for n, r in tr[:1]]
    hold_recs = [prepare(r, sensor_names, n) for n, r in ho]
    nonlinear_recs = [prepare(r, sensor_names, n, st.train_duration_nonlinear_s) for n, r in tr]
    pad = decay_time(nominal.lin)  # the convolution's zero padding: the nominal model's slowest decay
    # one drive at two levels inside the training data: nonlinear candidates are judged on the
    # level-dependent share of the response, which no linear error of the model disturbs; and proven on
    # it at a held-out level of that drive (a weaker training, a stronger held-out one)
    pair = level_pair(nonlinear_recs)
    pair_hold = level_pair(nonlinear_recs + hold_recs, stronger_in=hold_recs)
    problem = RigProblem(
        variant=int(variant),
        build=build,
        settings=st,
        say=say,
        t_start=t_start,
        train=tuple(tr),
        holdout=tuple(ho),
        sensor_names=sensor_names,
        channels=train_recs[0].channels,
        train_recs=train_recs,
        hold_recs=hold_recs,
        ev_train=Evaluator(train_recs, sensor_names, pad, exact=True),
        ev_train_nonlinear=Evaluator(nonlinear_recs, sensor_names, pad, exact=True),
        ev_hold=Evaluator(hold_recs, sensor_names, pad, exact=True),
        ev_hold_fast=Evaluator(hold_recs, sensor_names, pad),  # judges the members of joint fits
        ev_screen=Evaluator(screen_recs, sensor_names, pad),
        ev_spectral=SpectralEvaluator(train_recs, sensor_names),
        ev_distortion=DistortionEvaluator(pair, sensor_names, pad) if pair is not None else None,
        ev_distortion_hold=DistortionEvaluator(pair_hold, sensor_names, pad)
        if pair_hold is not None
        else None,
        p_cell=st.p_value / (len(tr) + len(ho)),
        distortion=distortion_shares(train_recs + hold_recs),
        wanted=frozenset(candidates) if candidates is not None else None,
        pool=pool if pool is not None and pool.parallel else None,
    )
    nominal = replace(nominal, gains=np.ones(len(problem.channels)))
    set_offsets(problem.evaluators, nominal.system)
    return problem, nominal


def _build_nominal(variant, damping_fn, bodies, sensors, from_cache: bool):
    """Return a fresh nominal model (not assembled) of the flexible ``bodies``.

    ``from_cache``: the bodies are the variant's production bodies (those
    :func:`~exudyn_study.model.build_model` loads), so the model is the one it builds.
    """
    from exudyn_study.model import build_model_from_bodies

    model = build_model_from_bodies(bodies, variant, damping=damping_fn, sensors=sensors, exudyn_mesh="used")
    if from_cache:
        model.metadata["mesh"] = "production"
    return model


def _nominal_meta(problem: RigProblem, damping, comparison: Comparison) -> dict:
    """Return the JSON's ``meta`` block of the nominal comparison."""
    ev_train, ev_hold = problem.ev_train, problem.ev_hold
    return {
        "model": problem.variant,
        "damping": str(damping),
        "train": [n for n, _ in problem.train],
        "holdout": [n for n, _ in problem.holdout],
        "metric": METRIC,
        "nominal_train_error": [summary_error(e) for e in ev_train.errors(comparison.sims_tr)],
        "nominal_holdout_error": [summary_error(e) for e in ev_hold.errors(comparison.sims_ho)],
        "significant_cells": int(comparison.significant.sum()),
        "bands_hz": [list(b) for b in BANDS_HZ],
        "residual_z": [m.z.round(2).tolist() for m in comparison.maps],
        "residual_effect": [m.effect.round(4).tolist() for m in comparison.maps],
        "channels": list(problem.channels),
        "candidates": [],
        "rounds": [],
    }


def _record_findings(
    problem: RigProblem,
    before: ModelState,
    after: ModelState,
    location: Location,
    batch: list,
    fit: dict,
    progress: Progress,
) -> Progress:
    """Append the round's accepted fits ``batch`` to the findings (with their text) and records."""
    findings, records = list(progress.findings), list(progress.records)
    k_accepted = len(before.accepted)
    for f in batch:
        h, p = f["h"], f["p"]
        at_bound = np.asarray(f.get("at_bound", np.zeros(len(h.names), bool)), dtype=bool)
        # fitted on the level-dependent share: level dependent by construction
        dependent = location.level_dependent or bool(f.get("on_distortion"))
        text = explain(h, p, f["std"], before.lin, after.lin, location.located)
        place = point_of(h, before.markers)
        flags = tuple(f.get("flags", ()))  # doubts the round raised (an earlier finding it may stand in for)
        findings.append(
            make_finding(h, p, f["std"], at_bound, flags, location.band_hz, dependent, text, fit, place)
        )
        records.append(
            {
                "h": h,
                "finding": len(findings) - 1,
                # the entry's place in ``ModelState.accepted`` (None: carried as output gains)
                "accepted": None if h.carry == "gains" else k_accepted,
                "lin_before": before.lin,
                "lin_after": after.lin,
                "located": list(location.located),
                "at_bound": at_bound,  # the round's: what the data did not determine
                "flags": flags,
            }
        )
        if h.carry != "gains":
            k_accepted += 1
    return replace(progress, findings=tuple(findings), records=tuple(records))


def _carry_batch(problem: RigProblem, state: ModelState, screening, fits, batch: list) -> tuple:
    """Carry the round's fits into the model; several single fits only if together they beat the best.

    Returns ``(after, comparison_after, batch)``.
    """
    after = carry(problem, state, batch)
    if len(batch) > 1 and not fits.together:
        r_batch = screening.judged_on(batch[0]["h"])[0].residual_vector(after.lin, after.gains)
        if not float(r_batch @ r_batch) < batch[0]["rss"]:
            problem.say(
                f"the {len(batch)} fits together do not beat {batch[0]['h'].label} alone: keeping it only"
            )
            batch = batch[:1]
            after = carry(problem, state, batch)
    return after, compare(problem, after.system, after.gains), batch


def _stretched(fits) -> bool:
    """Whether every acceptable catalogue fit of the round has a parameter at its bound (a stand-in).

    A round whose acceptable fits include the generic local element itself (offered where the structure
    screen points at it) is not: the generic element would only be fitted again.
    """
    if any(f["h"].physics == "local_element" for f in fits.ok):
        return False
    return not fits.together and all(np.any(f.get("at_bound", False)) for f in fits.ok)


def _generic_if_better(problem: RigProblem, state: ModelState, screening, fits, meta, round_no):
    """Fit the generic local element too; take it if it explains clearly more than the catalogue's best.

    A catalogue fit with a parameter at its bound may stand in for physics the catalogue lacks (a
    rear support with its damping at the bound for a dashpot to ground): the generic element
    replaces it when it removes at least ``GENERIC_MARGIN`` more of the residual.
    """
    from exudyn_study.diagnose.rig_state import RoundFits

    generic = fit_generic(problem, state, screening, RoundFits((), ()), meta, round_no)
    best_catalogue = max(f["improvement"] for f in fits.ok)
    better = _clearly_better(generic.ok, best_catalogue)
    if not better:
        return replace(fits, fitted=fits.fitted + generic.fitted)
    problem.say(
        f"the generic local element explains {100 * better[0]['improvement']:.0f} % against "
        f"{100 * best_catalogue:.0f} % for the catalogue's best (a parameter at its bound): taken instead"
    )
    return replace(fits, fitted=fits.fitted + generic.fitted, ok=tuple(better))


def _clearly_better(generic_fits, best_catalogue: float) -> list:
    """Return the generic element's fits that explain :data:`GENERIC_MARGIN` more than ``best_catalogue``."""
    return [f for f in generic_fits if f["improvement"] >= best_catalogue + GENERIC_MARGIN]


def _why_none(problem: RigProblem, screening, fits) -> str:
    """Return what the round's fits explained, or (none fitted) what the best-screened candidates would."""
    if fits.fitted:
        return "; ".join(
            f"{f['h'].label} improves {100 * f['improvement']:.0f} % ({f['rejected']})" for f in fits.fitted
        )
    from exudyn_study.diagnose.rig_fit import screened_improvement

    best = sorted(zip(screening.scores, screening.hyps, strict=True), key=lambda t: -t[0])[:3]
    return (
        "the best-screened candidates would explain at most "
        + ", ".join(f"{h.label} {100 * screened_improvement(s):.0f} %" for s, h in best)
        + f" (a finding needs {100 * problem.settings.min_improvement:.0f} %; not fitted)"
    )


def _catalogue_first(problem: RigProblem, fits):
    """Drop the generic local element's fits when a catalogue fit explains nearly as much.

    The generic element (a spring-damper to ground at a point) has the freedom to stand in for part of
    almost any local mismatch; a catalogue entry names physics. The generic element is kept only where it
    removes at least :data:`GENERIC_MARGIN` more of the residual than every acceptable catalogue fit.
    """
    generic = [f for f in fits.ok if f["h"].physics == "local_element"]
    catalogue = [f for f in fits.ok if f["h"].physics != "local_element"]
    if not generic or not catalogue:
        return fits
    best_catalogue = max(catalogue, key=lambda f: f["improvement"])
    kept = _clearly_better(generic, best_catalogue["improvement"])
    if len(kept) < len(generic):
        problem.say(
            f"{best_catalogue['h'].label} explains {100 * best_catalogue['improvement']:.0f} %, within "
            f"{100 * GENERIC_MARGIN:.0f} % of the generic local element: the catalogue entry is preferred"
        )
    kept_ids = {id(f) for f in kept}
    ok = tuple(f for f in fits.ok if f["h"].physics != "local_element" or id(f) in kept_ids)
    return replace(fits, ok=ok)


def _round(
    problem: RigProblem, state: ModelState, comparison: Comparison, progress: Progress, meta, round_no
):
    """One round: locate, screen, fit, prove, explain.

    Returns
    -------
    tuple
        ``(state, comparison, progress, stop_reason)``; ``stop_reason`` is None when the round found
        something (its findings are in ``progress``), else why the rounds stop.
    """
    t_round = time.perf_counter()
    stages = _Stages()
    location = locate(problem, comparison)
    stages.lap("locate")
    screening = screen(problem, state, comparison, location, progress.done(state), round_no)
    stages.lap("screen")
    meta["stage_s"]["rounds"].append(stages.seconds)
    if screening is None:
        return state, comparison, progress, "no catalogue candidate applies to the located mismatch"
    ranked = sorted(zip(screening.scores, screening.hyps, strict=True), key=lambda t: -t[0])
    meta["screened_best"] = [[h.label, round(float(score), 4)] for score, h in ranked[:3]]
    fits = fit_round(problem, state, screening, meta, round_no)
    stages.lap("fit")
    if not fits.ok and screening.deferred:
        # the linear findings refitted together first: the level-dependent share is compared in time, so
        # the nonlinear candidates need the linear model as right as it gets
        state, comparison, progress = refit_findings(problem, state, comparison, progress, meta)
        stages.lap("final_refit")
        fits = fit_nonlinear(problem, state, screening, fits, meta, round_no)
        stages.lap("fit_nonlinear")
    fits = simpler_entries(problem, state, screening, fits, meta, round_no)
    stages.lap("simpler_entries")
    if not fits.ok:  # outside the catalogue: the generic local element, the last candidate
        fits = fit_generic(problem, state, screening, fits, meta, round_no)
        stages.lap("fit_generic")
    elif _stretched(fits):
        fits = _generic_if_better(problem, state, screening, fits, meta, round_no)
        stages.lap("fit_generic")
    fits = body_wide(problem, state, screening, fits, meta, round_no)
    stages.lap("body_wide")
    if not fits.ok:
        moved = place_again(problem, state, comparison, screening, None, progress, meta, round_no)
        stages.lap("place_again")
        if moved is not None:
            return (*moved, None)
        return (
            state,
            comparison,
            progress,
            "no catalogue entry explains it: " + _why_none(problem, screening, fits),
        )
    fits = _catalogue_first(problem, fits)
    fits = refine_places(problem, state, screening, fits, meta, round_no)
    stages.lap("refine_places")
    fits = simpler_entries(problem, state, screening, fits, meta, round_no)  # of the refits at new places
    stages.lap("simpler_entries")
    moved = place_again(problem, state, comparison, screening, fits, progress, meta, round_no)
    stages.lap("place_again")
    if moved is not None:
        return (*moved, None)
    batch = choose_batch(problem, screening, fits)
    stages.lap("polish")
    after, comparison_after, batch = _carry_batch(problem, state, screening, fits, batch)
    stages.lap("carry_compare")
    proof = prove(problem, state, comparison, after, comparison_after, batch)
    stages.lap("prove")
    if not proof.accepted:
        set_offsets(problem.evaluators, state.system)  # the evaluators back at the round's model
        return state, comparison, progress, proof.reason
    progress = _record_findings(problem, state, after, location, batch, proof.fit, progress)
    problem.say(
        f"finding {len(progress.findings)}: {' + '.join(f['h'].label for f in batch)}, held-out error "
        f"{proof.fit['holdout_before']:.4f} -> {proof.fit['holdout_after']:.4f}"
    )
    round_s = time.perf_counter() - t_round
    meta["rounds"].append(
        {"round": round_no + 1, "candidates": len(screening.hyps), "wall_s": round(round_s, 1)}
    )
    if fits.nonlinear_s is not None:
        meta["rounds"][-1]["nonlinear_s"] = round(fits.nonlinear_s, 1)
    return after, comparison_after, progress, None


class _Stages:
    """Wall time (s) of the stages of a round, in the order they ran (a stage run twice adds up)."""

    def __init__(self):
        self.seconds: dict = {}
        self._t = time.perf_counter()

    def lap(self, name: str) -> None:
        t = time.perf_counter()
        self.seconds[name] = round(self.seconds.get(name, 0.0) + t - self._t, 2)
        self._t = t


def _finish(problem, state, comparison, nominal_sims_ho, progress, stop_reason, meta, figures) -> Diagnosis:
    """Describe what is left unexplained; final held-out errors, pseudo damage, the report's last figures."""
    unexplained = []
    if comparison.significant.any():
        rows = np.flatnonzero(comparison.significant.any(axis=1))
        recs, sims = problem.train_recs + problem.hold_recs, comparison.sims_tr + comparison.sims_ho
        dependent = is_level_dependent(recs, sims, rows, problem.distortion)
        best = [tuple(b) for b in meta.get("screened_best", [])]
        unexplained.append(
            unexplained_entry(
                comparison.significant, problem.channels, dependent, stop_reason, comparison.maps, best
            )
        )
    if progress.findings:
        final_errors = problem.ev_hold.errors(comparison.sims_ho)
        meta["final_holdout_error"] = [summary_error(e) for e in final_errors]
        meta["final_holdout_per_channel"] = {
            recording_label(name): {c: float(e[k]) for k, c in enumerate(problem.channels)}
            for (name, _), e in zip(problem.holdout, final_errors, strict=True)
        }
        nominal_errors = problem.ev_hold.errors(nominal_sims_ho)
        meta["holdout_per_channel"] = {
            recording_label(name): {
                c: {"nominal": float(e0[k]), "after": float(e1[k])} for k, c in enumerate(problem.channels)
            }
            for (name, _), e0, e1 in zip(problem.holdout, nominal_errors, final_errors, strict=True)
        }
        verdict = channel_verdict(
            problem.holdout, problem.channels, nominal_errors, final_errors, problem.settings
        )
        meta["holdout_median_improvement"] = verdict["holdout_median_improvement"]
        meta["holdout_channels_worse"] = verdict["channels_worse"]
        meta["relative_pseudo_damage"] = relative_damage(
            problem.hold_recs, nominal_sims_ho, comparison.sims_ho, problem.damage_cache
        )
        if figures is not None:
            recs = problem.train_recs + problem.hold_recs
            figures["after_T"] = {
                lab: model_transmissibility(
                    state.lin, figures["freq_hz"], rec.channels, problem.sensor_names, state.gains
                )
                for lab, rec in zip(figures["labels"], recs, strict=True)
            }
            located = [s_ for f in progress.findings for s_ in f.location["sensors"]][:3]
            figures["located_sensors"] = located or list(meta.get("located", []))
            figures["physics"] = " + ".join(f.physics for f in progress.findings)
            figures["pseudo_damage"] = {
                c: {"measured": 1.0, **v} for c, v in meta["relative_pseudo_damage"].items()
            }
    meta.update(_fitted_model_record(state, problem.channels))
    meta["wall_s"] = time.perf_counter() - problem.t_start
    return Diagnosis(True, list(progress.findings), unexplained, meta)


def _fitted_model_record(state, channels) -> dict:
    """Return what the findings put into the model, so that the fitted model can be rebuilt.

    ``model_entries``: the catalogue entries applied (entry, its location argument, its values),
    read by :func:`exudyn_study.diagnose.fitted.apply_diagnosis`; ``output_gains``: the product
    of the gain stages of the acquisition chain per channel (a sensor fault that is not a gain,
    such as a swap or a time offset, is named in the findings and not rebuilt here).
    """
    gains = np.ones(len(channels))
    stages = state.gains.stages if isinstance(state.gains, OutputChain) else (state.gains,)
    for stage in stages:
        if isinstance(stage, np.ndarray):
            gains = gains * np.asarray(stage, dtype=float)
    return {
        "model_entries": [{"physics": name, "location": loc, "values": dict(values)}
                          for name, loc, values in state.accepted],
        "output_gains": {c: float(g) for c, g in zip(channels, gains, strict=True)},
    }


@one_blas_thread
def diagnose_rig(
    variant: int,
    train: Sequence,
    holdout: Sequence,
    damping="adams-default",
    progress: Callable | None = None,
    bodies=None,
    sensors=None,
    candidates: Sequence[str] | None = None,
    settings: RigDiagnosisSettings | None = None,
    cache_dir=None,
    figures: dict | None = None,
) -> Diagnosis:
    """Diagnose the mismatch between model ``variant`` and the recordings.

    Runs with one BLAS thread (:func:`~exudyn_study.infra.blas.one_blas_thread`): the work is
    thousands of small (~100x100) eigen/solve problems, which multi-threaded BLAS makes
    several times slower on a shared machine. The metadata holds the wall time per stage
    (``stage_s``) and the CPU time of this process and of the local workers (``cpu_s``).

    Parameters
    ----------
    variant : {1, 2, 3}
        Model variant.
    train, holdout : sequence of Recording or paths
        Training recordings (fitted) and held-out recordings (only evaluated).
    damping : str
        The nominal model's damping function.
    progress : callable, optional
        Called with short status texts.
    bodies, sensors
        Reduced bodies and sensor names for :func:`~exudyn_study.model.build_model_from_bodies`
        (tests); default the variant's chassis bodies and all sensors.
    candidates : sequence of str, optional
        Catalogue entries to consider (default all the rig path can fit).
    settings : RigDiagnosisSettings, optional
        Knobs (default :class:`RigDiagnosisSettings`); its ``workers`` or ``scheduler`` run the fits'
        residual evaluations on local worker processes or a Dask cluster
        (:mod:`~exudyn_study.diagnose.rig_pool`; the result is the serial one).
    cache_dir : path, optional
        Flexible-body cache.
    figures : dict, optional
        Filled with the arrays of the report's figures
        (:func:`exudyn_study.diagnose.report.write_report`).

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        No training or held-out recording, different sensor layouts, no drive channel,
        channels the model lacks, an unreachable scheduler.
    """
    st = settings or RigDiagnosisSettings()
    cpu0 = os.times()
    with (
        StatusProgress(f"diagnosis of Model {variant}") as status,
        evaluation_pool(st.workers, st.scheduler) as pool,
    ):

        def say(text: str) -> None:
            log.info(text)
            status(text)
            if progress is not None:
                progress(text)

        diagnosis = _diagnose_rig(
            variant, train, holdout, damping, say, bodies, sensors, candidates, st, cache_dir, figures, pool
        )
        dask = pool.scheduler is not None
    # CPU time of this process and of the local workers (counted once they have ended, with the pool)
    cpu1 = os.times()
    cpu_s = {
        "diagnosis": round(cpu1.user + cpu1.system - cpu0.user - cpu0.system, 1),
        "local_workers": None
        if dask
        else round(
            max(0.0, cpu1.children_user + cpu1.children_system - cpu0.children_user - cpu0.children_system),
            1,
        ),
    }
    return replace(diagnosis, metadata={**diagnosis.metadata, "cpu_s": cpu_s})


def _diagnose_rig(
    variant, train, holdout, damping, say, bodies, sensors, candidates, st, cache_dir, figures, pool
):
    """Run the stages of :func:`diagnose_rig`, reporting with ``say(text)``."""
    t_start = time.perf_counter()
    stages = _Stages()
    problem, state = _problem(
        variant, train, holdout, damping, say, bodies, sensors, candidates, st, cache_dir, t_start, pool
    )
    stages.lap("setup")

    # compare the nominal model; no significant cell: nothing missing
    say("comparing the nominal model with the recordings")
    comparison = nominal = compare(problem, state.system, None)
    meta = _nominal_meta(problem, damping, comparison)
    stages.lap("compare_nominal")
    meta["workers"] = pool.describe()
    meta["stage_s"] = {**stages.seconds, "rounds": []}
    if figures is not None:
        figures_before(
            figures,
            problem.train + problem.holdout,
            problem.train_recs + problem.hold_recs,
            nominal.sims_tr + nominal.sims_ho,
            state.lin,
            problem.sensor_names,
            nominal.maps,
        )
        figures["train"] = [recording_label(n) for n, _ in problem.train]
        figures["holdout"] = [recording_label(n) for n, _ in problem.holdout]
    if not comparison.significant.any():
        meta["wall_s"] = time.perf_counter() - t_start
        say("no significant mismatch: no missing physics found")
        return Diagnosis(False, [], [], meta)
    if problem.distortion is not None:
        meta["nonlinear_share"] = dict(
            zip(problem.channels, np.round(problem.distortion[0], 5).tolist(), strict=True)
        )

    # rounds of locate, screen, fit, prove, explain, each on what the findings before it leave
    findings = Progress()
    stop_reason = f"mismatch left after {st.max_findings} rounds (the most this diagnosis runs)"
    for round_no in range(st.max_findings):
        elapsed, last = (
            time.perf_counter() - t_start,
            (meta["rounds"][-1]["wall_s"] if meta["rounds"] else 0.0),
        )
        if round_no > 0 and elapsed + last > st.time_budget_s:
            stop_reason = (
                f"mismatch left after {len(findings.findings)} findings: the time budget of "
                f"{st.time_budget_s:.0f} s would be exceeded by another round ({elapsed:.0f} s used, "
                f"the last round took {last:.0f} s)"
            )
            break
        state, comparison, findings, stop = _round(problem, state, comparison, findings, meta, round_no)
        if stop is not None:
            stop_reason = stop
            break
        if not comparison.significant.any():
            break

    # the linear findings refitted together; what is left, proven on the held-out recordings
    stages = _Stages()
    state, comparison, findings = refit_findings(problem, state, comparison, findings, meta)
    stages.lap("final_refit")
    meta["worker_evaluations"] = pool.evaluations
    diagnosis = _finish(problem, state, comparison, nominal.sims_ho, findings, stop_reason, meta, figures)
    stages.lap("finish")
    meta["stage_s"].update(stages.seconds)
    return diagnosis
