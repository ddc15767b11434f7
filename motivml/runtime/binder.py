"""Reconfiguration transactions of a running robot: check, prepare off the loop, commit between ticks.

`Binder` owns the running robot's active set. A request (`load`, `unload`, `reload`,
`swap`) goes through three steps, one request at a time:

1. **check**: `Reconfigurer.plan` applies reference.md section 4 on the SAT encoding. A
   refused request changes nothing, and the refusal says why in `validate`'s words;
2. **prepare**, on the caller's thread, never the control thread: the architecture of the
   new active set is built (the elements that stay are the same objects, with their
   state), and the plugins of the features that load are imported, constructed and started
   (by the run's `PluginHost`, plugin_host.py). If any of that fails, the plugins already
   started are stopped, and nothing is committed;
3. **commit**: the prepared change is queued for the control loop, which applies it at
   once between two ticks: the new architecture, the plugins in, the plugins out. The
   binder then stops the plugins that left, again off the control thread.

A Dynamic plugin that raises in its step has already left the loop's stepping: the run's
`FaultPolicy` (faults.py) unloads it through this transaction, or ends the run.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, TimeoutError
from dataclasses import dataclass, field

from ..architecture.builder import build
from ..architecture.document import Architecture
from ..binding.resolve import Variant
from ..documents.robot_folder import Plugin
from ..errors import Diagnostic, Location, MotivmlError, Severity, error
from ..language.model import Configuration, FeatureModel
from . import events
from .faults import FaultPolicy
from .loop import AppliedReconfiguration, Commit, Fault, Running, Runtime
from .plugin_host import PluginHost, Preparing
from .reconfigure import Plan, Reconfigurer, Refused
from .requests import Reload, Request


@dataclass
class Outcome:
    request: Request
    accepted: bool
    plan: Plan | None = None
    change: AppliedReconfiguration | None = None  # when it took effect
    latency: float = 0.0  # s, from the request's arrival (behind others included) to its commit
    diagnostics: list[Diagnostic] = field(default_factory=list)  # why not (accepted: warnings)
    breaks_relations: bool = False  # refused because the new active set breaks the model's relations

    @property
    def reason(self) -> str:
        return "; ".join(d.message for d in self.diagnostics)


def _answered(outcome: Outcome, tick: int, active: frozenset[str]) -> events.Answered:
    """The event that tells an outcome (`tick`, `active`: now, for one that changed nothing)."""
    plan, change = outcome.plan, outcome.change
    return events.Answered(
        change.tick if change is not None else tick,
        str(outcome.request),
        outcome.accepted,
        outcome.reason,
        plan.loads if plan is not None else (),
        plan.unloads if plan is not None else (),
        plan.after if outcome.accepted and plan is not None else active,
        (change.tick, change.request) if change is not None else None,
    )


class _Inbox:
    """Simulated clock: requests from other threads (the control socket) wait here until
    the control thread takes them, after its next tick (`Binder.make_changes_between_ticks`)."""

    def __init__(self) -> None:
        self._waiting: queue.SimpleQueue[tuple[Request, Future[Outcome], float]] = queue.SimpleQueue()

    def ask(self, request: Request, timeout: float | None, arrived: float) -> Outcome | None:
        """The request's outcome, or None if no tick took it within `timeout` (none will)."""
        future: Future[Outcome] = Future()
        self._waiting.put((request, future, arrived))
        try:
            return future.result(timeout)
        except TimeoutError:
            return None if future.cancel() else future.result()

    def empty(self, answer: Callable[[Request, float], Outcome]) -> None:
        """On the control thread, between two ticks: answer every request waiting."""
        while not self._waiting.empty():
            request, future, arrived = self._waiting.get()
            if future.set_running_or_notify_cancel():
                future.set_result(answer(request, arrived))


