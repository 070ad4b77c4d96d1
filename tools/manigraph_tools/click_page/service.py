"""``manigraph demo-ui`` as a bus service: the session on the bus, the web page beside it.

The service plays the planner's part while a person demonstrates: it consumes what the
planner consumes (``Scene``, ``SkillStatus``, ``EpisodeEvent``), publishes the ``Action``
each click becomes, and asks the sim for new episodes (``EpisodeRequest``), as ``manigraph
run`` does. It announces itself as ``demo-ui`` (liveliness and heartbeat, so ``manigraph
doctor`` and ``manigraph up`` see it); on a secure stack it presents the identity ``demo-ui``,
which the router lets publish actions and reset the world (``manigraph_tools.access``).

With ``--propose P`` a policy, loaded in this process, proposes each decision; the page shows
it and holds it until the person accepts or corrects it (``proposals.py``, ``proposer.py``).
"""

from __future__ import annotations

import re
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from manigraph_shared.bus import Bus
from manigraph_shared.demonstrations import DemonstrationLog, stamp_times
from manigraph_shared.errors import BusError, ConfigError, MessageError, RequestRefused
from manigraph_shared.messages import Action, EpisodeEvent, EpisodeRequest, Scene, SkillStatus
from manigraph_shared.options import Interval, Options, option
from manigraph_shared.scene_gate import SceneGate
from manigraph_shared.service import Service
from manigraph_tools.click_page.http import (
    READY_WAIT,
    BadRequest,
    DemoHttpServer,
    ServiceUnavailable,
)
from manigraph_tools.click_page.proposer import Proposer, load_proposer
from manigraph_tools.click_page.session import Click, DemoSession
from manigraph_tools.episodes import read_task_file
from manigraph_tools.family import FAMILIES

AT_LEAST_ONE = Interval(1, None)
#: Longest wait for the sim to answer a reset, seconds.
RESET_TIMEOUT = 30.0


@dataclass(frozen=True)
class DemoUiOptions(Options):
    """``manigraph demo-ui``'s flags; the episode fields are the page's first values."""

    http_host: str = option("127.0.0.1", help="address the page is served on (loopback)")
    http_port: int = option(
        8770, help="port of the page (0: any free one; view has 8765)", within=Interval(0, 65535)
    )
    output: Path | None = option(
        None, help="MCAP file the demonstrations go to (default demos/demo-ui-<time>.mcap)"
    )
    task: str = option("stack", help="task of the first episode")
    task_file: Path | None = option(None, help="your own TOML layout (docs/running.md)")
    blocks: int = option(3, help="blocks per stack K", within=AT_LEAST_ONE)
    stacks: int = option(1, help="number of stacks s", within=AT_LEAST_ONE)
    objects: int | None = option(
        None,
        help="objects, for a task sized by them (unset: its family's default)",
        within=AT_LEAST_ONE,
    )
    preference: str | None = option(
        None, help="how the objects are to be placed, for a task whose family reads it (its docs)"
    )
    seed: int = option(0, help="seed of the first episode", within=Interval(0, None))
    propose: str | None = option(
        None,
        help="a policy (name or checkpoint) that proposes each decision on the page: one click "
        "accepts it, another pair corrects it (docs/demo-ui.md)",
    )

    def output_path(self) -> Path:
        """The file to write: ``output`` (default ``demos/demo-ui-<time>.mcap``), or, if that
        exists, the first free ``<stem>-<n>.mcap`` beside it: a restarted page never
        overwrites the demonstrations of the one before."""
        path = self.output or Path("demos") / time.strftime("demo-ui-%Y%m%d-%H%M%S.mcap")
        number = 1
        candidate = path
        while candidate.exists():
            number += 1
            candidate = path.with_name(f"{path.stem}-{number}{path.suffix}")
        return candidate


