"""The one registry: names, options validated with field-named errors, generated flags."""

from __future__ import annotations

import argparse
import enum
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.options import (
    Interval,
    Options,
    add_option_arguments,
    option,
    option_argv,
    options_from_args,
)
from manigraph_shared.registry import Registry


class Mode(enum.Enum):
    FAST = "fast"
    SAFE = "safe"


@dataclass(frozen=True)
class ArmOptions(Options):
    speed: float = option(0.5, help="fraction of top speed", within=Interval(0, 1, low_open=True))
    video: Path | None = option(None, help="write a video here")
    realtime: bool = option(False, help="run in real time")
    mode: Mode = option(Mode.SAFE, help="how to move")
    grip: Literal["soft", "hard"] = option("soft", help="grip force")


@dataclass(frozen=True)
class GripperOptions(Options):
    speed: float = option(1.0, help="fraction of top speed", within=Interval(0, 1, low_open=True))
    retries: int = option(2, help="attempts per grasp", within=Interval(0, 5))


def drivers() -> Registry[type]:
    registry: Registry[type] = Registry("driver")

    @registry.register("arm", options=ArmOptions, help="a whole arm")
    class Arm:
        pass

    registry.add("gripper", dict, options=GripperOptions)
    registry.add("bare", list)
    return registry


def test_lookup_by_name_and_the_class_learns_its_name() -> None:
    registry = drivers()
    assert registry["gripper"] is dict
    assert registry["arm"].name == "arm"  # type: ignore[attr-defined]
    assert list(registry) == ["arm", "gripper", "bare"]
    assert "arm" in registry and "wheel" not in registry and len(registry) == 3


def test_duplicate_name_refused() -> None:
    registry = drivers()
    with pytest.raises(ConfigError, match="'arm' is already registered") as info:
        registry.add("arm", set)
    assert info.value.field == "driver"


def test_unknown_name_refused_naming_the_choices() -> None:
    with pytest.raises(ConfigError, match="'wheel' is not one of: arm, gripper, bare") as info:
        drivers()["wheel"]
    assert info.value.field == "driver"


def test_lazy_entry_imported_on_first_use() -> None:
    registry: Registry[object] = Registry("thing")
    registry.add_lazy("join", "os.path:join")
    import os.path

    assert registry["join"] is os.path.join
    with pytest.raises(ConfigError, match="module:attribute"):
        registry.add_lazy("bad", "os.path.join")


def test_options_defaults_and_conversion() -> None:
    registry = drivers()
    options = registry.options("arm", {"video": "out.gif", "mode": "fast"})
    assert options == ArmOptions(speed=0.5, video=Path("out.gif"), mode=Mode.FAST)
    assert registry.options("bare") is None


def test_unknown_option_refused_naming_the_field() -> None:
    registry = drivers()
    with pytest.raises(ConfigError) as info:
        registry.options("arm", {"spede": 0.3})
    assert info.value.field == "driver.spede"
    assert "unknown option" in info.value.problem and "speed" in info.value.problem
    # an option of another entry: the error says whose options these are
    with pytest.raises(ConfigError, match="not an option of driver 'gripper'") as info:
        registry.options("gripper", {"realtime": True})
    assert info.value.field == "driver.realtime"
    with pytest.raises(ConfigError, match="'bare' takes no options") as info:
        registry.options("bare", {"speed": 1.0})
    assert info.value.field == "driver.speed"


@pytest.mark.parametrize(
    ("values", "field", "allowed"),
    [
        ({"speed": 0.0}, "driver.speed", "must be in (0, 1], got 0.0"),
        ({"speed": 1.5}, "driver.speed", "must be in (0, 1], got 1.5"),
        ({"speed": "fast"}, "driver.speed", "must be a number in (0, 1], got 'fast'"),
        ({"mode": "reckless"}, "driver.mode", "must be one of: fast, safe"),
        ({"grip": "firm"}, "driver.grip", "must be one of: soft, hard"),
        ({"realtime": "yes"}, "driver.realtime", "must be true or false"),
    ],
)
def test_bad_value_refused_naming_field_and_allowed_range(
    values: dict[str, object], field: str, allowed: str
) -> None:
    with pytest.raises(ConfigError) as info:
        drivers().options("arm", values)
    assert info.value.field == field
    assert allowed in info.value.problem


