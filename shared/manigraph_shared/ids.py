"""Identifiers built from other identifiers, kept inside the contract's 64 characters.

A command id is its decision id plus a suffix, a decision id its episode id plus a step. Glued
together naively, a valid 64-character input gives a 66-character id that fails validation
downstream (and the episode hangs). :func:`derived_id` keeps the readable form whenever it
fits and otherwise shortens the base to a prefix, a dash and a short hash of the whole base, so any
valid input gives a valid, still unique, id.
"""

from __future__ import annotations

import hashlib

MAX_ID_LENGTH = 64
_HASH_CHARS = 10


def derived_id(base: str, separator: str, suffix: str) -> str:
    """``base + separator + suffix`` if it fits in 64 characters, else ``<prefix>-<hash>``
    of ``base`` followed by ``separator + suffix``.

    Raises:
        ValueError: the suffix alone leaves no room for a base.
    """
    whole = f"{base}{separator}{suffix}"
    if len(whole) <= MAX_ID_LENGTH:
        return whole
    tail = f"{separator}{suffix}"
    digest = hashlib.blake2b(base.encode(), digest_size=8).hexdigest()[:_HASH_CHARS]
    room = MAX_ID_LENGTH - len(tail) - len(digest) - 1
    if room < 1:
        raise ValueError(f"suffix: '{suffix}' leaves no room for an id")
    return f"{base[:room]}-{digest}{tail}"
