from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory

ProtobufDecoder = Callable[[str, bytes, bytes], dict[str, Any]]


@pytest.fixture
def decode_protobuf() -> ProtobufDecoder:
    """Decode a protobuf channel's message with the schema the channel carries (a
    FileDescriptorSet, as in MCAP and the Foxglove WebSocket protocol), as Foxglove does."""
    pools: dict[bytes, descriptor_pool.DescriptorPool] = {}

    def decode(schema_name: str, schema_data: bytes, payload: bytes) -> dict[str, Any]:
        pool = pools.get(schema_data)
        if pool is None:
            pool = descriptor_pool.DescriptorPool()
            for file in descriptor_pb2.FileDescriptorSet.FromString(schema_data).file:
                pool.Add(file)
            pools[schema_data] = pool
        cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))
        return json_format.MessageToDict(
            cls.FromString(payload),
            preserving_proto_field_name=True,
            always_print_fields_with_no_presence=True,
        )

    return decode