class DemoUiService(Service):
    name = "demo-ui"
    tick_period = 0.5

    def __init__(self, bus: Bus, options: DemoUiOptions) -> None:
        super().__init__(bus)
        self.options = options
        self.output = options.output_path()
        self.task_file = read_task_file(options.task_file)
        self.session = DemoSession(self._open_log, str(self.output), proposer=options.propose)
        self.gate = SceneGate()
        self.stopping = threading.Event()
        self.proposer = (
            None
            if options.propose is None
            else Proposer(self.session, load_proposer(options.propose), self.stopping)
        )
        self._log: DemonstrationLog | None = None
        self._episodes = 0
        try:
            self.http = DemoHttpServer((options.http_host, options.http_port), self)
        except OSError as exc:
            raise ConfigError(
                "http-port", f"cannot serve on {options.http_host}:{options.http_port}: {exc}"
            ) from None
        self._server_thread = threading.Thread(
            target=self.http.serve_forever, name="demo-ui-http", daemon=True
        )

    @property
    def url(self) -> str:
        return f"http://{self.options.http_host}:{self.http.port}/"

    def _open_log(self) -> DemonstrationLog:
        self._log = DemonstrationLog(self.output, log_time=stamp_times)
        return self._log

    # --- the bus ----------------------------------------------------------------------------
    def setup(self) -> None:
        self.on(EpisodeEvent, self._on_episode)
        self.on(Scene, self._on_scene)
        self.on(SkillStatus, self.session.on_status)
        self.bus.watch_alive(self.session.on_alive)
        self._server_thread.start()
        if self.proposer is not None:
            self.proposer.start()
            self.log.info("%s proposes each decision on the page", self.options.propose)
        self.log.info("demonstration page: %s (demonstrations go to %s)", self.url, self.output)

    def _on_episode(self, event: EpisodeEvent) -> None:
        overtaking = self.gate.on_episode(event)
        self.session.on_episode(event)
        for scene in overtaking:  # refused before this event reached us; acceptable now
            self._on_scene(scene)

    def _on_scene(self, scene: Scene) -> None:
        if self.admit(self.gate, scene):
            self.session.on_scene(scene)

    def tick(self) -> None:
        self.session.tick(time.monotonic())

    def teardown(self) -> None:
        self.stopping.set()
        self.http.shutdown()
        self.http.server_close()
        if self._log is not None:
            self._log.close()

    # --- what the page asks (HTTP threads) --------------------------------------------------
    def page_defaults(self) -> dict[str, Any]:
        o = self.options
        return {
            "task": "file" if self.task_file is not None else o.task,
            "task_file": o.task_file.name if o.task_file is not None else None,
            "blocks": o.blocks,
            "stacks": o.stacks,
            "objects": o.objects,
            "preference": o.preference,
            "seed": o.seed,
            **_family_fields(),
        }

    def start_episode(self, fields: dict[str, Any]) -> str:
        known = {"task", "blocks", "stacks", "objects", "preference", "seed"}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise BadRequest(
                f"{unknown[0]}: not an episode field (known: {', '.join(sorted(known))})"
            )
        defaults = self.page_defaults()
        values = {name: fields.get(name, defaults[name]) for name in known}
        self._episodes += 1
        seed = values["seed"]
        episode_id = f"demo-{int(time.time())}-{self._episodes}"
        task_file = self.task_file if values["task"] == "file" else None
        try:
            request = EpisodeRequest.from_builtins(
                {
                    "episode_id": episode_id,
                    "task": values["task"],
                    "blocks": values["blocks"],
                    "stacks": values["stacks"],
                    "objects": values["objects"],
                    "options": {"preference": values["preference"]} if values["preference"] else {},
                    "seed": seed,
                    "task_file": task_file,
                }
            )
        except MessageError as exc:
            field, why = exc.problems[0]
            raise BadRequest(f"{field}: {why}") from None
        if request.task == "file" and task_file is None:
            raise BadRequest("task: 'file' needs demo-ui --task-file")
        self.session.expect(request)
        try:
            start = self.bus.request(request, EpisodeEvent, timeout=RESET_TIMEOUT)
        except RequestRefused as exc:
            text = re.sub(r"^manigraph/world/reset: ", "", str(exc))
            self.session.say("error", f"the world refused the episode: {text}")
            raise BadRequest(text) from None
        except BusError as exc:
            self.session.say("error", f"no episode: {exc}")
            raise ServiceUnavailable(f"the sim did not answer: {exc}") from None
        self.session.on_episode(start)
        return request.episode_id

    def act(self, click: Click) -> Action:
        action = self.session.act(click, wait=READY_WAIT)
        self.bus.publish(action)
        return action


def _family_fields() -> dict[str, Any]:
    """What the page learns of the installed families (``manigraph_tools.family``): each
    family task's episode fields, what its count counts, and the family action each kind of
    fixture takes (its button's)."""
    families = [family for _, family in FAMILIES.items()]
    return {
        "family_tasks": {t: list(f.sized_by) for f in families for t in f.tasks},
        "counted": {t: f.counted for f in families for t in f.tasks},
        "fixture_actions": {k: a for f in families for k, a in f.fixture_actions.items()},
    }
