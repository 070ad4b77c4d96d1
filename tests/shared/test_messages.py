from __future__ import annotations

import json
import time

import msgspec
import pytest

from manigraph_shared.errors import MessageError
from manigraph_shared.messages import (
    MAX_PAYLOAD_BYTES,
    Action,
    CameraInfo,
    CompressedImage,
    DetectedMarker,
    EpisodeEvent,
    EpisodeRequest,
    LayoutGoal,
    LayoutObject,
    MarkerDetections,
    Message,
    ObjectCategory,
    Quaternion,
    RobotCommand,
    RobotFeedback,
    Scene,
    SceneGoal,
    SceneObject,
    ServiceStatus,
    SkillStatus,
    TaskLayout,
    Vector3,
    message_type_for_key,
)
from manigraph_shared.messages.base import Struct

NOW = 1_700_000_000.0


def scene(**overrides: object) -> Scene:
    fields: dict[str, object] = {
        "episode_id": "ep-1",
        "stamp": NOW,
        "sequence": 3,
        "objects": [
            SceneObject(
                id="block_0",
                category="block",
                position=Vector3(x=0.5, y=0.1, z=0.02),
                size=Vector3(x=0.04, y=0.04, z=0.04),
            )
        ],
        "goals": [
            SceneGoal(id="goal_0", category="block", position=Vector3(x=0.4, y=-0.1, z=0.02))
        ],
    }
    fields.update(overrides)
    return Scene(**fields)


SAMPLES: list[Message] = [
    scene(),
    Action(
        decision_id="ep-1:0",
        episode_id="ep-1",
        scene_sequence=3,
        object_id="block_0",
        goal_id="goal_0",
        orientation_index=5,
        policy="expert",
        stamp=NOW,
    ),
    SkillStatus(
        decision_id="ep-1:0", skill="pick_and_place", state="failed", reason="x", stamp=NOW
    ),
    EpisodeEvent(
        episode_id="ep-1",
        phase="end",
        task="stack",
        seed=1,
        goals_total=4,
        goals_filled=4,
        steps=4,
        success=True,
        stamp=NOW,
    ),
    EpisodeRequest(episode_id="ep-1", task="stack", blocks=40, seed=7),
    RobotCommand(
        command_id="c1",
        decision_id="ep-1:0",
        op="pick",
        object_id="block_0",
        position=Vector3(x=0.5, y=0.1, z=0.02),
        stamp=NOW,
    ),
    RobotFeedback(command_id="c1", ok=False, reason="object_covered", stamp=NOW),
    ServiceStatus(service="planner", state="error", detail="bad scene", stamp=NOW),
    CompressedImage(camera="front", stamp=NOW, sequence=2, format="jpeg", data=b"\xff\xd8\x00"),
    CameraInfo(
        camera="front",
        stamp=NOW,
        width=640,
        height=480,
        camera_matrix=[415.7, 0, 319.5, 0, 415.7, 239.5, 0, 0, 1],
    ),
    MarkerDetections(
        camera="front",
        stamp=NOW,
        markers=[DetectedMarker(id=4, corners=[1, 2, 3, 4, 5, 6, 7, 8], object_id="block_0")],
    ),
    TaskLayout(
        episode_id="ep-1",
        stamp=NOW,
        objects=[
            LayoutObject(
                id="block_0",
                category="block",
                size=Vector3(x=0.04, y=0.04, z=0.04),
                position=Vector3(x=0.5, y=0.1, z=0.02),
            )
        ],
        goals=[LayoutGoal(id="goal_0", category="block", position=Vector3(x=0.4, y=0, z=0.02))],
    ),
]


@pytest.mark.parametrize("message", SAMPLES, ids=lambda m: type(m).__name__)
def test_round_trip_is_lossless(message: Message) -> None:
    decoded = type(message).decode(message.encode(), message.key_for())
    assert decoded == message


PUBLISHED = [m for m in SAMPLES if type(m).delivery.value != "query"]


@pytest.mark.parametrize("message", PUBLISHED, ids=lambda m: type(m).__name__)
def test_every_published_type_is_found_by_its_key(message: Message) -> None:
    assert message_type_for_key(message.key_for()) is type(message)


def test_query_payloads_are_not_mistaken_for_published_samples() -> None:
    assert message_type_for_key(EpisodeRequest.key) is None


def test_status_key_carries_the_service_name() -> None:
    status = ServiceStatus(service="skills", state="ok", stamp=NOW)
    assert status.key_for() == "manigraph/status/skills"
    assert message_type_for_key("manigraph/status/skills") is ServiceStatus
    assert message_type_for_key("manigraph/elsewhere") is None


def rejected_fields(payload: bytes, message_type: type[Message] = Scene) -> list[str]:
    with pytest.raises(MessageError) as caught:
        message_type.decode(payload, "manigraph/test")
    assert caught.value.key == "manigraph/test"
    return caught.value.fields


def good_scene_json() -> dict[str, object]:
    return json.loads(scene().encode())


