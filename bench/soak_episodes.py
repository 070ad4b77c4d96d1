"""Real episodes while the soak's hostile load runs: ``manigraph run --blocks 4 --episodes 1``,
one after another, on the soaked stack (``bench/soak.py``); an episode that fails for
``timeout`` or ``no_progress``, or whose run does not finish, is a *hung* episode."""

from __future__ import annotations

import collections
import json
import subprocess
import threading

from soak_stack import SoakStack  # bench/soak_stack.py

HUNG_REASONS = ("timeout", "no_progress")  # what the run client says of an episode that hung


class EpisodesMeanwhile:
    """Real ``manigraph run --blocks 4 --episodes 1`` runs, one after another, in a thread."""

    def __init__(self, soak: SoakStack, run_timeout: float = 1800.0) -> None:
        self.soak = soak
        self.run_timeout = run_timeout
        self.results: list[dict[str, object]] = []
        self.hung = 0
        self.failed = 0
        self._reasons: collections.Counter[str] = collections.Counter()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        """Let the episode under way finish, then stop."""
        self._done.set()
        self._thread.join()

    def _loop(self) -> None:
        seed = 1000
        while not self._done.is_set():
            args = ("run", "--blocks", "4", "--episodes", "1", "--seed", str(seed), "--json")
            try:
                result = self.soak.running.run(*args, timeout=self.run_timeout)
            except subprocess.TimeoutExpired:
                self.hung += 1
                self._reasons["run did not finish"] += 1
                continue
            seed += 1
            lines = result.stdout.strip().splitlines()
            if not lines or not lines[-1].startswith("{"):
                self.failed += 1
                self._reasons[f"no summary (exit {result.returncode})"] += 1
                continue
            for episode in json.loads(lines[-1])["results"]:
                self.results.append(episode)
                if episode["success"]:
                    continue
                reason = str(episode["reason"])
                self._reasons[reason.split(":")[0]] += 1
                if reason.startswith(HUNG_REASONS):
                    self.hung += 1
                else:
                    self.failed += 1

    def summary(self) -> str:
        done = sum(bool(r["success"]) for r in self.results)
        return f"episodes meanwhile: {done}/{len(self.results)} succeeded, {self.hung} hung"

    def failures(self) -> str:
        return ", ".join(f"{reason} x{n}" for reason, n in self._reasons.items())