def test_constructing_options_directly_is_validated_too() -> None:
    with pytest.raises(ConfigError, match="retries: must be in \\[0, 5\\], got 9"):
        GripperOptions(retries=9)
    with pytest.raises(ConfigError, match="retries: must be an integer in \\[0, 5\\], got True"):
        GripperOptions(retries=True)  # a bool is not a count


def test_flags_generated_with_defaults_help_and_choices() -> None:
    parser = argparse.ArgumentParser()
    drivers().add_arguments(parser)
    text = parser.format_help()
    flags = {a.dest: a for a in parser._actions}
    assert set(flags) >= {"speed", "video", "realtime", "mode", "grip", "retries"}
    assert flags["mode"].choices == ["fast", "safe"]
    assert flags["grip"].choices == ["soft", "hard"]
    # --speed is shared by two entries with their own defaults; the help names both
    assert "fraction of top speed (arm, gripper only; default: arm 0.5, gripper 1.0)" in " ".join(
        text.split()
    )
    assert "run in real time (arm only)" in " ".join(text.split())


def test_flag_of_another_entry_refused_and_defaults_kept() -> None:
    registry = drivers()
    parser = argparse.ArgumentParser()
    registry.add_arguments(parser)
    args = parser.parse_args([])
    assert registry.options_from_args("gripper", args) == GripperOptions()  # its own defaults
    args = parser.parse_args(["--realtime"])
    with pytest.raises(ConfigError, match="not an option of driver 'gripper'"):
        registry.options_from_args("gripper", args)
    with pytest.raises(SystemExit):  # argparse itself refuses a value outside the choices
        parser.parse_args(["--mode", "reckless"])


def test_round_trip_args_to_options_to_argv() -> None:
    registry = drivers()
    parser = argparse.ArgumentParser()
    registry.add_arguments(parser)
    argv = ["--speed", "0.25", "--realtime", "--mode", "fast", "--video", "v.gif"]
    args = parser.parse_args(argv)
    options = registry.options_from_args("arm", args)
    assert options == ArmOptions(speed=0.25, video=Path("v.gif"), realtime=True, mode=Mode.FAST)
    forwarded = registry.argv("arm", registry.given_options(args))
    again = registry.options_from_args("arm", parser.parse_args(forwarded))
    assert again == ArmOptions(
        speed=0.25, video=Path("v.gif").resolve(), realtime=True, mode=Mode.FAST
    )


@dataclass(frozen=True)
class EpisodeOptions(Options):
    task: str = option("stack", help="task name")
    blocks: int = option(4, help="blocks per stack", within=Interval(1, 100))
    episodes: int | None = option(None, help="episodes to run")
    feature_scale: tuple[float, ...] = option((1.0, 1.0), help="multipliers")


def test_single_options_class_flags_round_trip() -> None:
    parser = argparse.ArgumentParser()
    add_option_arguments(parser, EpisodeOptions, defaults={"episodes": 100}, exclude=["task"])
    args = parser.parse_args(["--blocks", "6", "--feature-scale", "2", "3"])
    assert not hasattr(args, "task")
    options = options_from_args(EpisodeOptions, args, task="pyramid")
    assert options == EpisodeOptions("pyramid", 6, 100, (2.0, 3.0))
    assert "blocks per stack (default: 4)" in parser.format_help()
    with pytest.raises(ConfigError, match="blocks: must be in \\[1, 100\\], got 0"):
        options_from_args(EpisodeOptions, parser.parse_args(["--blocks", "0"]))
    assert option_argv(EpisodeOptions, {"blocks": 6, "episodes": None}) == ["--blocks", "6"]


def test_intervals_read_as_written() -> None:
    assert str(Interval(0, 0.1, low_open=True)) == "(0, 0.1]"
    assert str(Interval(0, 0.08, high_open=True)) == "[0, 0.08)"
    assert Interval(1, None).describe() == ">= 1"
    assert Interval(0, None, low_open=True).describe() == "> 0"
    assert 0.1 in Interval(0, 0.1, low_open=True) and 0 not in Interval(0, 0.1, low_open=True)
    assert float("nan") not in Interval(None, None) and True not in Interval(0, 1)
