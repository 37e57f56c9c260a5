"""The model a rig diagnosis fitted, rebuilt from its JSON.

:func:`~exudyn_study.diagnose.rig.diagnose_rig` writes into the diagnosis's metadata what its
findings put into the model: ``model_entries`` (per finding the catalogue entry, the location
argument it was applied at and its parameter values in the entry's units) and ``output_gains``
(per channel the sensor gain found, 1 where none). :func:`apply_diagnosis` applies them to a
freshly built model of the same variant, so that any later study (the damage grid's
``diagnosed`` column) runs the fitted model, not only the diagnosis itself.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

from exudyn_study.diagnose.schema import Diagnosis, read_json
from exudyn_study.errors import InputError

__all__ = ["apply_diagnosis", "load_diagnosis", "diagnosis_variant"]


def load_diagnosis(source: Diagnosis | Mapping | str | os.PathLike) -> Diagnosis:
    """Return a :class:`Diagnosis` from a diagnosis, its dict or its JSON file.

    Parameters
    ----------
    source : Diagnosis, mapping or path-like
        A diagnosis, its ``to_dict()`` form, or the JSON file ``exudyn-study diagnose`` wrote.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        A missing or malformed file, or a diagnosis without ``model_entries`` in its metadata
        (written by a version of the diagnosis that did not record them: run it again).
    """
    if isinstance(source, Diagnosis):
        d = source
    elif isinstance(source, Mapping):
        d = Diagnosis.from_dict(source)
    else:
        d = read_json(source)
    if d.mismatch_found and "model_entries" not in d.metadata:
        raise InputError(
            "diagnosis: its metadata lacks 'model_entries' (what the findings put into the model); "
            "run exudyn-study diagnose again to rebuild the fitted model from it"
        )
    return d


def diagnosis_variant(diagnosis: Diagnosis) -> int | None:
    """Return the rig model variant the diagnosis was made on (None: not a rig diagnosis).

    Parameters
    ----------
    diagnosis : Diagnosis
        A diagnosis; its metadata's ``model`` names the variant (1, 2 or 3) on the rig path.

    Returns
    -------
    int or None
    """
    v = diagnosis.metadata.get("model")
    return int(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def apply_diagnosis(model, diagnosis: Diagnosis | Mapping | str | os.PathLike, exclude=()):
    """Apply a rig diagnosis's findings to ``model`` (built, not yet assembled).

    Parameters
    ----------
    model : exudyn_study.model.Model
        A model of the variant the diagnosis was made on, not assembled.
    diagnosis : Diagnosis, mapping or path
        The diagnosis (``exudyn-study diagnose --json``).
    exclude : sequence of str
        Catalogue entries not to apply, e.g. ``('modal_damping',)`` when the bodies' modal
        damping is set otherwise (a ``modal_damping`` finding scales the damping the diagnosis
        was run with).

    Returns
    -------
    exudyn_study.model.Model
        ``model`` with every catalogue entry of the findings added and the sensor gains found
        multiplied into ``model.output_gains``.

    Raises
    ------
    InputError
        Another model variant than the diagnosis's, an assembled model, a malformed entry.
    """
    from exudyn_study.physics.catalogue import entry

    d = load_diagnosis(diagnosis)
    variant = diagnosis_variant(d)
    if variant is not None and getattr(model, "variant", variant) != variant:
        raise InputError(f"diagnosis of model {variant} cannot be applied to model {model.variant}")
    if getattr(model, "assembled", False):
        raise InputError("apply_diagnosis: the model is assembled already; apply the findings before "
                         "assemble()")
    for k, e in enumerate(d.metadata.get("model_entries") or []):
        if not isinstance(e, Mapping) or not {"physics", "location", "values"} <= set(e):
            raise InputError(f"diagnosis model_entries[{k}] = {e!r}; expected physics, location, values")
        if str(e["physics"]) not in exclude:
            entry(str(e["physics"])).apply(model, e["location"], **dict(e["values"]))
    gains = getattr(model, "output_gains", None)
    for channel, g in (d.metadata.get("output_gains") or {}).items():
        if g is None or not math.isfinite(float(g)) or float(g) <= 0:
            raise InputError(f"diagnosis output gain of {channel!r} = {g!r}; expected a finite value > 0")
        if float(g) != 1.0 and gains is not None:
            gains[channel] = float(gains.get(channel, 1.0)) * float(g)
    model.metadata["diagnosis"] = "; ".join(f.physics for f in d.findings) or "no finding"
    return model
