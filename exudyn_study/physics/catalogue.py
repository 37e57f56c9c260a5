"""The physics catalogue: entries, their parameters and the registry.

A :class:`PhysicsEntry` is the DESIGN's *physics hypothesis*: ``name``, ``doc`` (which
physics it represents and which signature it leaves in recordings), ``parameters``
(:class:`Parameter` with unit and bounds), ``locations`` (what ``location`` means for it)
and ``apply(model, location, **params)``, which validates the parameters, fills in
defaults and calls the entry's ``add_items(model, location, params) -> dict`` to add the
Exudyn items to a not-yet-assembled model. ``apply`` returns an :class:`Applied` record
(entry, location, parameters, item numbers); it writes nothing into ``model.metadata``
(a truth model's physics must not leak into the recordings simulated from it).

Any object with the same attributes and ``apply`` satisfies :class:`Augmentation` and can
be registered; :class:`PhysicsEntry` is the convenient way to make one.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from exudyn_study.errors import InputError

__all__ = ["Parameter", "PhysicsEntry", "Augmentation", "Applied", "CATALOGUE", "register", "unregister",
           "entry"]


@dataclass(frozen=True)
class Parameter:
    """One parameter of a catalogue entry.

    Parameters
    ----------
    name : str
        Python identifier with the unit in the name where it is not SI-obvious
        (``mass_kg``, ``stiffness_n_per_m``).
    unit : str
        SI unit (``'kg'``, ``'N/m'``, ``'1'`` for dimensionless).
    lower, upper : float
        Inclusive bounds, ``lower <= upper``.
    default : float
        Within the bounds.
    description : str, optional
        One line.

    Raises
    ------
    InputError
        On non-finite or inverted bounds, or a default outside them.
    """

    name: str
    unit: str
    lower: float
    upper: float
    default: float
    description: str = ""

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise InputError(f"parameter name {self.name!r}: expected a Python identifier")
        lo, hi = float(self.lower), float(self.upper)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise InputError(f"parameter {self.name!r}: bounds [{self.lower!r}, {self.upper!r}]; "
                             "expected finite lower <= upper")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        object.__setattr__(self, "default", self.check(self.default, "default"))

    def check(self, value, owner: str = "") -> float:
        """``value`` as float if within the bounds, else InputError naming the parameter and bounds.

        Parameters
        ----------
        value : float
            Value to check, in the parameter's ``unit``.
        owner : str, default ""
            Name prefixed to the error message (for example the entry's name); empty for none.

        Returns
        -------
        float
            ``value`` as a float.

        Raises
        ------
        InputError
            If ``value`` is not a finite number within ``[lower, upper]``.
        """
        who = f"{owner}: " if owner else ""
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = math.nan
        if not (math.isfinite(v) and self.lower <= v <= self.upper):
            raise InputError(f"{who}parameter {self.name} = {value!r} {self.unit}; expected a value in "
                             f"[{self.lower:g}, {self.upper:g}] {self.unit}")
        return v


@dataclass(frozen=True)
class Applied:
    """What :meth:`PhysicsEntry.apply` added to a model.

    Attributes
    ----------
    name : str
        Catalogue entry.
    location : str or None
    parameters : mapping name -> float (SI, defaults filled in)
    items : mapping label -> Exudyn item number (objects, nodes, markers it added or changed)
    """

    name: str
    location: str | None
    parameters: Mapping[str, float]
    items: Mapping[str, int] = field(default_factory=dict)

    def describe(self) -> str:
        """One line, e.g. ``added_mass at ARFVZ: mass_kg=5 kg``."""
        values = ", ".join(f"{k}={v:g}" for k, v in self.parameters.items())
        return f"{self.name} at {self.location}: {values}"


@runtime_checkable
class Augmentation(Protocol):
    """What the catalogue needs of an entry (structural: any class with these members)."""

    name: str
    doc: str
    parameters: tuple
    locations: str

    def apply(self, model, location=None, **params) -> Applied:
        """Add the entry's Exudyn items to ``model`` (not yet assembled) at ``location``.

        Parameters
        ----------
        model : object
            Rig model whose Exudyn system is not yet assembled.
        location : str, optional
            Where the entry acts, as described by the entry's ``locations`` (None: the entry's
            default).
        **params
            Values of the entry's parameters by name, in their units.

        Returns
        -------
        Applied
            The added items.
        """
        ...


@dataclass(frozen=True)
class PhysicsEntry:
    """A physics hypothesis of the catalogue.

    Parameters
    ----------
    name : str
        Catalogue name (identifier).
    doc : str
        Which physics it represents and which signature it leaves in recordings.
    parameters : tuple of Parameter
    add_items : callable ``(model, location, params: dict) -> dict label -> item number``
        Adds the Exudyn items; ``params`` are validated and complete.
    locations : str
        What ``location`` may be for this entry (shown in errors and listings).
    check_location : callable ``(model, location) -> str | None``, optional
        Validates/normalises ``location`` (raises InputError naming the accepted ones).
    """

    name: str
    doc: str
    parameters: tuple
    add_items: Callable[[Any, Any, dict], dict]
    locations: str = ""
    check_location: Callable[[Any, Any], Any] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise InputError(f"physics entry name {self.name!r}: expected an identifier")
        if not self.doc or not self.doc.strip():
            raise InputError(f"physics entry {self.name!r}: a docstring (physics and signature) is required")
        params = tuple(self.parameters)
        if not all(isinstance(p, Parameter) for p in params):
            raise InputError(f"physics entry {self.name!r}: parameters must be Parameter objects")
        names = [p.name for p in params]
        if len(set(names)) != len(names):
            raise InputError(f"physics entry {self.name!r}: repeated parameter names {names}")
        object.__setattr__(self, "parameters", params)

    def parameter(self, name: str) -> Parameter:
        """Return the parameter called ``name`` (InputError listing the known ones).

        Parameters
        ----------
        name : str
            Name of the parameter.

        Returns
        -------
        Parameter
            The entry's parameter called ``name``.

        Raises
        ------
        InputError
            If the entry has no parameter called ``name``.
        """
        for p in self.parameters:
            if p.name == name:
                return p
        raise InputError(f"physics entry {self.name!r} has no parameter {name!r}; it has "
                         f"{[p.name for p in self.parameters]}")

    @property
    def defaults(self) -> dict[str, float]:
        """Parameter name -> default."""
        return {p.name: p.default for p in self.parameters}

    def resolve(self, **params) -> dict[str, float]:
        """Return validated parameters with defaults filled in (InputError on unknown or out-of-bounds)."""
        unknown = sorted(set(params) - {p.name for p in self.parameters})
        if unknown:
            raise InputError(f"physics entry {self.name!r}: unknown parameter(s) {unknown}; expected "
                             f"{[f'{p.name} [{p.unit}]' for p in self.parameters]}")
        return {p.name: p.check(params.get(p.name, p.default), self.name) for p in self.parameters}

    def apply(self, model, location=None, **params) -> Applied:
        """Add this physics to ``model`` at ``location``.

        Parameters
        ----------
        model : exudyn_study.model.Model
            Not yet assembled.
        location : str or None
            See :attr:`locations`.
        **params : float
            Parameter values in the units of :attr:`parameters` (missing ones: defaults).

        Returns
        -------
        Applied

        Raises
        ------
        InputError
            Assembled model, unknown parameter, value out of bounds, bad location.
        """
        if getattr(model, "assembled", False):
            raise InputError(f"physics entry {self.name!r}: the model is already assembled; apply physics "
                             "before model.assemble()")
        values = self.resolve(**params)
        if self.check_location is not None:
            location = self.check_location(model, location)
        items = self.add_items(model, location, values)
        return Applied(self.name, location, types.MappingProxyType(values),
                       types.MappingProxyType(dict(items or {})))


_REGISTRY: dict[str, Augmentation] = {}
#: read-only view name -> entry of everything registered (built-ins and user entries)
CATALOGUE: Mapping[str, Augmentation] = types.MappingProxyType(_REGISTRY)


def register(new: Augmentation, replace: bool = False) -> Augmentation:
    """Add ``new`` to the catalogue (under ``new.name``) and return it.

    Parameters
    ----------
    new : Augmentation
        Entry to add; it has ``name``, ``doc``, ``parameters``, ``locations`` and ``apply``.
    replace : bool, default False
        Whether to replace an entry already registered under the same name.

    Returns
    -------
    Augmentation
        ``new``.

    Raises
    ------
    InputError
        If it does not satisfy :class:`Augmentation`, or the name is taken and ``replace`` is False.
    """
    if not isinstance(new, Augmentation):
        raise InputError(f"register: {new!r} is not a physics entry (needs name, doc, parameters, locations "
                         "and apply(model, location, **params))")
    if new.name in _REGISTRY and not replace:
        raise InputError(f"register: physics entry {new.name!r} is already in the catalogue; "
                         "pass replace=True")
    _REGISTRY[new.name] = new
    return new


def unregister(name: str) -> None:
    """Remove ``name`` from the catalogue (InputError if unknown).

    Parameters
    ----------
    name : str
        Name of the catalogue entry to remove.

    Raises
    ------
    InputError
        If no entry is registered under ``name``.
    """
    entry(name)
    del _REGISTRY[name]


def entry(name: str) -> Augmentation:
    """Return the catalogue entry called ``name`` (InputError listing the known names).

    Parameters
    ----------
    name : str
        Name of the catalogue entry.

    Returns
    -------
    Augmentation
        The registered entry.

    Raises
    ------
    InputError
        If no entry is registered under ``name``.
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        known = sorted(_REGISTRY)
        raise InputError(f"physics entry {name!r} is unknown; the catalogue has {known}") from None
