"""Typed option dataclasses: validated once, and the source of their command-line flags.

A config is a frozen dataclass deriving :class:`Options`; each field declares its type,
default, help and allowed range with :func:`option`::

    @dataclass(frozen=True)
    class GeometricOptions(Options):
        goal_tolerance: float = option(
            0.01, help="metres from a goal that fill it", within=Interval(0, 0.1, low_open=True)
        )
        box_geometry: Literal["geometric", "physics"] | None = option(None, help="...")

Constructing one checks every field (type, choices of a ``Literal`` or ``Enum``, range) and
raises :class:`~manigraph_shared.errors.ConfigError` naming the field and what is allowed.
:func:`add_option_arguments` turns the fields into ``argparse`` flags (``goal_tolerance`` →
``--goal-tolerance``, type, default and help from the field, choices from the ``Literal`` or
``Enum``, a ``bool`` that defaults to False → a switch), :func:`options_from_args` reads them
back, and :func:`option_argv` writes options back as flags (to start another process with
them).
"""

from __future__ import annotations

import argparse
import dataclasses
import enum
import math
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar, Union

from manigraph_shared.errors import ConfigError

__all__ = [
    "Interval",
    "OptionField",
    "Options",
    "add_option_arguments",
    "flag_name",
    "option",
    "option_argv",
    "option_fields",
    "options_from_args",
]

OptionsT = TypeVar("OptionsT")


@dataclass(frozen=True)
class Interval:
    """The range a number may take: ``Interval(0, 0.1, low_open=True)`` is (0, 0.1]."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: object) -> bool:
        if not isinstance(value, int | float) or isinstance(value, bool) or math.isnan(value):
            return False
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        return self.high is None or (value < self.high if self.high_open else value <= self.high)

    def __str__(self) -> str:
        """``(0, 0.1]``, or ``>= 1`` / ``< 5`` when one side is open-ended."""
        if self.high is None and self.low is not None:
            return f"{'>' if self.low_open else '>='} {self.low:g}"
        if self.low is None and self.high is not None:
            return f"{'<' if self.high_open else '<='} {self.high:g}"
        low = "(-inf" if self.low is None else f"{'(' if self.low_open else '['}{self.low:g}"
        high = "inf)" if self.high is None else f"{self.high:g}{')' if self.high_open else ']'}"
        return f"{low}, {high}"

    def describe(self) -> str:
        """As said after "must be": ``in (0, 0.1]`` or ``>= 1``."""
        text = str(self)
        return text if text[0] in "<>" else f"in {text}"


def option(
    default: Any = dataclasses.MISSING,
    *,
    help: str,
    within: Interval | None = None,
    unit: str = "",
    flag: bool = True,
) -> Any:
    """A dataclass field of an :class:`Options` with its help text, allowed range (``within``)
    and unit (said in help and errors); ``flag=False`` keeps it off the command line."""
    metadata = {"help": help, "within": within, "unit": unit, "flag": flag}
    if isinstance(default, list | dict | set):
        raise TypeError("option: give a tuple, not a mutable default")
    return dataclasses.field(default=default, metadata=metadata)


@dataclass(frozen=True)
class OptionField:
    """One field of an options dataclass, with its resolved type."""

    name: str
    kind: Any  # the annotation without ``| None``
    optional: bool  # None is allowed
    default: Any  # dataclasses.MISSING when required
    help: str
    within: Interval | None
    unit: str
    flag: bool

    @property
    def choices(self) -> tuple[Any, ...] | None:
        if typing.get_origin(self.kind) is Literal:
            return typing.get_args(self.kind)
        if isinstance(self.kind, type) and issubclass(self.kind, enum.Enum):
            return tuple(member.value for member in self.kind)
        return None

    def allowed(self) -> str:
        """What the field accepts, for error messages."""
        choices = self.choices
        if choices is not None:
            text = "one of: " + ", ".join(str(c) for c in choices)
        else:
            text = _TYPE_WORDS.get(self.kind, getattr(self.kind, "__name__", str(self.kind)))
            if self.within is not None:
                text += f" {self.within.describe()}" + (f" {self.unit}" if self.unit else "")
        return text + (" (or unset)" if self.optional and self.default is None else "")

    def check(self, value: Any) -> Any:
        """``value`` converted to the field's type (a str to a Path, a list to a tuple, an
        Enum's value to the member); ``ConfigError`` naming the field if it does not fit."""
        if value is None and self.optional:
            return None
        converted = _convert(self.kind, value)
        if converted is _BAD:
            raise ConfigError(self.name, f"must be {self.allowed()}, got {value!r}")
        if self.within is not None and converted not in self.within:
            unit = f" {self.unit}" if self.unit else ""
            raise ConfigError(self.name, f"must be {self.within.describe()}{unit}, got {value!r}")
        return converted


_TYPE_WORDS: dict[Any, str] = {
    int: "an integer",
    float: "a number",
    bool: "true or false",
    str: "a string",
    Path: "a path",
}
_BAD = object()


def _convert(kind: Any, value: Any) -> Any:
    origin = typing.get_origin(kind)
    if kind is bool:
        return value if isinstance(value, bool) else _BAD
    if kind is int:
        return value if isinstance(value, int) and not isinstance(value, bool) else _BAD
    if kind is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        return _BAD
    if kind is str:
        return value if isinstance(value, str) else _BAD
    if kind is Path:
        return Path(value) if isinstance(value, str | Path) else _BAD
    if origin is Literal:
        return value if value in typing.get_args(kind) else _BAD
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        try:
            return kind(value)
        except ValueError:
            return _BAD
    if origin is tuple:
        args = typing.get_args(kind)
        if not isinstance(value, list | tuple) or len(args) != 2 or args[1] is not Ellipsis:
            return _BAD
        items = tuple(_convert(args[0], item) for item in value)
        return _BAD if any(item is _BAD for item in items) else items
    return value  # a type the options layer does not know: the dataclass checks it


