"""The stack's emergency-stop latch, kept by the router: a stop lasts until ``resume``.

Every ``EmergencyStop`` the router sees (every cell's: ``manigraph/**/robot/estop``) is kept,
the newest per key, in memory and in ``estop.json`` in the stack's **state directory**
(:func:`state_dir`). A stop that changes a cell's state (engaged or released) is written
atomically before the next one is taken; one that repeats the state (a flood of stops, forged
or not) only updates the reason and stamp kept, written at most once per
:data:`REPEAT_WRITE_S`, so no sender can make the router fsync without bound. A query on the stop's
key is answered with what is kept (a stop never sent is answered released, ``stamp`` 0), so a
service that starts, or restarts, learns the stop before it moves anything
(:mod:`manigraph_shared.estop_latch`), and a router that restarts, or a whole ``manigraph up``
started again on the same stack, comes back stopped.

*The same stack* is the same state directory: by default one per listening endpoint of the
router on this machine (``~/.local/state/manigraph/tcp-127.0.0.1-7447``), else
``--state-dir`` or ``$MANIGRAPH_STATE_DIR``. A latch file that cannot be read is not taken
for "released": every cell then answers engaged, naming the file, until a ``manigraph resume``
for that cell (what could not be read stays said in the file until then).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import threading
import time
from pathlib import Path
from typing import Any

import zenoh

from manigraph_shared.errors import MessageError
from manigraph_shared.estop_latch import NEVER_ENGAGED
from manigraph_shared.messages import EmergencyStop
from manigraph_shared.messages.base import PREFIX

log = logging.getLogger("manigraph.router.estop")

#: The stack's state directory, used as it is (the router's ``--state-dir`` wins over it).
STATE_DIR_ENV = "MANIGRAPH_STATE_DIR"
#: The latch's file in the state directory.
LATCH_FILE = "estop.json"
#: Every cell's stop key (the default cell's ``manigraph/robot/estop`` included).
EVERY_CELL = f"{PREFIX}/**/robot/estop"
#: Keys kept at most (one per cell): a flood of forged cells cannot grow the file for ever.
MAX_KEYS = 256
#: Largest latch file read (a stop is ~300 bytes; 256 of them fit many times over).
MAX_FILE_BYTES = 1 << 20
#: A stop that repeats a cell's state is written at most this often (seconds); a change of
#: state is written at once.
REPEAT_WRITE_S = 1.0


def state_dir(explicit: Path | None, listen: tuple[str, ...]) -> Path:
    """The stack's state directory: ``explicit``, else ``$MANIGRAPH_STATE_DIR``, else one per
    listening endpoint under ``$XDG_STATE_HOME`` (``~/.local/state``)."""
    if explicit is not None:
        return explicit
    if os.environ.get(STATE_DIR_ENV):
        return Path(os.environ[STATE_DIR_ENV])
    base = Path(os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state")
    endpoint = listen[0] if listen else "tcp/127.0.0.1:7447"
    return base / "manigraph" / re.sub(r"[^A-Za-z0-9._-]+", "-", endpoint).strip("-")


class EstopKeeper:
    """Keeps every cell's last stop, on disk and for queries, on the router's session."""

    def __init__(self, session: zenoh.Session, directory: Path) -> None:
        self.session = session
        self.path = directory / LATCH_FILE
        self._lock = threading.Lock()
        self._kept: dict[str, EmergencyStop] = {}
        #: Why the file could not be read: every cell is engaged until a stop message says
        #: otherwise.
        self.unreadable: str | None = None
        self._declared: list[Any] = []
        #: Repeated stops not yet on disk, and the timer that writes them.
        self._dirty = False
        self._timer: threading.Timer | None = None
        #: Files written (for the bench and the tests: the cost of a flood).
        self.writes = 0

    # --- life cycle -------------------------------------------------------------------------
    def start(self) -> None:
        self._load()
        self._declared.append(self.session.declare_subscriber(EVERY_CELL, self._on_sample))
        self._declared.append(self.session.declare_queryable(EVERY_CELL, self._on_query))
        engaged = {key: stop for key, stop in self._kept.items() if stop.engaged}
        if self.unreadable:
            log.error(
                "EMERGENCY STOP ENGAGED in every cell: the latch %s could not be read (%s); "
                "`manigraph resume` releases it",
                self.path,
                self.unreadable,
            )
        for key, stop in engaged.items():
            log.warning(
                "EMERGENCY STOP ENGAGED (latched on %s since %s%s): %s; `manigraph resume` "
                "releases it",
                key,
                time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(stop.stamp)),
                f", by {stop.by}" if stop.by else "",
                stop.reason or "no reason given",
            )
        log.info("emergency-stop latch: %s", self.path)

    def close(self) -> None:
        for entity in reversed(self._declared):
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        self._declared.clear()
        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
        self._write_repeats()

    # --- what it keeps ----------------------------------------------------------------------
    def kept(self, key: str) -> EmergencyStop:
        """The stop kept for ``key`` (released, stamp 0, if none was ever sent)."""
        with self._lock:
            stop = self._kept.get(key)
            unreadable = self.unreadable
        if stop is not None:
            return stop
        if unreadable is not None:
            return EmergencyStop(
                engaged=True,
                reason=f"the stack's latch file could not be read: {unreadable}"[:256],
                by="latch",
                stamp=0.0,
            )
        return EmergencyStop(engaged=False, reason=NEVER_ENGAGED, by="latch", stamp=0.0)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        try:
            stop = EmergencyStop.decode(sample.payload.to_bytes(), key)
        except MessageError as exc:  # refused, as every service refuses it
            log.warning("refused a stop message: %s", exc)
            return
        with self._lock:
            if key not in self._kept and len(self._kept) >= MAX_KEYS:
                log.error("refused a stop on %s: %d cells kept already", key, MAX_KEYS)
                return
            before = self._kept.get(key)
            self._kept[key] = stop
            changed = before is None or before.engaged != stop.engaged
            if changed:
                self._dirty = False
                self._save(dict(self._kept), self.unreadable)
            else:
                self._dirty = True
                if self._timer is None:
                    self._timer = threading.Timer(REPEAT_WRITE_S, self._write_repeats)
                    self._timer.daemon = True
                    self._timer.start()
        log.log(
            logging.WARNING if changed else logging.DEBUG,
            "emergency stop %s on %s: %s%s",
            "ENGAGED" if stop.engaged else "released",
            key,
            stop.reason or "(no reason)",
            f" (by {stop.by})" if stop.by else "",
        )

    def _on_query(self, query: zenoh.Query) -> None:
        asked = str(query.key_expr)
        if "*" in asked:  # every cell that has a stop kept
            with self._lock:
                keys = [key for key in self._kept if zenoh.KeyExpr(asked).intersects(key)]
        else:
            keys = [asked]
        for key in keys:
            try:
                query.reply(key, self.kept(key).encode())
            except zenoh.ZError as exc:  # the querier went away meanwhile
                log.debug("latch query not answered: %s", exc)

    def _write_repeats(self) -> None:
        """Write the repeated stops kept since the last write, if any."""
        with self._lock:
            self._timer = None
            if self._dirty:
                self._dirty = False
                self._save(dict(self._kept), self.unreadable)

    # --- the file ---------------------------------------------------------------------------
    def _load(self) -> None:
        try:
            if not self.path.exists():
                return
            with self.path.open("rb") as handle:
                raw = handle.read(MAX_FILE_BYTES + 1)
            if len(raw) > MAX_FILE_BYTES:
                raise ValueError(f"larger than {MAX_FILE_BYTES} bytes")
            document = json.loads(raw)
            stops = document["stops"]
            if not isinstance(stops, dict):
                raise ValueError("'stops' is not a table")
            kept = {
                str(key): EmergencyStop.decode(json.dumps(value).encode(), str(key))
                for key, value in list(stops.items())[:MAX_KEYS]
            }
            unreadable = document.get("unreadable")
        except (OSError, ValueError, KeyError, TypeError, MessageError) as exc:
            self.unreadable = f"{self.path}: {exc}"[:200]
            return
        self._kept = kept
        self.unreadable = str(unreadable)[:200] if unreadable else None

    def _save(self, stops: dict[str, EmergencyStop], unreadable: str | None) -> None:
        """Write ``stops`` atomically (a crash leaves the old file or the new, never half)."""
        document: dict[str, object] = {
            "version": 1,
            "stops": {key: json.loads(stop.encode()) for key, stop in stops.items()},
        }
        if unreadable is not None:
            document["unreadable"] = unreadable
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            partial = self.path.with_suffix(".json.partial")
            with partial.open("w", encoding="utf-8") as handle:
                json.dump(document, handle, indent=1)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(partial, self.path)
            self.writes += 1
            directory = os.open(self.path.parent, os.O_RDONLY)
            try:
                os.fsync(directory)
            finally:
                os.close(directory)
        except OSError as exc:  # kept in memory still: this router answers right until it stops
            log.error("the emergency-stop latch could not be written to %s: %s", self.path, exc)
