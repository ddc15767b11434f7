"""One job in a second process: a child forked from this one does it while this one goes on,
and sends its result back, pickled (`InChild`); and what every such child does to stay
harmless (`die_with_parent`, `end`).

Big documents are checked this way beside what the caller does with them meanwhile (a
model's schema check while the model is read), and `binding.check` explains a model's
warnings so while it searches. Only where `os.fork` exists and this process runs no other
thread (a fork copies the calling thread alone: another one may hold a lock the child
needs); elsewhere, and whenever the child fails, the caller does the job itself.

Not `concurrent.futures.ProcessPoolExecutor` with a fork context: its workers are forked
before the job exists and receive it pickled, whereas the point here is a child that
inherits the job's large unpicklable state (a parsed model, a solver) at the moment of the
fork, is sent further requests while it works (`ask`), and dies with its parent.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable
from typing import Any, BinaryIO, Generic, NoReturn, TypeVar

T = TypeVar("T")

HELD = {signal.SIGINT, signal.SIGTERM}  # held back from a fork until the child is set up
_PR_SET_PDEATHSIG = 1  # prctl(2) (linux/prctl.h)
_OOM_SCORE = "/proc/self/oom_score_adj"  # (proc(5))


def can_fork() -> bool:
    """Whether a child may be forked here now (`os.fork` exists, no other thread runs)."""
    return hasattr(os, "fork") and threading.active_count() == 1


class Failed:
    """What `InChild.result` gives when the child sent no result (it raised, died, or sent
    something unreadable)."""


FAILED = Failed()


class InChild(Generic[T]):
    """`job(requests)` run in a child process forked by `start`; `ask` sends it requests,
    each a pickle on `requests`, and `result()` is what the job returned."""

    def __init__(self, pid: int, requests: BinaryIO, answers: BinaryIO) -> None:
        self.pid, self._requests, self._answers = pid, requests, answers
        self._writing: threading.Thread | None = None

    @classmethod
    def start(cls, job: Callable[[BinaryIO], T]) -> InChild[T] | None:
        """The child, forked now and at work; None if it cannot be (nothing is left behind).

        Ctrl-C and SIGTERM are held back from the fork until the child is set up (or
        ended), so that an interruption never leaves it unreaped or running this process's
        own exit path."""
        held = HELD & signal.valid_signals()
        parent = os.getpid()
        made: InChild[T] | None = None
        pipes: list[int] = []
        signal.pthread_sigmask(signal.SIG_BLOCK, held)
        try:
            try:
                down, up = os.pipe(), os.pipe()
                pipes = [*down, *up]
                pid = os.fork()
            except OSError:
                for fd in pipes:
                    os.close(fd)
                return None
            if pid == 0:  # pragma: no cover - the child (coverage does not follow a fork): `_child` is tested here
                _child(job, down[0], up[1], parent, (down[1], up[0]))
            os.close(down[0])
            os.close(up[1])
            try:
                made = cls(pid, open(down[1], "wb"), open(up[0], "rb"))
            except BaseException as failed:
                end(pid)
                for fd in (down[1], up[0]):
                    try:
                        os.close(fd)
                    except OSError:
                        pass
                if isinstance(failed, OSError):  # (as a failed fork: the caller does the job)
                    return None
                raise
        finally:
            unblock(held, made)
        return made

    def ask(self, what: object) -> None:
        """Send `what`, from a thread: a request larger than the pipe holds would otherwise
        hold this process up until the child, still at other work, reads it."""
        if not self.pid:  # (ended already: nothing to send)
            return
        import pickle

        if self._writing is not None:
            self._writing.join()  # (in order)
        writing = threading.Thread(target=self._write, args=(pickle.dumps(what),), name="motivml-child-ask")
        try:
            writing.start()
        except RuntimeError:  # (no thread to be had: the child gets nothing, and `result` is FAILED)
            end(self.pid)
            self.pid = 0
            return
        self._writing = writing

    def _write(self, message: bytes) -> None:
        try:
            self._requests.write(message)
            self._requests.flush()
        except (OSError, ValueError):  # (the child has gone, or the pipe was closed: no result)
            pass

    def result(self) -> T | Failed:
        """What the job returned (waiting for it); FAILED if the child sent nothing usable."""
        if self._writing is not None:
            self._writing.join()
        if not self.pid:
            return FAILED
        import pickle

        try:
            found: T = pickle.load(self._answers)
        except Exception:  # noqa: BLE001 - an unpickling error, end of file, an OSError: no result
            return FAILED
        return found

    def close(self) -> None:
        """End the child (at once, if it is still at work) and reap it."""
        if self.pid:
            end(self.pid)
            self.pid = 0
        if self._writing is not None:
            self._writing.join()  # (a write to a child killed ends at once)
        for stream in (self._requests, self._answers):
            try:
                stream.close()
            except OSError:
                pass


def unblock(held: set[signal.Signals], made: InChild[Any] | None) -> None:
    """Let the signals held back from a fork through; a Ctrl-C waiting among them (raised
    here) first ends the child just made, so that none is left unreaped."""
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, held)
    except BaseException:
        if made is not None:
            made.close()
        raise


def _child(
    job: Callable[[BinaryIO], object], requests: int, answers: int, parent: int, unused: tuple[int, ...] = ()
) -> NoReturn:
    """The child's life, from the fork to its end (whatever happens, it ends here): `job`
    with `requests` to read and `answers` to write; `unused` are the parent's ends."""
    code = 1
    try:
        import pickle

        from . import ending_at_once

        for fd in unused:
            os.close(fd)
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # (Ctrl-C is the parent's to handle; it ends this)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD & signal.valid_signals())
        ending_at_once()  # (it ends with os._exit: nothing need be freed before the answer)
        die_with_parent(parent)
        with open(requests, "rb") as asked, open(answers, "wb") as sent:
            pickle.dump(job(asked), sent)
        code = 0
    except BaseException:  # noqa: BLE001, S110 - the parent does the job instead (it sees no result)
        pass
    finally:
        os._exit(code)


def die_with_parent(parent: int) -> None:
    """Linux: this process is killed when its parent (`parent`, its pid from before the
    fork) ends, so that a parent killed outright leaves no child at work, and is the first
    the kernel kills when memory runs out (the parent then does the job itself)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # (it ended before the request took effect, or before the fork)
        raise SystemExit(1)
    try:
        with open(_OOM_SCORE, "w") as adjust:
            adjust.write("1000")
    except OSError:
        pass


def end(pid: int) -> None:
    """Kill a child and reap it."""
    if pid <= 0:  # (0 or -1 would name a whole group of processes)
        return
    try:
        os.kill(pid, signal.SIGKILL)
    except OSError:
        pass
    try:
        os.waitpid(pid, 0)
    except OSError:
        pass