def option_fields(config: type[Any]) -> list[OptionField]:
    """The fields of the options dataclass ``config``, types resolved (once per class)."""
    if config not in _FIELDS:
        _FIELDS[config] = tuple(_resolve_fields(config))
    return list(_FIELDS[config])


_FIELDS: dict[type[Any], tuple[OptionField, ...]] = {}


def _resolve_fields(config: type[Any]) -> list[OptionField]:
    if not dataclasses.is_dataclass(config):
        raise TypeError(f"{config!r} is not a dataclass")
    hints = typing.get_type_hints(config)
    fields = []
    for item in dataclasses.fields(config):
        if not item.init:
            continue
        kind, optional = _strip_none(hints[item.name])
        default = item.default
        if item.default_factory is not dataclasses.MISSING:
            default = item.default_factory()
        fields.append(
            OptionField(
                name=item.name,
                kind=kind,
                optional=optional,
                default=default,
                help=item.metadata.get("help", ""),
                within=item.metadata.get("within"),
                unit=item.metadata.get("unit", ""),
                flag=item.metadata.get("flag", True),
            )
        )
    return fields


def _strip_none(annotation: Any) -> tuple[Any, bool]:
    if typing.get_origin(annotation) in (Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        optional = len(args) < len(typing.get_args(annotation))
        return (args[0] if len(args) == 1 else Union[tuple(args)]), optional  # noqa: UP007
    return annotation, False


class Options:
    """Base of an options dataclass: every field is checked once, at construction."""

    def __post_init__(self) -> None:
        for item in option_fields(type(self)):
            value = getattr(self, item.name)
            checked = item.check(value)
            if checked is not value:
                object.__setattr__(self, item.name, checked)


def build_options(config: type[OptionsT], values: Mapping[str, Any], where: str = "") -> OptionsT:
    """``config(**values)``; an unknown name or a bad value raises ``ConfigError`` naming the
    field, prefixed with ``where`` (``backend.goal_tolerance``)."""
    prefix = f"{where}." if where else ""
    known = {item.name for item in option_fields(config)}
    for name in values:
        if name not in known:
            listed = ", ".join(sorted(known)) or "none"
            raise ConfigError(f"{prefix}{name}", f"unknown option (known: {listed})")
    missing = [i.name for i in option_fields(config) if i.default is dataclasses.MISSING]
    for name in missing:
        if name not in values:
            raise ConfigError(f"{prefix}{name}", "missing")
    try:
        return config(**values)
    except ConfigError as exc:
        raise ConfigError(f"{prefix}{exc.field}", exc.problem) from None


# --- flags --------------------------------------------------------------------------------------
def flag_name(field_name: str) -> str:
    return "--" + field_name.replace("_", "-")


def flag_kwargs(item: OptionField) -> dict[str, Any]:
    """``add_argument`` keyword arguments for one field (without default and help)."""
    if item.kind is bool:
        if item.default is True:
            return {"action": argparse.BooleanOptionalAction}
        return {"action": "store_true"}
    choices = item.choices
    if choices is not None:
        # An Enum is given by its value; the Options class turns the value into the member.
        return {"type": type(choices[0]), "choices": list(choices)}
    if typing.get_origin(item.kind) is tuple:
        return {"type": typing.get_args(item.kind)[0], "nargs": "+"}
    if item.kind in (int, float, str, Path):
        return {"type": item.kind}
    raise TypeError(f"option {item.name}: no command-line form for {item.kind!r}; flag=False")


def describe_default(value: Any) -> str:
    if isinstance(value, enum.Enum):
        return str(value.value)
    if isinstance(value, tuple):
        return " ".join(str(v) for v in value)
    return "unset" if value is None else str(value)


def add_option_arguments(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup,
    config: type[Any],
    *,
    defaults: Mapping[str, Any] | None = None,
    exclude: Iterable[str] = (),
) -> None:
    """One flag per field of ``config``, with its default (or ``defaults[name]``)."""
    defaults = dict(defaults or {})
    skip = set(exclude)
    for item in option_fields(config):
        if not item.flag or item.name in skip:
            continue
        default = defaults.get(item.name, item.default)
        required = default is dataclasses.MISSING
        text = item.help + (f", {item.unit}" if item.unit else "")
        if not required and item.kind is not bool and default is not None:
            text += f" (default: {describe_default(default)})"
        parser.add_argument(
            flag_name(item.name),
            dest=item.name,
            help=text,
            **({"required": True} if required else {"default": default}),
            **flag_kwargs(item),
        )


def options_from_args(
    config: type[OptionsT], args: argparse.Namespace, where: str = "", **values: Any
) -> OptionsT:
    """``config`` from the flags :func:`add_option_arguments` added (plus ``values``)."""
    names = {item.name for item in option_fields(config)}
    found = {name: getattr(args, name) for name in names if hasattr(args, name)}
    return build_options(config, {**found, **values}, where)


def option_argv(config: type[Any], values: Mapping[str, Any]) -> list[str]:
    """``values`` (some fields of ``config``) written back as command-line flags; a path is
    made absolute, since the process reading it may run elsewhere."""
    fields = {item.name: item for item in option_fields(config)}
    argv: list[str] = []
    for name, value in values.items():
        item = fields[name]
        if item.kind is bool:
            if value is not item.default:
                argv.append(flag_name(name) if value else "--no-" + flag_name(name)[2:])
        elif value is not None:
            if isinstance(value, Path):
                value = value.resolve()
            words = value if isinstance(value, tuple) else (value,)
            argv += [flag_name(name), *(describe_default(v) for v in words)]
    return argv
