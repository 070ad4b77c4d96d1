"""A handler run ``inline`` (on the Zenoh thread a sample arrives on) still takes its turn:
it runs at once only while the service is idle, never beside another handler, never ahead of
older work. A real router and two real sessions; the service runs on a thread of this test."""

from __future__ import annotations

import threading
import time

from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodePhase,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.service import Service
from manigraph_testkit.testing import Stack

SERVICE_THREAD = "probe-service"


class Probe(Service):
    """Scenes inline; an episode event keeps the service busy until ``release`` is set."""

    name = "inline-probe"

    def __init__(self, *args: object) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        self.ran: list[tuple[str, str]] = []  # (what, on which thread), in the order run
        self.busy = threading.Event()
        self.release = threading.Event()
        self.changed = threading.Condition()
        self._running = 0
        self.overlapped = False

    def setup(self) -> None:
        self.on(EpisodeEvent, self._hold)
        self.on(Scene, lambda scene: self._note(scene.episode_id), inline=True)

    def _hold(self, event: EpisodeEvent) -> None:
        self._note(f"event {event.episode_id}", hold=True)

    def _note(self, what: str, hold: bool = False) -> None:
        self._running += 1
        self.overlapped |= self._running > 1
        if hold:
            self.busy.set()
            self.release.wait(10.0)
        self._running -= 1
        with self.changed:
            self.ran.append((what, threading.current_thread().name))
            self.changed.notify_all()

    def wait_for(self, what: str, timeout: float = 10.0) -> str:
        """The thread ``what`` ran on."""
        with self.changed:
            assert self.changed.wait_for(lambda: any(w == what for w, _ in self.ran), timeout), (
                f"{what} never ran: {self.ran}"
            )
            return next(thread for w, thread in self.ran if w == what)


def scene(episode: str, sequence: int) -> Scene:
    block = Vector3(x=0.04, y=0.04, z=0.04)
    return Scene(
        episode_id=episode,
        stamp=time.time(),
        sequence=sequence,
        objects=[
            SceneObject(
                id="b0", category="block", position=Vector3(x=0.5, y=-0.2, z=0.02), size=block
            )
        ],
        goals=[SceneGoal(id="g0", category="block", position=Vector3(x=0.5, y=0.2, z=0.02))],
    )


def test_an_inline_handler_runs_at_once_when_idle_and_waits_its_turn_when_busy(
    running_stack: Stack,
) -> None:
    running_stack.start("router")
    with running_stack.client() as service_bus, running_stack.client() as bus:
        probe = Probe(service_bus)
        thread = threading.Thread(target=probe.run, name=SERVICE_THREAD, daemon=True)
        thread.start()
        try:
            running_stack.wait_alive(bus, Probe.name)
            bus.publish(scene("idle", 1))
            assert probe.wait_for("idle") != SERVICE_THREAD  # no hand-over while idle

            bus.publish(
                EpisodeEvent(
                    episode_id="e1",
                    phase=EpisodePhase.START,
                    task="stack",
                    seed=0,
                    goals_total=1,
                    goals_filled=0,
                    stamp=time.time(),
                )
            )
            assert probe.busy.wait(10.0)
            bus.publish(scene("while-busy", 2))
            time.sleep(0.5)  # ample time for Zenoh to deliver it
            assert [what for what, _ in probe.ran] == ["idle"]  # it did not run beside
            probe.release.set()
            assert probe.wait_for("while-busy") == SERVICE_THREAD  # queued, then in turn
            assert [what for what, _ in probe.ran] == ["idle", "event e1", "while-busy"]
            assert not probe.overlapped
        finally:
            probe.release.set()
            probe.stop_event.set()
            thread.join(10.0)
