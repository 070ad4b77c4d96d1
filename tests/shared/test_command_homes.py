"""One home per command (issue #50, item 6): every ``manigraph`` subcommand is the ``command`` of
``<package>/commands/<verb>.py``, and no module of a package's ``commands/`` shares its name
with a module elsewhere in that package (``replay.py`` beside ``commands/replay.py`` was two
things of one name)."""

from __future__ import annotations

import importlib.util
import shutil
from collections.abc import Sequence
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from manigraph_shared.cli import GROUP, Command

#: Packages whose commands have not moved to ``commands/<verb>.py`` yet; a package leaves the
#: list when they have (empty: every command is at home).
NOT_YET_MOVED: frozenset[str] = frozenset()


def _package(value: str) -> str:
    """The top-level package of the entry point ``value`` (``module.path:attribute``)."""
    return value.split(":", 1)[0].split(".", 1)[0]


def home(name: str, value: str) -> str:
    """Where the command ``name`` of the entry point ``value`` belongs."""
    return f"{_package(value)}.commands.{name.replace('-', '_')}:command"


def homeless(entries: Sequence[tuple[str, str]], pending: frozenset[str]) -> list[str]:
    """A line per command away from its home, in a package not in ``pending``; and a line per
    package of ``pending`` whose commands are all at home (it should leave the list)."""
    problems = []
    moved = set(pending) & {_package(value) for _, value in entries}
    for name, value in entries:
        if value == home(name, value):
            continue
        if _package(value) in pending:
            moved.discard(_package(value))
        else:
            problems.append(f"{name}: {value} is not {home(name, value)}")
    for package in sorted(moved):
        problems.append(f"{package}: every command is at home; drop it from NOT_YET_MOVED")
    return problems


def modules_of(folder: Path) -> set[str]:
    """The names of the modules directly in ``folder``: its ``.py`` files and its packages."""
    names = {path.stem for path in folder.glob("*.py") if path.stem != "__init__"}
    return names | {path.name for path in folder.iterdir() if (path / "__init__.py").is_file()}


def twins(package: Path) -> list[str]:
    """A line per module of ``package/commands/`` whose name a module elsewhere in ``package``
    also has (at any depth)."""
    commands = package / "commands"
    if not commands.is_dir():
        return []
    elsewhere: dict[str, Path] = {}
    for folder in [package, *(p.parent for p in package.rglob("__init__.py"))]:
        if folder == commands or commands in folder.parents:
            continue
        for name in modules_of(folder):
            elsewhere.setdefault(name, folder / name)
    return [
        f"{package.name}.commands.{name} and {elsewhere[name].relative_to(package.parent)}"
        for name in sorted(modules_of(commands) & set(elsewhere))
    ]


def _installed() -> list[tuple[str, str]]:
    return [(entry.name, entry.value) for entry in entry_points(group=GROUP)]


def _folder(package: str) -> Path:
    spec = importlib.util.find_spec(package)
    assert spec is not None and spec.submodule_search_locations, package
    return Path(next(iter(spec.submodule_search_locations)))


def test_every_command_lives_in_its_packages_commands_folder() -> None:
    entries = _installed()
    assert {"router", "replay", "demos", "eval", "improve", "sim", "skills"} <= {
        name for name, _ in entries
    }
    assert homeless(entries, NOT_YET_MOVED) == []


def test_each_moved_command_is_a_command_object() -> None:
    for entry in entry_points(group=GROUP):
        if _package(entry.value) not in NOT_YET_MOVED:
            assert isinstance(entry.load(), Command), entry.value


def test_no_command_module_shares_a_name_with_another_module_of_its_package() -> None:
    packages = sorted({_package(value) for _, value in _installed()})
    assert [line for package in packages for line in twins(_folder(package))] == []


def test_a_command_away_from_home_is_named() -> None:
    planted = [
        ("replay", "manigraph_tools.replay:replay_command"),
        ("demo-ui", "manigraph_tools.commands.demo_ui:command"),
        ("train", "manigraph_planner.train_command:command"),
    ]
    assert homeless(planted, frozenset({"manigraph_planner"})) == [
        "replay: manigraph_tools.replay:replay_command is not "
        "manigraph_tools.commands.replay:command"
    ]


def test_a_package_whose_commands_have_moved_must_leave_the_waiting_list() -> None:
    moved = [("planner", "manigraph_planner.commands.planner:command")]
    assert homeless(moved, frozenset({"manigraph_planner"})) == [
        "manigraph_planner: every command is at home; drop it from NOT_YET_MOVED"
    ]


@pytest.mark.parametrize(
    ("planted", "twin"),
    [
        ("replay.py", "manigraph_tools/replay"),
        ("interop/demo_ui.py", "manigraph_tools/interop/demo_ui"),
        ("status/__init__.py", "manigraph_tools/status"),
    ],
)
def test_a_twin_planted_in_a_copy_of_the_tools_is_found(
    tmp_path: Path, planted: str, twin: str
) -> None:
    copy = tmp_path / "manigraph_tools"
    shutil.copytree(_folder("manigraph_tools"), copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert twins(copy) == []
    (copy / planted).parent.mkdir(parents=True, exist_ok=True)
    (copy / planted).write_text("")
    verb = Path(twin).name
    assert twins(copy) == [f"manigraph_tools.commands.{verb} and {twin}"]
