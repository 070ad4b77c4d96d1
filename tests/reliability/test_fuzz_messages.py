"""Property-based fuzzing of every message type of the contract (``Message.registry``).

(a) decoding arbitrary bytes, arbitrary JSON and near-miss messages never raises anything but
the typed ``MessageError``; (b) every valid message round-trips through its encoding.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from manigraph_shared.errors import MessageError
from manigraph_shared.messages import Message, key_matches
from manigraph_testkit.fuzzing import hostile_payloads, message_types, valid_messages

TYPES = message_types()
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def test_every_registered_type_is_fuzzed() -> None:
    assert len(TYPES) == len(Message.registry) >= 13


def _decode_only_raises_message_error(cls: type[Message], payload: bytes) -> None:
    try:
        message = cls.decode(payload, cls.key_pattern())
    except MessageError as exc:
        assert exc.problems, "a rejection names at least one field"
    else:
        assert isinstance(message, cls)


@pytest.mark.parametrize("cls", TYPES, ids=lambda c: c.__name__)
@FUZZ
@given(payload=st.binary(max_size=1024))
def test_arbitrary_bytes_are_rejected_with_a_message_error(
    cls: type[Message], payload: bytes
) -> None:
    _decode_only_raises_message_error(cls, payload)


@pytest.mark.parametrize("cls", TYPES, ids=lambda c: c.__name__)
@FUZZ
@given(data=st.data())
def test_hostile_json_is_rejected_with_a_message_error(
    cls: type[Message], data: st.DataObject
) -> None:
    _decode_only_raises_message_error(cls, data.draw(hostile_payloads(cls)))


@pytest.mark.parametrize("cls", TYPES, ids=lambda c: c.__name__)
@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_valid_messages_round_trip(cls: type[Message], data: st.DataObject) -> None:
    message = data.draw(valid_messages(cls))
    assert cls.decode(message.encode(), cls.key) == message
    if cls.delivery.value != "query":
        assert key_matches(cls.key_pattern(), message.key_for())
