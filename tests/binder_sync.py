"""Explicit synchronisation with a running robot's binder, for tests on the simulated clock.

The binder prepares a request on its own worker thread and hands the prepared change to
the control loop, which commits it at its next tick; a test that drives the loop itself
must tick once the change has been handed over, not before and not by guessing with
sleeps. `Handover` wraps the runtime's hand-over point (`Runtime.submit`) and its log
(`Runtime.note`) so that a test can wait for either, with a generous timeout that only
guards against a hang.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from types import TracebackType

from motivml.runtime.binder import Outcome
from motivml.runtime.launch import Robot
from motivml.runtime.loop import Commit
from motivml.runtime.requests import change

HANG_GUARD = 30.0  # s: only ever reached if something is stuck


class Handover:
    """While in force: `handed` is set whenever the binder hands a change to the loop, and
    `wait_for_note` waits for a line in the run's log."""

    def __init__(self, robot: Robot) -> None:
        self.runtime = robot.runtime
        self.handed = threading.Event()
        self._noted = threading.Condition()

    def __enter__(self) -> Handover:
        runtime = self.runtime
        submit, note = runtime.submit, runtime.note

        def handing(commit: Commit) -> None:
            submit(commit)
            self.handed.set()

        def noting(text: str) -> None:
            note(text)
            with self._noted:
                self._noted.notify_all()

        runtime.submit = handing  # type: ignore[method-assign]
        runtime.note = noting  # type: ignore[method-assign]
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None
    ) -> None:
        del self.runtime.submit, self.runtime.note  # the class's methods again

    def wait_for_note(self, wanted: Callable[[str], bool]) -> bool:
        """Wait until a note for which `wanted` is true is in the log; False on a hang."""
        with self._noted:
            return self._noted.wait_for(
                lambda: any(wanted(text) for _, _, text in self.runtime.notes), HANG_GUARD
            )


def ask(robot: Robot, text: str) -> Outcome:
    """Make a request through the binder's worker thread, as a caller outside the loop
    does; once the worker has handed its change to the loop, tick once (simulated time)
    so that it commits. A refused request is answered without a tick. (The worker waits
    for the commit without a time limit: a busy machine cannot make it give up.)"""
    action, *features = text.split()
    with Handover(robot) as handover:
        future = robot.binder.submit(change(action, features), timeout=None)
        future.add_done_callback(lambda _: handover.handed.set())
        assert handover.handed.wait(HANG_GUARD), (
            f"{text}: the binder neither answered nor handed a change over"
        )
        if not future.done():
            robot.runtime.tick()
        return future.result(HANG_GUARD)
