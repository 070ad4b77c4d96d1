"""What the router ACL tests share: a subscriber that records which forged messages got through."""

from __future__ import annotations

import threading

from manigraph_shared.messages import Message


def tag_of(message: Message) -> str:
    """The tag a test put in a message: its episode id, or its command id."""
    return str(getattr(message, "episode_id", None) or getattr(message, "command_id", ""))


class Inbox:
    """The tags of every message received, and a wait for one of them."""

    def __init__(self) -> None:
        self.tags: list[str] = []
        self.arrived = threading.Condition()

    def receive(self, message: Message) -> None:
        with self.arrived:
            self.tags.append(tag_of(message))
            self.arrived.notify_all()

    def wait_for(self, tag: str, timeout: float = 5.0) -> bool:
        with self.arrived:
            return self.arrived.wait_for(lambda: tag in self.tags, timeout)