class Binder:
    """The transaction of a running robot's changes (see the module's text); it owns the
    active set, the plugin host and the fault policy."""

    def __init__(
        self,
        runtime: Runtime,
        variant: Variant,
        architecture: Architecture | None,
        plugins: dict[str, Plugin],
        active: list[str],
        config: Configuration | None = None,
        robot: str = "robot",
        unimplemented: frozenset[str] = frozenset(),
        strict: bool = False,
        ros_namespace: str = "/",
    ) -> None:
        self.runtime = runtime
        self.variant = variant
        self.architecture = architecture
        self.active = frozenset(active)
        runtime.begin_with(self.active)  # what status() reads, with the plugins, at each commit
        self.unimplemented = unimplemented  # Dynamic features nothing implements: warned about (strict: refused)
        self.strict = strict
        self.reconfigurer = Reconfigurer(variant, config)
        self.host = PluginHost(runtime, variant, plugins, robot, ros_namespace)
        self.plugins = self.host.plugins  # the variant's plugins, by feature
        self.static = self.host.static
        self._lock = threading.Lock()
        self.between_ticks = False  # simulated clock: changes are made on the control thread
        self._inbox = _Inbox()  # (simulated clock: requests of other threads wait for a tick)
        self._bring_elements = (
            {e.feature for e in architecture.elements()} if architecture is not None else set()
        )  # features whose coming or going changes the architecture
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="motivml-binder")
        self.closing = threading.Event()  # the run has ended: no tick will take a commit any more
        self._in_flight: Commit | None = None  # the commit a request waits for
        self.failed_stops: list[str] = []  # plugins whose stop() raised at the end of the run
        self._trying = threading.local()  # .now: this thread is trying a fault's unloads
        self.faults = FaultPolicy(self, runtime)
        runtime.send_faults_to(self.faults.on_fault)

    def start(self) -> None:
        """Start the plugins of the start state (before the loop runs); all or none."""
        self.host.start_state(self.active)

    # --------------------------------------------------------------- requests
    def submit(self, request: Request, timeout: float | None = 5.0) -> Future[Outcome]:
        """Run a request on the binder's worker thread (its latency counted from now)."""
        return self._executor.submit(self.request, request, timeout, time.perf_counter())

    def make_changes_between_ticks(self) -> None:
        """Simulated clock: every change is made on the control thread, between two ticks.

        Requests from other threads (the control socket) wait in an inbox that the control
        thread empties after each tick; so a run is deterministic and no thread ever waits
        for a tick while holding the binder.
        """
        self.between_ticks = True
        self.runtime.after_each_tick(lambda: self._inbox.empty(self.request_between_ticks), first=True)

    def request(self, request: Request, timeout: float | None = 5.0, arrived: float | None = None) -> Outcome:
        """Check, prepare and commit one request; wait (up to `timeout`) for its commit. Its
        latency counts from `arrived` (default: now), the time it waited behind another
        request included."""
        began = time.perf_counter() if arrived is None else arrived
        if self.between_ticks:
            outcome = self._inbox.ask(request, timeout, began)
            if outcome is None:
                message = f"the control loop did not take the request within {timeout:g} s: nothing changed"
                return self._timed_out(request, None, message)
            return outcome
        with self._lock:
            prepared = self._check_and_prepare(request)
            if isinstance(prepared, Outcome):
                return prepared
            plan, commit = prepared
            self._in_flight = commit
            try:
                self.runtime.submit(commit)
                if self.closing.is_set():
                    self._give_up(commit)
                else:
                    self.runtime.commit_waiting()
                taken = commit.done.wait(timeout)
            finally:
                self._in_flight = None
            if (not taken and self.runtime.withdraw(commit)) or commit.withdrawn:
                self.host.unswitch(self._leaving(commit), [])
                for running in commit.add.values():
                    self.host.stop(running)
                message = (
                    "the run ended before the control loop took the change: nothing changed"
                    if commit.withdrawn and taken
                    else f"the control loop did not take the change within {timeout:g} s: nothing changed"
                )
                return self._timed_out(request, plan, message)
            commit.done.wait()
            return self._committed(plan, commit, began)

    def request_between_ticks(self, request: Request, arrived: float | None = None) -> Outcome:
        """A request made by the control thread itself, between two ticks: committed at once.

        For scheduled requests on the simulated clock (`motivml run --at`): the same check
        and preparation, then the commit applied here instead of by the next tick.
        """
        with self._lock:
            began = time.perf_counter() if arrived is None else arrived
            prepared = self._check_and_prepare(request)
            if isinstance(prepared, Outcome):
                return prepared
            plan, commit = prepared
            self.runtime.submit(commit)
            self.runtime.commit_now()
            return self._committed(plan, commit, began)

    def _check_and_prepare(self, request: Request) -> tuple[Plan, Commit] | Outcome:
        """The plan and its prepared commit, or the outcome that says why there is none."""
        try:
            plan = self.reconfigurer.plan(self.active, request, repairs=not getattr(self._trying, "now", False))
        except Refused as refused:
            return self._refused(
                Outcome(
                    request, False, diagnostics=refused.diagnostics, breaks_relations=refused.breaks_relations
                )
            )
        hollow = [f for f in plan.loads if f in self.unimplemented]
        if hollow and self.strict:
            return self._refused(
                Outcome(request, False, plan, diagnostics=self._hollow(hollow, Severity.ERROR))
            )
        try:
            commit = self._prepare(plan)
        except MotivmlError as failed:
            return self._refused(Outcome(request, False, plan, diagnostics=failed.diagnostics))
        try:
            self.host.switch(self._leaving(commit), list(commit.add.values()))
        except MotivmlError as failed:
            for running in commit.add.values():
                self.host.stop(running)
            return self._refused(Outcome(request, False, plan, diagnostics=failed.diagnostics))
        return plan, commit

    # ---------------------------------------------------------------- switch
    def _leaving(self, commit: Commit) -> list[Running]:
        return [self.runtime.plugins[f] for f in commit.remove if f in self.runtime.plugins]

    def _hollow(self, features: list[str], severity: Severity) -> list[Diagnostic]:
        verb = "would be" if severity is Severity.ERROR else "is now"
        return [unimplemented_feature(self.variant.model, f, verb, severity) for f in features]

    def _timed_out(self, request: Request, plan: Plan | None, message: str) -> Outcome:
        """Refused: the control loop did not take the request or its change (in time)."""
        return self._refused(
            Outcome(request, False, plan, diagnostics=[error(Location("run"), message, "reconfigure.timeout")])
        )

    def _refused(self, outcome: Outcome) -> Outcome:
        """Every refusal goes into the run's log as it happens, with its reason (but a fault's
        tries at unloading, ancestor by ancestor: what they came to is noted instead)."""
        if getattr(self._trying, "now", False):
            return outcome
        self.runtime.note(f"refused {outcome.request}: {outcome.reason}")
        self.runtime.told.publish(events.Refused(self.runtime.ticks, str(outcome.request), outcome.reason))
        return self._tell(outcome)

    def _tell(self, outcome: Outcome) -> Outcome:
        """Every answer is told to the run's listeners (a front door tells its node), on the
        requesting thread with the binder held, so that they hear the answers in order; a
        listener's bug never undoes a commit (the listeners say it in the log)."""
        self.runtime.told.publish(_answered(outcome, self.runtime.ticks, self.active))
        return outcome

    def _committed(self, plan: Plan, commit: Commit, began: float) -> Outcome:
        """After the commit: stop the plugins that left, take the new active set."""
        for running in commit.removed:
            self.host.stop(running)
        self.active = plan.after
        change = commit.change
        assert change is not None
        hollow = [f for f in plan.loads if f in self.unimplemented]
        if hollow:
            self.runtime.note(
                f"{plan.request}: nothing implements {', '.join(hollow)}: active as a feature only"
            )
        return self._tell(
            Outcome(
                plan.request,
                True,
                plan,
                change,
                change.clock - began,
                diagnostics=self._hollow(hollow, Severity.WARNING),
            )
        )

    def _prepare(self, plan: Plan) -> Commit:
        assembly = None
        moved = set(plan.loads) | set(plan.unloads)
        if self.architecture is not None and moved & self._bring_elements:
            assembly, _ = build(self.architecture, set(plan.after), self.runtime.rate, self.runtime.assembly)
        preparing = Preparing(assembly)
        add = self.host.start_instances(plan.loads, preparing, fresh=isinstance(plan.request, Reload))
        remove = tuple(f for f in plan.unloads if f in self.runtime.plugins)
        return Commit(
            str(plan.request), plan.loads, plan.unloads, assembly, add, remove, writes=preparing.writes, active=plan.after
        )

    def _give_up(self, commit: Commit) -> None:
        """Withdraw a commit no tick will take, and wake the request waiting for it."""
        if self.runtime.withdraw(commit):
            commit.done.set()  # (withdrawn: the request sees it was not applied)

    # ----------------------------------------------------------------- faults
    def quietly(self, request: Request) -> Outcome:
        """A request of the fault policy (faults.py): checked and committed like any other,
        without repairs, and a refusal is neither noted nor told to the listeners."""
        self._trying.now = True
        try:
            return self.request_between_ticks(request) if self.between_ticks else self.request(request)
        finally:
            self._trying.now = False

    def on_its_thread(self, job: Callable[[Fault], None], fault: Fault) -> None:
        """Run `job` on the binder's worker thread, after the requests before it."""
        self._executor.submit(job, fault)

    def close(self) -> None:
        """Stop every plugin, after the request in flight (if any) has ended.

        The run has ended, so a request still waiting for a tick (a fault's unload, say)
        gives up at once instead of waiting out its timeout.
        """
        self.closing.set()
        pending = self._in_flight
        if pending is not None:
            self._give_up(pending)
        self._executor.shutdown(wait=True)
        settled = self._lock.acquire(timeout=10.0)  # a request from the socket may be preparing
        try:
            self.failed_stops += self.host.stop_all()
        finally:
            if settled:
                self._lock.release()
        self.reconfigurer.close()
        self.host.close()


def unimplemented_feature(model: FeatureModel, feature: str, verb: str, severity: Severity) -> Diagnostic:
    """A Dynamic feature that nothing implements (no plugin, no architecture element) is active."""
    where = (
        model.source.locate(model.path(model.index[feature], "id")) if model.source else Location(model.name)
    )
    return Diagnostic(
        severity,
        where,
        f"{feature} {verb} active and Dynamic, but nothing implements it: no plugin and no architecture "
        f"element (mark it abstract if it only groups others; run --strict refuses it)",
        "run.unimplemented",
        feature,
    )
