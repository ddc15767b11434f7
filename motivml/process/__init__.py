"""What a process running one command may skip, and what it must not: the memory and process
policy of motivml, on the ground floor so that every stage can follow it.

A one-shot command (`validate`, `configure`, `analyse`: the CLI runs it inside
`one_command`) builds large objects once and then ends. It may

- pause the cyclic garbage collector while it builds them (`no_gc`: they hold no cycles)
  and freeze them afterwards, so that no later collection walks them again;
- leave a large object no longer needed (a solver) to the end of the process, which frees
  it anyway (`keep_till_exit`), once the process says it ends with its command
  (`ending_with_the_command`) or, for a forked child, at once (`ending_at_once`).

Long-running commands (`run`, the configurator) use none of this: they keep Python's own
collection and free what they no longer need. A child forked for one job (`forked`) ends
with `os._exit` and frees nothing.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator

_freezing = False  # inside `one_command`: what a pause built is frozen when it ends


@contextlib.contextmanager
def no_gc() -> Iterator[None]:
    """Pause the cyclic garbage collector while building many objects.

    JSON values hold no reference cycles, and each full collection walks every object
    alive: with a 100,000-feature model in memory that made parsing several times slower.
    Inside `one_command`, the objects are frozen when the pause ends, so that the first
    collection after it does not walk them all either.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            if _freezing:
                gc.freeze()
            gc.enable()


_process_ends = False  # this process ends when its one command does (`ending_with_the_command`)


def ending_with_the_command() -> None:
    """Say that this process ends when its command does (the motivml program, whose
    one-job commands end it at once): inside `one_command`, what the end of the process
    frees anyway need not be freed before (`keep_till_exit`)."""
    global _process_ends
    _process_ends = True


_at_once = False  # this process ends with os._exit once its job is done (`ending_at_once`)


def ending_at_once() -> None:
    """Say that this process ends with `os._exit` once its job is done (a child forked by
    `forked.InChild`): nothing it holds need ever be freed (`keeping_all`)."""
    global _at_once
    _at_once = True


def keep_till_exit() -> bool:
    """Whether a large object no longer needed (a solver: 0.1 s to delete at 100,000
    features) may be left for the end of the process, which is near."""
    return _at_once or (_process_ends and _freezing)


def keeping_all() -> bool:
    """Whether every such object is left, not just the last one (`ending_at_once`)."""
    return _at_once


@contextlib.contextmanager
def one_command() -> Iterator[None]:
    """The time of one command of a process that does little else (the CLI's validate,
    configure, analyse ...).

    When a pause of the collector (`no_gc`) ends, the objects alive then (a model, its
    encoding) are frozen (`gc.freeze`): the collections that follow skip them, instead of
    the first one walking every object the pause built (0.6 s of a 3 s `validate --config`
    at 100,000 features). Frozen objects are still freed by reference counting, and are
    given back to the collector (`gc.unfreeze`) when the command ends. Long-running
    commands (run, the configurator) do not use this: they keep their own collection policy.
    """
    global _freezing
    before = _freezing
    _freezing = True
    try:
        yield
    finally:
        _freezing = before
        if not before:
            gc.unfreeze()
