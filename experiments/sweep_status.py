"""The state of a sweep's trials, collected while it runs and shown as a table.

Trials report their step counts to a :class:`ProgressBoard` (a Ray actor in the sweep; a plain class here, so
that this module imports nothing heavy in the actor's process). :class:`LiveTable` redraws the table in place
on a terminal and, when the output is a file or a pipe, prints it only when a trial changes state (or, for
long trials, every ``log_every_s`` seconds), so that logs stay readable.
"""

from __future__ import annotations

import shutil
import sys
import time
from dataclasses import dataclass
from typing import TextIO

# "landed": skipped for its export (--skip-landed); the last three are --plan's: what a trial would do
STATES = ("pending", "running", "finished", "stopped", "failed", "done before", "landed", "to start", "to resume",
          "conflict")


class ProgressBoard:
    """Steps done so far per trial key, as the trials report them."""

    def __init__(self) -> None:
        self.steps: dict[str, int] = {}

    def report(self, key: str, steps: int) -> None:
        self.steps[key] = int(steps)

    def snapshot(self) -> dict[str, int]:
        return dict(self.steps)


@dataclass
class TrialStatus:
    """One row of the table: a trial's state, steps (done / requested), score and a note (time or error)."""

    key: str
    total: int
    state: str = "pending"
    steps: int = 0
    score: float | None = None
    note: str = ""


def render(rows: list[TrialStatus], elapsed_s: float | None) -> str:
    """The table of ``rows`` under a one-line count of trials per state (and the time elapsed, where given)."""
    counts = {s: sum(r.state == s for r in rows) for s in STATES}
    head = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    width = max([len("trial"), *(len(r.key) for r in rows)])
    clock = "" if elapsed_s is None else f"; {_clock(elapsed_s)} elapsed"
    lines = [f"sweep: {len(rows)} trials: {head}{clock}",
             f"{'trial':<{width}}  {'state':<11}  {'steps':>23}  {'score':>6}  note"]
    for r in rows:
        steps = f"{r.steps:,} / {r.total:,}"
        score = "" if r.score is None else f"{r.score:.1f}"
        lines.append(f"{r.key:<{width}}  {r.state:<11}  {steps:>23}  {score:>6}  {r.note}".rstrip())
    return "\n".join(lines)


def _clock(seconds: float) -> str:
    m, s = divmod(int(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class LiveTable:
    """Shows ``render(rows)`` while a sweep runs: redrawn in place on a terminal, printed on changes otherwise."""

    def __init__(self, stream: TextIO | None = None, interactive: bool | None = None, log_every_s: float = 60.0):
        self.stream = stream or sys.stdout
        self.interactive = self.stream.isatty() if interactive is None else interactive
        self.log_every_s = log_every_s
        self.start = time.monotonic()
        self._drawn_lines = 0
        self._last_states: list[str] | None = None
        self._last_print = float("-inf")

    def update(self, rows: list[TrialStatus]) -> None:
        states = [r.state for r in rows]
        now = time.monotonic()
        if not self.interactive and states == self._last_states and now - self._last_print < self.log_every_s:
            return
        self._last_states, self._last_print = states, now
        self._show(render(rows, now - self.start))

    def close(self, rows: list[TrialStatus]) -> None:
        """The final table, with lines in full (in place of the live one on a terminal)."""
        self._show(render(rows, time.monotonic() - self.start), clip=False)
        self._drawn_lines = 0

    def _show(self, text: str, clip: bool = True) -> None:
        if self.interactive and clip:  # one screen row per line: a wrapped line would throw off the redraw
            width = shutil.get_terminal_size().columns - 1
            text = "\n".join(line[:width] for line in text.splitlines())
        if self.interactive and self._drawn_lines:
            self.stream.write(f"\x1b[{self._drawn_lines}F\x1b[J")  # back to the table's first line, clear below
        self.stream.write(text + "\n")
        self.stream.flush()
        self._drawn_lines = text.count("\n") + 1 if self.interactive else 0
