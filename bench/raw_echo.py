"""The floor of every round trip: a process that echoes bytes back through the same router.

``python bench/raw_echo.py ENDPOINT`` subscribes to ``bench/echo/ping`` and puts every payload
unchanged on ``bench/echo/pong``, with the QoS manigraph gives a state stream (express,
congestion control DROP). No decoding, no validation, no service thread: what Zenoh from
Python costs, which the round-trip benches print beside their own figures.
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time

import zenoh

PING = "bench/echo/ping"
PONG = "bench/echo/pong"


def open_client(endpoint: str, wait_seconds: float = 60.0) -> zenoh.Session:
    """A bare client session of ``endpoint``, retried until the router answers."""
    deadline = time.monotonic() + wait_seconds
    while True:
        config = zenoh.Config()
        config.insert_json5("mode", '"client"')
        config.insert_json5("connect/endpoints", json.dumps([endpoint]))
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("connect/exit_on_failure", "true")
        try:
            return zenoh.open(config)
        except zenoh.ZError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def main() -> None:
    session = open_client(sys.argv[1])
    publisher = session.declare_publisher(
        PONG, congestion_control=zenoh.CongestionControl.DROP, express=True
    )
    session.declare_subscriber(PING, lambda sample: publisher.put(sample.payload))
    session.liveliness().declare_token("bench/echo/alive")
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    stop.wait()
    session.close()


if __name__ == "__main__":
    main()
