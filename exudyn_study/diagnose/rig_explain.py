"""Explain: findings and what is left, in plain language and as JSON blocks; the report's figures.

A stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`: :func:`make_finding` turns a fitted
hypothesis into a :class:`~exudyn_study.diagnose.schema.Finding` (a parameter at its bound
flagged), :func:`explain` writes its text (a registered ``explain`` callable, else the values and
the modes it moved), :func:`unexplained_entry` describes the significant residual that is left.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.diagnose.rig_candidates import (
    RIG_CANDIDATES,
    ExplainContext,
    point_of,  # noqa: F401 - the explain stage's name for it
    sensor_component,
)
from exudyn_study.diagnose.rig_compare import BANDS_HZ, drive_spectra
from exudyn_study.diagnose.rig_hypotheses import Hypothesis, apply_output_frf
from exudyn_study.diagnose.schema import NOT_IDENTIFIABLE, Finding


def recording_label(name) -> str:
    """Return a recording's label in the JSON and the report: its file name (else the name as given).

    Parameters
    ----------
    name : str or path-like
        The recording's name as given (often a path).

    Returns
    -------
    str
        The part after the last ``/``.
    """
    return str(name).rsplit("/", 1)[-1]


def make_finding(
    h, p, std, at_bound, flags, band_hz, level_dependent, explanation, fit, place=None
) -> Finding:
    """Return the :class:`Finding` of hypothesis ``h`` at ``p``; a parameter at its bound is flagged.

    ``place``: optional location keys of a finding at a point (``position_m``, ``nearest_sensor``).

    Parameters
    ----------
    h : Hypothesis
        The fitted hypothesis (physics, parameter names and units, sensors, component, interface).
    p : array_like
        Fitted parameter values, shape (n_params,).
    std : array_like
        Standard deviation of each parameter, shape (n_params,).
    at_bound : array_like of bool
        Per parameter, whether the fit ended at its bound, shape (n_params,).
    flags : sequence of str
        Further doubts about the finding, one sentence each.
    band_hz : tuple of float or None
        Band (Hz) of the mismatch the finding explains.
    level_dependent : bool
        Whether the mismatch changes with the excitation level.
    explanation : str
        Plain-language explanation (:func:`explain`).
    fit : dict
        Errors before and after (``train_before``, ``train_after``, ``holdout_before``,
        ``holdout_after``, ``metric``; see :class:`~exudyn_study.diagnose.schema.Finding`).
    place : dict or None, optional
        Location keys of a finding at a point (``position_m``, ``nearest_sensor``; None: none).

    Returns
    -------
    Finding
        The finding, with a flag per parameter at its bound, one naming the parameters whose
        standard deviation exceeds their magnitude, and a
        :data:`~exudyn_study.diagnose.schema.NOT_IDENTIFIABLE`
        flag when that holds for all of them (the data determine none).
    """
    params = {
        n: {"value": float(v), "unit": u, "std": float(s_), "at_bound": bool(b)}
        for n, v, u, s_, b in zip(h.names, p, h.units, std, at_bound, strict=True)
    }
    bound = [
        f"{n} ended at its bound ({v['value']:.3g} {v['unit']}): the data do not determine it"
        for n, v in params.items()
        if v["at_bound"]
    ]
    loose = [n for n, v in params.items() if not v["at_bound"] and not _determined(v)]
    if params and not any(_determined(v) and not v["at_bound"] for v in params.values()):
        bound.insert(0, f"{NOT_IDENTIFIABLE}: the data determine none of its parameters "
                        "(each at a bound or with a standard deviation larger than its value)")
        explanation = f"Not identifiable, not a finding: the values below are not determined. {explanation}"
    elif loose:
        bound.append("the data do not determine " + ", ".join(
            f"{n} ({params[n]['value']:.3g} +- {params[n]['std']:.2g} {params[n]['unit']})" for n in loose))
    bound += _physics_flags(h.physics, params)
    return Finding(
        physics=h.physics,
        location={
            "sensors": list(h.sensors),
            "component": h.component,
            "interface": h.interface,
            **(place or {}),
        },
        band_hz=band_hz,
        level_dependent=level_dependent,
        explanation=explanation,
        parameters=params,
        fit=fit,
        flags=tuple(bound) + tuple(flags),
    )


#: a tuned mass-damper this damped has no resonance of its own (quality factor 1 / (2 zeta) below 1.7)
TMD_NO_RESONANCE_DAMPING = 0.3


def _physics_flags(physics: str, params: dict) -> list:
    """Return doubts particular to the physics at its fitted values.

    A tuned mass-damper damped by ``TMD_NO_RESONANCE_DAMPING`` or more makes no resonance (its dynamic
    stiffness peaks below twice the mass's own); well above its tuning its mass hardly moves and its
    damper dissipates as a dashpot to ground, so the generic local element near it may explain the same.
    One tuned above the diagnosed band shows no resonance in the data: below its tuning its mass
    follows its point, so in the band it is a point mass with an apparent value
    ``m / (1 - (f / f_t)^2)`` (damping aside).
    """
    out = []
    if physics == "tuned_mass_damper" and "damping_ratio" in params:
        zeta = params["damping_ratio"]["value"]
        if zeta >= TMD_NO_RESONANCE_DAMPING:
            out.append(
                f"damping ratio {100 * zeta:.0f} %: no resonance of its own (quality factor below 1.7); well "
                "above its tuning it dissipates like a dashpot to ground, so a dashpot near this place may "
                "explain the data as well"
            )
    if physics == "tuned_mass_damper" and "frequency_hz" in params:
        from exudyn_study.diagnose.rig_compare import BAND_HZ

        f_t = params["frequency_hz"]["value"]
        if f_t > BAND_HZ[1]:
            out.append(
                f"tuned to {f_t:.1f} Hz, above the diagnosed band ({BAND_HZ[1]:.0f} Hz): its resonance is "
                "not in the data; in the band it acts as a point mass whose apparent value grows towards "
                "the tuning, so a point mass near this place may explain the data as well"
            )
    return out


def _determined(p: dict) -> bool:
    """Whether the data determine a fitted parameter: its standard deviation below its magnitude."""
    return p["std"] is not None and abs(p["std"]) < abs(p["value"])


def explain_local_element(h, p, std, place: dict, closest) -> str:
    """Explain the generic local element: outside the catalogue, where, and the closest catalogue candidates.

    ``closest``: (label, share of the residual explained at screening) of the round's best catalogue
    candidates.

    Parameters
    ----------
    h : Hypothesis
        The generic local element's hypothesis (location and component).
    p : array_like
        Fitted ``(stiffness N/m, damping N s/m)``.
    std : array_like
        Their standard deviations, same units.
    place : dict
        ``position_m`` and ``nearest_sensor`` of the place (:func:`point_of`; may be empty).
    closest : sequence of tuple
        ``(label, share of the residual explained at screening)`` of the best catalogue candidates.

    Returns
    -------
    str
        The explanation.
    """
    k, c = (float(v) for v in p)
    sk, sc = (float(v) for v in std)
    where = h.location
    if place.get("position_m"):
        x, y, z = place["position_m"]
        where += f" ({x:.3f}, {y:.3f}, {z:.3f}) m, on {h.component or '?'}, nearest sensor "
        where += str(place.get("nearest_sensor"))
    near = ", ".join(f"{lab} ({100 * share:.0f} % of the residual)" for lab, share in closest[:3])
    return (
        f"A local dynamic stiffness to ground of {k:.3g} +- {sk:.2g} N/m and {c:.3g} +- {sc:.2g} N s/m at "
        f"{where}: not in the catalogue (no catalogue candidate explains as much); closest entries: "
        f"{near or 'none'}."
    )


def modes_hz(lin):
    """Undamped natural frequencies of ``lin`` (its linear tangent), Hz.

    Parameters
    ----------
    lin : LinearSystem or NonlinearSystem
        The system (a nonlinear one by its linear tangent).

    Returns
    -------
    numpy.ndarray
        Natural frequencies (Hz), ascending, shape (n_dof,).
    """
    import scipy.linalg as sla

    lin = getattr(lin, "lin", lin)  # a NonlinearSystem: its linear tangent
    w2 = sla.eigh(lin.stiffness, lin.mass, eigvals_only=True)
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * math.pi)


def shifted_modes(lin0, lin1, f_max=60.0):
    """Return the three modes below ``f_max`` that moved most from ``lin0`` to ``lin1`` and the new ones.

    Parameters
    ----------
    lin0 : LinearSystem or NonlinearSystem
        The model before the finding.
    lin1 : LinearSystem or NonlinearSystem
        The model with the finding.
    f_max : float, optional
        Highest mode considered (Hz; default 60). Modes below 1 Hz are left out.

    Returns
    -------
    tuple
        ``(pairs, new)``: up to three ``(before Hz, after Hz)`` pairs, largest relative shift first,
        and the modes of ``lin1`` (Hz) more than 3 % from every mode of ``lin0``.
    """
    f0, f1 = modes_hz(lin0), modes_hz(lin1)
    f0, f1 = f0[(f0 > 1.0) & (f0 < f_max)], f1[(f1 > 1.0) & (f1 < f_max)]
    pairs = []
    for a in f0:
        b = f1[np.argmin(np.abs(f1 - a))] if f1.size else a
        pairs.append((a, b))
    pairs.sort(key=lambda ab: -abs(ab[1] - ab[0]) / ab[0])
    new = [b for b in f1 if f0.size == 0 or np.min(np.abs(f0 - b)) / b > 0.03]
    return pairs[:3], new


def explain(h: Hypothesis, p, std, lin0, lin1, located) -> str:
    """Plain-language explanation of a finding: its registered ``explain`` callable, else a generic text.

    Parameters
    ----------
    h : Hypothesis
        The fitted hypothesis.
    p : array_like
        Fitted parameter values, shape (n_params,).
    std : array_like
        Standard deviation of each parameter, shape (n_params,).
    lin0 : LinearSystem or NonlinearSystem
        The model before the finding.
    lin1 : LinearSystem or NonlinearSystem
        The model with the finding.
    located : sequence of str
        Channels where the mismatch was located (the first six are named).

    Returns
    -------
    str
        The explanation.
    """
    v = {n: (float(a), float(s)) for n, a, s in zip(h.names, p, std, strict=True)}
    pairs, new = shifted_modes(lin0, lin1)
    shifts = ", ".join(f"{a:.2f} -> {b:.2f} Hz" for a, b in pairs if abs(b - a) > 0.005)
    where = ", ".join(located[:6]) + (", ..." if len(located) > 6 else "")
    if h.physics == "local_element":  # the generic element: no registered candidate
        return explain_local_element(h, p, std, getattr(h, "place", {}), getattr(h, "closest", ()))
    cand = RIG_CANDIDATES.get(h.physics)
    if cand is not None and cand.explain is not None:
        return str(cand.explain(h, v, ExplainContext(shifts=shifts, new_modes_hz=tuple(new), where=where)))
    values = ", ".join(f"{n} = {a:.3g} +- {s:.2g}" for n, (a, s) in v.items())
    place = "" if h.location is None else f" at {h.location}"
    return f"{h.physics}{place}: {values} ({shifts})."


#: the carriers of an unexplained residual hold this share of its coherent energy
CARRIER_SHARE = 0.8


def residual_carriers(cells, maps, share: float = CARRIER_SHARE) -> tuple:
    """Return the smallest set of channels and the narrowest band holding ``share`` of the residual.

    The coherent residual energy of a significant cell is its effect squared (largest over the
    recordings, :class:`~exudyn_study.diagnose.rig_compare.SignificanceMap`); channels are taken
    strongest first until they hold ``share`` of it, then the narrowest run of bands holding
    ``share`` of those channels' energy.

    Parameters
    ----------
    cells : numpy.ndarray of bool
        Significant cells, shape (n_channels, n_bands).
    maps : list of SignificanceMap
        The recordings' significance maps (their ``effect`` and ``significant``).
    share : float, optional
        Share of the coherent residual energy to hold (default :data:`CARRIER_SHARE`).

    Returns
    -------
    tuple
        ``(rows, (first band, last band))``: channel indices, strongest first, and band indices.
    """
    w = np.max([np.where(m.significant, m.effect, 0.0) ** 2 for m in maps], axis=0) * cells
    per_channel = w.sum(axis=1)
    order = [int(i) for i in np.argsort(-per_channel) if per_channel[i] > 0]
    total = float(per_channel.sum())
    rows, held = [], 0.0
    for i in order:
        rows.append(i)
        held += float(per_channel[i])
        if held >= share * total:
            break
    per_band = w[rows].sum(axis=0)
    need, best = share * float(per_band.sum()), (0, len(per_band) - 1)
    for j0 in range(len(per_band)):
        for j1 in range(j0, len(per_band)):
            if per_band[j0 : j1 + 1].sum() >= need:
                if j1 - j0 < best[1] - best[0]:
                    best = (j0, j1)
                break
    return rows, best


def unexplained_entry(cells, channels, level_dependent, text, maps=None, best_places=()):
    """Return the JSON entry of the significant residual ``cells`` (channel x band) left unexplained.

    With ``maps`` (the significance maps of the recordings) the entry names the smallest set of
    sensors and the band that carry :data:`CARRIER_SHARE` of the residual (:func:`residual_carriers`),
    all significant sensors besides; ``best_places``: (label, share explained) of the best candidates
    the last screening found, named in the text.

    Parameters
    ----------
    cells : numpy.ndarray of bool
        Significant cells left unexplained, shape (n_channels, n_bands of :data:`BANDS_HZ`).
    channels : sequence of str
        Channel name of each row of ``cells``.
    level_dependent : bool
        Whether the residual changes with the excitation level.
    text : str
        Closing sentence of the explanation (why nothing explains it).
    maps : list of SignificanceMap or None, optional
        The recordings' significance maps (None: all significant sensors and bands are named).
    best_places : sequence of tuple, optional
        ``(label, share explained)`` of the best candidates of the last screening (default none).

    Returns
    -------
    dict
        ``location``, ``band_hz``, ``level_dependent``, ``all_sensors``, ``best_places`` and
        ``explanation``.
    """
    rows = np.flatnonzero(cells.any(axis=1))
    cols = np.flatnonzero(cells.any(axis=0))
    sensors = [channels[i] for i in rows]
    band = [BANDS_HZ[cols[0]][0], BANDS_HZ[cols[-1]][1]]
    carriers = sensors
    if maps is not None:
        idx, (j0, j1) = residual_carriers(cells, maps)
        carriers, band = [channels[i] for i in idx], [BANDS_HZ[j0][0], BANDS_HZ[j1][1]]
    comps = sorted({sensor_component(s) or "?" for s in carriers})
    where = f"{', '.join(carriers[:8])}{', ...' if len(carriers) > 8 else ''}"
    text_all = (
        f" ({100 * CARRIER_SHARE:.0f} % of it; significant at {len(sensors)} sensor(s) in "
        f"{BANDS_HZ[cols[0]][0]:g}-{BANDS_HZ[cols[-1]][1]:g} Hz)"
        if maps is not None
        else ""
    )
    places = (
        "; best places the screen found: "
        + ", ".join(f"{lab} ({100 * sh:.0f} % of the residual)" for lab, sh in best_places[:3])
        if best_places
        else ""
    )
    return {
        "location": {
            "sensors": carriers,
            "component": comps[0] if len(comps) == 1 else None,
            "interface": None,
        },
        "band_hz": band,
        "level_dependent": bool(level_dependent),
        "all_sensors": sensors,
        "best_places": [{"candidate": lab, "share": round(float(sh), 4)} for lab, sh in best_places[:3]],
        "explanation": f"significant residual carried by {len(carriers)} sensor(s) ({where}) in "
        f"{band[0]:g}-{band[1]:g} Hz{text_all}{places}; {text}",
    }


def model_transmissibility(lin, freq, channels, sensor_names, gains=None):
    """Model transmissibility (sensor acceleration / drive acceleration) at ``freq``, (n_channels, n_f).

    Parameters
    ----------
    lin : LinearSystem or NonlinearSystem
        The model (a nonlinear one by its linear tangent).
    freq : numpy.ndarray
        Frequencies (Hz), shape (n_f,), none zero.
    channels : sequence of str
        Channels to return, in row order.
    sensor_names : sequence of str
        The model's sensor names, in the order of its outputs.
    gains : numpy.ndarray or OutputChain or None, optional
        Output gain per channel or a chain of acquisition stages (None: all one).

    Returns
    -------
    numpy.ndarray
        Complex transmissibility, shape (n_channels, n_f).
    """
    from exudyn_study.linear.response import frf_linear

    idx = [list(sensor_names).index(c) for c in channels]
    lin = getattr(lin, "lin", lin)  # a NonlinearSystem: its linear tangent (the figure says so)
    w2 = (2 * np.pi * np.asarray(freq)) ** 2
    h = frf_linear(lin, freq)[idx, 0, :] / (-w2[None, :])
    return apply_output_frf(h, gains, channels, freq)


def figures_before(figures, named, recs, sims, lin0, sensor_names, maps):
    """Residual map (model error power / noise power per bin), measured and nominal transmissibilities.

    Parameters
    ----------
    figures : dict
        Figure data, updated in place (``channels``, ``freq_hz``, ``labels``, ``levels``,
        ``residual_map``, ``bands_hz``, ``measured``, ``nominal_T``).
    named : sequence of tuple
        ``(name, recording)`` of each recording, training then held out.
    recs : list of RigRecording
        The prepared recordings, in the order of ``named``.
    sims : list of numpy.ndarray
        Simulations of the nominal model per recording, shape (n_channels, n_samples).
    lin0 : LinearSystem or NonlinearSystem
        The nominal model.
    sensor_names : sequence of str
        The model's sensor names, in the order of its outputs.
    maps : list of SignificanceMap
        The recordings' significance maps (unused: the map is recomputed per frequency bin).
    """
    k0 = 1000
    labels = [recording_label(n) for n, _ in named]
    rmaps, measured, levels = [], {}, []
    freq = None
    for lab, r, s in zip(labels, recs, sims, strict=True):
        u = r.drive.samples[k0:]
        res = drive_spectra(u, (r.measured - s)[:, k0:])
        meas = drive_spectra(u, r.measured[:, k0:])
        f = res.f
        band = (f >= 3.0) & (f <= 60.0)
        g2 = res.coherence
        rmaps.append((g2 / (1.0 - g2))[:, band])
        w2 = (2 * np.pi * f[band]) ** 2
        measured[lab] = meas.h1[:, band] / (-w2[None, :])
        freq = f[band]
        levels.append(float(np.std(np.gradient(np.gradient(u, 1e-3), 1e-3))))
    figures.update(
        channels=list(recs[0].channels),
        freq_hz=freq,
        labels=labels,
        levels=levels,
        residual_map=np.array(rmaps),
        bands_hz=[list(b) for b in BANDS_HZ],
        measured=measured,
    )
    figures["nominal_T"] = {
        lab: model_transmissibility(lin0, freq, r.channels, sensor_names)
        for lab, r in zip(labels, recs, strict=True)
    }
