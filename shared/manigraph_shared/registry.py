"""One registry for every part that gets swapped: sim backends, tasks, robot drivers, policies,
GNN architectures, batch layouts, training recipes.

An entry is a name, the thing registered (a class, a factory, an instance) and the options
dataclass it is configured with (:mod:`manigraph_shared.options`), or None when it takes no
options::

    BACKENDS: Registry[Callable[[Any], SimBackend]] = Registry("backend")

    @BACKENDS.register("geometric", options=GeometricOptions, help="the fast block world")
    class GeometricBackend(SimBackend): ...

    BACKENDS.add_lazy("physics", "manigraph_sim.physics.backend:PhysicsBackend",
                      options=PhysicsOptions)   # imported only when used

    backend_cls = BACKENDS["geometric"]                      # ConfigError naming the choices
    options = BACKENDS.options("geometric", {"goal_tolerance": 0.02})

The registry refuses a second entry under a name, an unknown name, an option the entry does
not have and a value outside its range, always with one error type,
:class:`~manigraph_shared.errors.ConfigError`, whose ``field`` says what was wrong
(``backend``, ``backend.goal_tolerance``). :meth:`Registry.add_arguments` adds the flags of
every entry's options to a parser (each flag once; the help says which entries take it and
with which default), :meth:`Registry.options_from_args` builds the chosen entry's options from
them and refuses a flag the chosen entry does not take.
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar, cast

from manigraph_shared.errors import ConfigError
from manigraph_shared.options import (
    OptionField,
    build_options,
    describe_default,
    flag_kwargs,
    flag_name,
    option_argv,
    option_fields,
)

__all__ = ["Entry", "Registry", "import_target"]

T = TypeVar("T")
S = TypeVar("S")


def import_target(path: str) -> Any:
    """The object ``"module:attribute"`` names, its module imported on first use."""
    module, _, attribute = path.partition(":")
    return getattr(importlib.import_module(module), attribute)


@dataclass
class Entry(Generic[T]):
    """One registered part: ``target`` is the object, or ``"module:attribute"`` to import
    when first used (so listing a registry stays cheap)."""

    name: str
    target: T | str
    options: type[Any] | None = None
    help: str = ""
    _loaded: T | None = field(default=None, repr=False)

    def load(self) -> T:
        if self._loaded is None:
            if isinstance(self.target, str):
                self._loaded = cast(T, import_target(self.target))
            else:
                self._loaded = self.target
        return self._loaded

    def option_fields(self) -> list[OptionField]:
        return option_fields(self.options) if self.options is not None else []


class Registry(Generic[T]):
    """Named parts of one kind (``kind`` names them in errors: ``backend``, ``driver``)."""

    def __init__(self, kind: str, *, fill: Callable[[], None] | None = None) -> None:
        """``fill``: called once, before the registry is first read, to register what others
        declare (a service's task families: ``manigraph_shared.family_packages``)."""
        self.kind = kind
        self._entries: dict[str, Entry[T]] = {}
        self._fill = fill

    def fill_with(self, fill: Callable[[], None]) -> None:
        """Call ``fill`` once, before the registry is next read (after any fill set before):
        a module that fills this registry from another declares so where it is imported."""
        before = self._fill

        def both() -> None:
            if before is not None:
                before()
            fill()

        self._fill = both

    def _filled(self) -> dict[str, Entry[T]]:
        """The entries, after the one call of ``fill`` (registering during it reads what is
        there so far)."""
        fill, self._fill = self._fill, None
        if fill is not None:
            fill()
        return self._entries

    # --- registering ----------------------------------------------------------------------------
    def add(
        self, name: str, target: T | str, *, options: type[Any] | None = None, help: str = ""
    ) -> Entry[T]:
        """Register ``target`` (or its ``"module:attribute"``) under ``name``."""
        if not name:
            raise ConfigError(self.kind, "a registered name must not be empty")
        if name in self._entries:
            raise ConfigError(self.kind, f"'{name}' is already registered")
        if options is not None:
            option_fields(options)  # a TypeError now if it is not an options dataclass
        entry = Entry(name, target, options, help)
        self._entries[name] = entry
        return entry

    def add_lazy(
        self, name: str, path: str, *, options: type[Any] | None = None, help: str = ""
    ) -> Entry[T]:
        """Register ``"module:attribute"``, imported when the entry is first used."""
        if ":" not in path:
            raise ConfigError(self.kind, f"'{path}' is not 'module:attribute'")
        return self.add(name, path, options=options, help=help)

    def register(
        self, name: str, *, options: type[Any] | None = None, help: str = ""
    ) -> Callable[[S], S]:
        """Decorator form of :meth:`add`; a registered class gets ``name`` as its ``name``."""

        def decorate(target: S) -> S:
            self.add(name, cast(T, target), options=options, help=help)
            if isinstance(target, type):
                target.name = name  # type: ignore[attr-defined]
            return target

        return decorate

    # --- looking up -------------------------------------------------------------------------------
    def entry(self, name: str) -> Entry[T]:
        entry = self._filled().get(name)
        if entry is None:
            known = ", ".join(self._entries) or "nothing registered"
            raise ConfigError(self.kind, f"'{name}' is not one of: {known}")
        return entry

    def __getitem__(self, name: str) -> T:
        return self.entry(name).load()

    def check(self, name: str) -> str:
        """``name`` if it is registered; else ``ConfigError`` naming the choices."""
        return self.entry(name).name

    def get(self, name: str) -> T | None:
        return self[name] if name in self._filled() else None

    def __contains__(self, name: object) -> bool:
        return name in self._filled()

    def __iter__(self) -> Iterator[str]:
        return iter(self._filled())

    def __len__(self) -> int:
        return len(self._filled())

    def names(self) -> list[str]:
        return list(self._filled())

    def items(self) -> Iterator[tuple[str, T]]:
        for name, entry in list(self._filled().items()):
            yield name, entry.load()

    # --- options ----------------------------------------------------------------------------------
    def options(self, name: str, values: Mapping[str, Any] | None = None) -> Any:
        """The options of entry ``name`` from ``values`` (defaults for what is missing), or
        None if it takes none; ``ConfigError`` naming ``<kind>.<field>`` otherwise."""
        entry = self.entry(name)
        values = dict(values or {})
        if entry.options is None:
            if values:
                first = next(iter(values))
                raise ConfigError(f"{self.kind}.{first}", f"'{name}' takes no options")
            return None
        known = {item.name for item in entry.option_fields()}
        for key in values:
            if key not in known and key in self._all_option_names():
                listed = ", ".join(sorted(known)) or "none"
                raise ConfigError(
                    f"{self.kind}.{key}", f"not an option of {self.kind} '{name}' (its: {listed})"
                )
        return build_options(entry.options, values, self.kind)

    def _all_option_names(self) -> set[str]:
        entries = self._filled().values()
        return {item.name for entry in entries for item in entry.option_fields()}

    def add_arguments(
        self, parser: argparse.ArgumentParser | argparse._ArgumentGroup, *, only: str = ""
    ) -> None:
        """One flag per option of every entry (or of entry ``only``). A flag that is not
        given stays out of the namespace, so the chosen entry's own default applies."""
        flags: dict[str, tuple[OptionField, list[tuple[str, Any]]]] = {}
        for entry in self._filled().values():
            if only and entry.name != only:
                continue
            for item in entry.option_fields():
                if not item.flag:
                    continue
                seen = flags.setdefault(item.name, (item, []))
                if flag_kwargs(seen[0]) != flag_kwargs(item):
                    raise ConfigError(
                        f"{self.kind}.{item.name}",
                        f"'{entry.name}' declares it with another type than the others",
                    )
                seen[1].append((entry.name, item.default))
        for name, (item, users) in flags.items():
            parser.add_argument(
                flag_name(name),
                dest=name,
                default=argparse.SUPPRESS,
                help=self._flag_help(item, users),
                **flag_kwargs(item),
            )

    def _flag_help(self, item: OptionField, users: list[tuple[str, Any]]) -> str:
        """The field's help, then which entries take the flag (unless all do) and their
        defaults (one if they agree; none for a switch or an unset default)."""
        notes = []
        if len(users) < len(self._entries) or len(self._entries) == 1:
            notes.append(", ".join(user for user, _ in users) + " only")
        defaults = [default for _, default in users]
        if item.kind is not bool and any(d is not None for d in defaults):
            if all(d == defaults[0] for d in defaults):
                notes.append(f"default: {describe_default(defaults[0])}")
            else:
                listed = ", ".join(f"{u} {describe_default(d)}" for u, d in users)
                notes.append(f"default: {listed}")
        text = item.help + (f", {item.unit}" if item.unit else "")
        return f"{text} ({'; '.join(notes)})" if notes else text

    def given_options(self, args: argparse.Namespace) -> dict[str, Any]:
        """The options flags :meth:`add_arguments` added that were given on the command line."""
        return {
            name: getattr(args, name) for name in self._all_option_names() if hasattr(args, name)
        }

    def options_from_args(self, name: str, args: argparse.Namespace) -> Any:
        """Entry ``name``'s options from the flags of :meth:`add_arguments`."""
        return self.options(name, self.given_options(args))

    def argv(self, name: str, values: Mapping[str, Any]) -> list[str]:
        """``values`` (checked as entry ``name``'s options) as command-line flags, to forward
        them to the process that runs the entry."""
        self.options(name, values)
        entry = self.entry(name)
        return option_argv(entry.options, values) if entry.options is not None else []

    def describe(self) -> str:
        """``name: help`` per entry, for a flag's help."""
        return "; ".join(
            f"{e.name}: {e.help}" if e.help else e.name for e in self._filled().values()
        )
