"""The delay relay that stands in for netem (``manigraph_testkit.delay_link``), as its own
process on loopback in front of a TCP echo: every byte arrives, in order, both ways, never
before its delay; an end of stream passes through. How late it is, is a bench figure
(``bench/bench_netem.py`` prints what the link adds to the round trip)."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import pytest

from manigraph_testkit.testing import free_port

DELAY_MS = 15.0


@pytest.fixture
def echo_port() -> Iterator[int]:
    """A TCP echo server on loopback (one connection at a time, until the test ends)."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.2)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            with conn:
                conn.settimeout(10.0)
                while data := conn.recv(65536):
                    conn.sendall(data)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join(5.0)
    server.close()


@pytest.fixture
def relay_port(echo_port: int) -> Iterator[int]:
    port = free_port()
    relay = subprocess.Popen(
        [sys.executable, "-m", "manigraph_testkit.delay_link", "--listen", f"127.0.0.1:{port}",
         "--to", f"127.0.0.1:{echo_port}", "--delay-ms", str(DELAY_MS)],
    )  # fmt: skip
    deadline = time.monotonic() + 30.0
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
            break
        except OSError:
            assert relay.poll() is None, "the relay exited"
            assert time.monotonic() < deadline, "the relay never listened"
            time.sleep(0.05)
    yield port
    relay.terminate()
    assert relay.wait(10.0) == 0  # stops on SIGTERM within its 0.2 s accept poll


def receive(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        assert chunk, f"closed after {len(data)} of {size} bytes"
        data += chunk
    return data


def test_every_byte_crosses_in_order_and_never_before_its_delay(relay_port: int) -> None:
    with socket.create_connection(("127.0.0.1", relay_port), timeout=10.0) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        for size in (1, 300, 17_000, 200_000):  # a byte, an Action, a K = 40 Scene, a burst
            payload = bytes((i * 7 + size) % 256 for i in range(size))
            sent = time.monotonic()
            sock.sendall(payload)
            assert receive(sock, size) == payload
            assert (time.monotonic() - sent) * 1000 >= 2 * DELAY_MS  # there and back


def test_the_end_of_a_stream_passes_through(relay_port: int) -> None:
    with socket.create_connection(("127.0.0.1", relay_port), timeout=10.0) as sock:
        sock.sendall(b"last words")
        sock.shutdown(socket.SHUT_WR)  # the echo sees the end, answers, and closes
        assert receive(sock, 10) == b"last words"
        assert sock.recv(1) == b""
