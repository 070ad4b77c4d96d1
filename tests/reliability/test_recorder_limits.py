"""The recorder's files are bounded and a killed recorder's file is made whole again."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import McapLogWriter, is_finalised, recover_log
from manigraph_shared.messages import Action
from manigraph_shared.service import TRIM_AFTER_MESSAGES
from manigraph_testkit.testing import Stack, record_then_kill
from manigraph_tools.recorder import Recorder

pytestmark = pytest.mark.integration


def action(step: int) -> Action:
    return Action(
        decision_id=f"e:{step}",
        episode_id="e",
        scene_sequence=step,
        object_id="b",
        goal_id="g",
        policy="load",
        stamp=time.time(),
    )


def standard_read(path: Path) -> list[int]:
    """Action sequences as the ``mcap`` package's own seeking reader sees them."""
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        steps = [
            Action.decode(message.data).scene_sequence
            for _, channel, message in reader.iter_messages()
            if channel.topic == Action.key
        ]
        assert summary.statistics.message_count >= len(steps)
    return steps


def test_recovery_of_a_cut_file_keeps_every_flushed_message(tmp_path: Path) -> None:
    path = tmp_path / "cut.mcap"
    writer = McapLogWriter(path)
    for step in range(50):
        writer.write(Action.key, action(step).encode(), time.time_ns())
    writer.flush()
    writer.write(Action.key, action(50).encode(), time.time_ns())  # in a chunk never closed
    writer._stream.flush()  # what the OS has when the process dies
    assert not is_finalised(path)
    with pytest.raises(Exception):  # noqa: B017  the standard reader cannot open it
        standard_read(path)
    assert recover_log(path) == 50
    assert is_finalised(path) and standard_read(path) == list(range(50))
    assert recover_log(path) == 50  # recovering a whole file changes nothing


def test_recovering_something_that_is_not_mcap_is_refused(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(LogError, match="not an MCAP file"):
        recover_log(junk)
    assert junk.read_bytes() == b"not an mcap file at all"


def test_files_rotate_by_size_and_every_file_is_finalised(
    running_stack: Stack, tmp_path: Path
) -> None:
    log = tmp_path / "run.mcap"
    running_stack.start("router")
    running_stack.start("recorder", "record", "--output", str(log), "--max-bytes", "20000")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "recorder")
        time.sleep(0.3)
        for step in range(3000):
            bus.publish(action(step))
        time.sleep(1.5)
    assert running_stack.stop("recorder") == 0
    files = sorted(tmp_path.glob("run*.mcap"))
    assert len(files) >= 3 and files[0].name == "run.001.mcap" and log in files
    steps = [s for f in files for s in standard_read(f)]
    assert sorted(steps) == list(range(3000))
    # each file holds about max_bytes (one compressed chunk past it at most)
    assert all(f.stat().st_size < 200_000 for f in files)


def test_files_rotate_by_age(running_stack: Stack, tmp_path: Path) -> None:
    out = tmp_path / "logs"
    out.mkdir()
    running_stack.start("router")
    running_stack.start("recorder", "record", "--output", str(out), "--max-seconds", "1")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "recorder")
        time.sleep(3.5)
    running_stack.stop("recorder")
    files = list(out.glob("manigraph-*.mcap"))
    assert len(files) >= 3 and all(is_finalised(f) for f in files)


def test_a_killed_recorder_file_opens_with_the_standard_reader_after_recover(
    running_stack: Stack, tmp_path: Path
) -> None:
    killed = record_then_kill(running_stack, tmp_path / "killed.mcap")
    result = running_stack.run("record", "--recover", str(killed.log))
    assert result.returncode == 0 and "finalised with" in result.stderr
    recovered = set(standard_read(killed.log))
    must_have = killed.flushed_before(0.2)
    assert len(must_have) > 100 and must_have <= recovered


def test_a_recorder_finalises_what_a_killed_one_left_in_its_directory(
    running_stack: Stack, tmp_path: Path
) -> None:
    out = tmp_path / "logs"
    out.mkdir()
    left = out / "manigraph-20260101-000000.mcap"
    writer = McapLogWriter(left)
    writer.write(Action.key, action(0).encode(), time.time_ns())
    writer.flush()
    old = time.time() - 60
    os.utime(left, (old, old))
    running_stack.start("router")
    running_stack.start("recorder", "record", "--output", str(out))
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "recorder")
    assert is_finalised(left) and standard_read(left) == [0]


def test_the_heap_is_trimmed_again_once_a_burst_has_been_written(
    running_stack: Stack, tmp_path: Path
) -> None:
    """A trim during a burst frees little while the queue is full; the recorder trims once
    more when the queue has drained (the soak's valid-scene flood left it 30 % larger a minute
    later: its last trim was mid-flood, and heartbeats alone take minutes to make a burst)."""
    running_stack.start("router")
    with running_stack.client() as bus:
        recorder = Recorder(bus, tmp_path / "r.mcap")  # not started: its queue is ours
        assert not recorder.trim_heap()  # nothing happened yet
        recorder.samples_seen += TRIM_AFTER_MESSAGES  # a burst ...
        recorder._samples.put(("manigraph/x", b"{}", 0))  # ... still queued for the disk
        assert recorder.trim_heap()
        assert not recorder.trim_heap()  # still queued, no new samples
        recorder._samples.get()  # written
        assert recorder.trim_heap()  # once more, now that the queue is empty
        assert not recorder.trim_heap()
        recorder.samples_seen += 5  # heartbeats
        assert not recorder.trim_heap()


def test_a_sample_the_foxglove_view_cannot_draw_is_still_logged_and_the_writer_goes_on(
    running_stack: Stack, tmp_path: Path
) -> None:
    class BrokenView:
        def convert(self, key: str, data: bytes) -> list[object]:
            raise KeyError("a category the view does not know")

    running_stack.start("router")
    path = tmp_path / "r.mcap"
    with running_stack.client() as bus:
        recorder = Recorder(bus, path)  # not started: the writer loop runs here
        recorder._foxglove = BrokenView()  # type: ignore[assignment]
        recorder._open(path)
        for step in range(5):
            recorder._samples.put((Action.key, action(step).encode(), time.time_ns()))
        recorder._samples.put(None)
        recorder._write_loop()
    assert standard_read(path) == [0, 1, 2, 3, 4]
    assert recorder.messages_written == 5 and recorder.foxglove_failures == 5