def test_truncated_payload_is_rejected() -> None:
    payload = scene().encode()
    assert rejected_fields(payload[: len(payload) // 2]) == ["<payload>"]


def test_malformed_json_is_rejected() -> None:
    assert rejected_fields(b"{not json") == ["<payload>"]


def test_payload_of_the_wrong_type_names_the_missing_fields() -> None:
    fields = rejected_fields(SAMPLES[1].encode())
    assert {"sequence", "objects", "goals"} <= set(fields)
    assert "decision_id" in fields  # extra fields are refused, not silently dropped


@pytest.mark.parametrize("bad", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_rejected(bad: str) -> None:
    payload = scene().encode().replace(b'"x":0.5', f'"x":{bad}'.encode())
    assert rejected_fields(payload) == ["objects.0.position.x"]


def test_out_of_range_values_name_the_field() -> None:
    data = good_scene_json()
    data["goals"][0]["position"]["z"] = 250.0  # type: ignore[index]
    assert rejected_fields(json.dumps(data).encode()) == ["goals.0.position.z"]
    data = good_scene_json()
    data["sequence"] = -1
    assert rejected_fields(json.dumps(data).encode()) == ["sequence"]


def test_non_unit_quaternion_is_rejected() -> None:
    data = good_scene_json()
    data["objects"][0]["orientation"] = {"x": 0.5, "y": 0.0, "z": 0.0, "w": 0.5}  # type: ignore[index]
    assert rejected_fields(json.dumps(data).encode()) == ["objects.0.orientation"]


def test_duplicate_ids_are_rejected() -> None:
    data = good_scene_json()
    data["goals"][0]["id"] = "block_0"  # type: ignore[index]
    with pytest.raises(MessageError, match="block_0") as caught:
        Scene.decode(json.dumps(data).encode())
    assert caught.value.fields == ["id"]


def test_oversized_payload_is_rejected_unread() -> None:
    payload = b" " * (MAX_PAYLOAD_BYTES + 1)
    with pytest.raises(MessageError, match="exceeds"):
        Scene.decode(payload)


def test_failed_status_must_give_a_reason() -> None:
    payload = json.dumps(
        {"decision_id": "a", "skill": "s", "state": "failed", "stamp": time.time()}
    ).encode()
    assert rejected_fields(payload, SkillStatus) == ["reason"]


def test_ended_episode_must_say_whether_it_succeeded() -> None:
    payload = json.dumps(
        {
            "episode_id": "e",
            "phase": "end",
            "task": "stack",
            "seed": 0,
            "goals_total": 2,
            "goals_filled": 1,
            "stamp": NOW,
        }
    ).encode()
    assert rejected_fields(payload, EpisodeEvent) == ["success"]


def test_non_positive_size_names_the_object() -> None:
    data = good_scene_json()
    data["objects"][0]["size"]["z"] = 0.0  # type: ignore[index]
    assert rejected_fields(json.dumps(data).encode()) == ["objects.0.size"]


def test_bad_identifier_is_rejected() -> None:
    data = good_scene_json()
    data["episode_id"] = "has space"
    assert rejected_fields(json.dumps(data).encode()) == ["episode_id"]


def test_schema_is_json_schema_titled_by_type() -> None:
    schema = json.loads(Scene.mcap_schema())
    assert schema["title"] == "manigraph.Scene"
    assert {"objects", "goals", "stamp"} <= set(schema["properties"])


def test_a_camera_matrix_that_is_not_pinhole_is_rejected() -> None:
    bad = CameraInfo(
        camera="front", stamp=NOW, width=640, height=480, camera_matrix=[1, 0, 0, 0, 1, 0, 0, 0, 1]
    ).to_builtins()
    bad["camera_matrix"] = [415.7, 3.0, 319.5, 0, 415.7, 239.5, 0, 0, 1]
    with pytest.raises(MessageError) as error:
        CameraInfo.decode(json.dumps(bad).encode())
    assert "camera_matrix" in error.value.fields


def test_image_bytes_travel_as_base64() -> None:
    image = CompressedImage(camera="front", stamp=NOW, sequence=0, format="png", data=b"\x89PNG")
    assert b"iVBORw" in image.encode()  # base64 of the bytes, not a list of numbers
    assert CompressedImage.decode(image.encode()).data == b"\x89PNG"


def test_every_decoder_is_built_at_import_before_any_thread_decodes() -> None:
    """msgspec builds a type's decoding information lazily and not thread-safely: two Zenoh
    threads decoding their first samples at once crashed the skills service (SIGSEGV)."""
    import subprocess
    import sys

    check = (
        "import manigraph_shared.messages as m;"
        "missing = [n for n, c in m.Message.registry.items() if c._decoder is None];"
        "print(missing)"
    )
    result = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


class _Checked(Struct, frozen=True, kw_only=True):
    size: float

    def _check(self) -> None:
        if self.size <= 0:
            raise ValueError("size: must be > 0")


class _CheckedWithEnum(_Checked, frozen=True, kw_only=True):
    """Inherits a check, adds an enum field: both run (each struct's __post_init__ is built
    for what it has, see messages/base.py)."""

    category: ObjectCategory


class _Plain(_Checked, frozen=True, kw_only=True):
    """Adds nothing: the inherited check still runs."""

    label: str = ""


def test_checks_and_enum_fields_hold_through_inheritance() -> None:
    assert _CheckedWithEnum(size=1.0, category="block").category is ObjectCategory.BLOCK  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="size"):
        _CheckedWithEnum(size=0.0, category=ObjectCategory.BLOCK)
    with pytest.raises(ValueError, match="size"):
        _Plain(size=-1.0)
    decoded = msgspec.json.decode(b'{"size": 2.0, "category": "cover"}', type=_CheckedWithEnum)
    assert decoded.category is ObjectCategory.COVER
    with pytest.raises(msgspec.ValidationError, match="size"):
        msgspec.json.decode(b'{"size": 0.0, "category": "cover"}', type=_CheckedWithEnum)
    with pytest.raises(ValueError, match="unit quaternion"):
        Quaternion(x=0.5)
    assert Quaternion(x=0.7071, w=0.7071).w == pytest.approx(0.7071)
