from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import McapLogWriter, contract_version, decode_log, read_log
from manigraph_shared.messages import CONTRACT_VERSION, Action, Scene, ServiceStatus


def action(step: int) -> Action:
    return Action(
        decision_id=f"e:{step}",
        episode_id="e",
        scene_sequence=step,
        object_id="b",
        goal_id="g",
        policy="expert",
        stamp=time.time(),
    )


def test_channels_carry_the_contract_schema(tmp_path: Path) -> None:
    path = tmp_path / "log.mcap"
    log = McapLogWriter(path)
    log.write(Action.key, action(0).encode(), 1)
    status = ServiceStatus(service="sim", state="ok", stamp=1.0)
    log.write(status.key_for(), status.encode(), 2)
    log.write("manigraph/not/in/contract", b"{}", 3)
    log.close()

    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    topics = {c.topic: summary.schemas.get(c.schema_id) for c in summary.channels.values()}
    assert topics[Action.key].name == "manigraph.Action"
    assert topics[Action.key].encoding == "jsonschema"
    assert json.loads(topics[Action.key].data)["title"] == "manigraph.Action"
    assert topics["manigraph/status/sim"].name == "manigraph.ServiceStatus"
    assert topics["manigraph/not/in/contract"] is None  # recorded, without a schema

    messages = list(read_log(path))
    assert [m.log_time_ns for m in messages] == [1, 2, 3]
    assert messages[0].decode() == Action.decode(messages[0].data)


def test_a_declared_foreign_channel_keeps_its_schema_and_stays_out_of_the_contract(
    tmp_path: Path,
) -> None:
    path = tmp_path / "log.mcap"
    log = McapLogWriter(path)
    log.add_channel("/drawing", "protobuf", "pkg.Drawing", "protobuf", b"descriptor")
    decision = action(0)
    log.write("/drawing", b"\x08\x01", 1)
    log.write(Action.key, decision.encode(), 2)
    log.close()
    with path.open("rb") as stream:
        ((schema, channel, message),) = make_reader(stream).iter_messages(topics=["/drawing"])
    assert schema is not None and (schema.name, schema.encoding, schema.data) == (
        "pkg.Drawing",
        "protobuf",
        b"descriptor",
    )
    assert (channel.message_encoding, message.data) == ("protobuf", b"\x08\x01")
    assert decode_log(path) == [decision]  # the contract's messages only


def test_topic_filters(tmp_path: Path) -> None:
    path = tmp_path / "log.mcap"
    log = McapLogWriter(path)
    for step in range(3):
        log.write(Action.key, action(step).encode(), step)
        log.write("manigraph/status/sim", b"{}", step)
    log.close()
    assert {m.topic for m in read_log(path, topics=["manigraph/planner/*"])} == {Action.key}
    assert {m.topic for m in read_log(path, exclude=["manigraph/status/**"])} == {Action.key}


def test_torn_file_yields_every_flushed_message(tmp_path: Path) -> None:
    path = tmp_path / "log.mcap"
    log = McapLogWriter(path, flush_interval=3600)
    for step in range(50):
        log.write(Action.key, action(step).encode(), step)
    log.flush()
    flushed_size = path.stat().st_size
    for step in range(50, 60):
        log.write(Action.key, action(step).encode(), step)
    log.flush()
    # The writer dies mid-way through the second chunk: cut the file there.
    data = path.read_bytes()
    cut = flushed_size + (len(data) - flushed_size) // 2
    torn = tmp_path / "torn.mcap"
    torn.write_bytes(data[:cut])
    steps = [Action.decode(m.data).scene_sequence for m in read_log(torn)]
    assert steps == list(range(50))


def test_not_an_mcap_file_is_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "notes.mcap"
    path.write_text("these are notes, not a log")
    with pytest.raises(LogError, match=rf"^not an MCAP file: {path}$"):
        list(read_log(path))
    with pytest.raises(LogError, match="cannot open"):
        list(read_log(tmp_path / "missing.mcap"))


GOLDEN = Path(__file__).resolve().parents[1] / "golden"


def test_a_log_names_its_contract_version_and_older_logs_still_decode(tmp_path: Path) -> None:
    path = tmp_path / "now.mcap"
    writer = McapLogWriter(path)
    writer.close()
    assert contract_version(path) == CONTRACT_VERSION == 4
    golden = GOLDEN / "sage-stack4.mcap"
    assert contract_version(golden) == 1  # written before versions were recorded
    scenes = [m for m in decode_log(golden) if isinstance(m, Scene)]
    assert scenes and all(o.attributes == {} for s in scenes for o in s.objects)
    assert all(g.accepts == {} and g.attributes == {} for s in scenes for g in s.goals)
    text = tmp_path / "notes.txt"
    text.write_text("# not a log\n")
    with pytest.raises(LogError, match="not an MCAP file"):
        contract_version(text)
