"""The progress bar of every command that can take more than a moment (analyse, sample,
import, export, configure): on a terminal's stderr after a second, never on a pipe."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from .common import err

if TYPE_CHECKING:
    from rich.progress import Progress

PROGRESS_AFTER = 1.0  # seconds: a quicker command shows no progress bar


class ProgressBar:
    """A progress bar on stderr, shown once a command has taken PROGRESS_AFTER seconds, on a
    terminal only and not when asked not to (`shown`: False with --format json); it names
    the step under way and how far the command is. Ctrl-C still ends the command: the bar
    is a daemon timer's, and stops with the command."""

    def __init__(self, total: int, shown: bool = True) -> None:
        self.total = total
        self.done = -1
        self.name = ""
        self.lock = threading.Lock()
        self.progress: Progress | None = None
        self.closed = False
        self.shown = shown
        self.timer = threading.Timer(PROGRESS_AFTER, self._show)
        self.timer.daemon = True

    def __enter__(self) -> ProgressBar:
        if self.shown and err.is_terminal:
            self.timer.start()
        return self

    def step(self, name: str) -> None:
        with self.lock:
            self.done += 1
            self.name = name
            if self.progress is not None:
                self.progress.update(self.task, completed=self.done, description=name)

    def reached(self, done: int, total: int, name: str = "combinations settled") -> None:
        """Progress as a count (`sample`: the combinations settled of all)."""
        with self.lock:
            self.done, self.total, self.name = done, total, name
            if self.progress is not None:
                self.progress.update(self.task, completed=done, total=total, description=self.name)

    def _show(self) -> None:
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        with self.lock:
            if self.closed:
                return
            progress = Progress(
                TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(), console=err, transient=True
            )
            self.task = progress.add_task(self.name, total=self.total, completed=max(self.done, 0))
            progress.start()
            self.progress = progress

    def __exit__(self, *exc: object) -> None:
        self.timer.cancel()
        with self.lock:
            self.closed = True
            if self.progress is not None:
                self.progress.stop()
