"""Running a coordination statechart beside the control loop, with sismic.

`Coordinator` turns a checked `Coordination` into a sismic statechart: states and
transitions one for one, under a hidden root. Guards and actions are calls into the running
robot, the only names their code sees. It then advances the statechart every
`loop rate / coordination rate` ticks, on the control thread, between two ticks: the
simulated sismic clock takes the control time, the queued external events go in, and
`execute()` runs until the statechart is stable. Entered and exited states go into the
run's log. The run may end when a top-level final state is reached.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from sismic.clock import SimulatedClock as StatechartClock
from sismic.interpreter import Interpreter
from sismic.model import BasicState, CompoundState, FinalState, Statechart, Transition

from ..architecture.builder import ComponentInstance
from ..coordination.document import Coordination
from ..errors import describe_exception
from . import requests
from .binder import Binder
from .events import StateChanged
from .loop import Runtime

ROOT = "motivml.root"  # the hidden root state (no state id has a dot)
MAX_STEPS = 1000  # per advance: a chart that takes more does not settle


def _call(action: dict[str, Any]) -> str:
    ((kind, value),) = action.items()
    if kind == "log":
        return f"log({value!r})"
    if kind == "send":
        return f"send({value['space']!r}, {[float(v) for v in value['value']]!r})"
    if kind == "learning":
        return f"set_learning({value['module']!r}, {value['state']!r})"
    if kind in ("start", "stop"):
        return f"{kind}_component({value!r})"
    return f"reconfigure({kind!r}, {list(value)!r})"


def _code(actions: list[dict[str, Any]]) -> str | None:
    return "\n".join(_call(a) for a in actions) or None


def _guard(transition: dict[str, Any]) -> str | None:
    # a microsecond of slack: control times are tick counts divided by the rate, and
    # 0.301 - 0.051 is a hair under 0.25 in floating point
    parts = [f"after({float(transition['after']) - 1e-6!r})"] if "after" in transition else []
    for condition in transition.get("when", []):
        if "component" in condition:
            parts.append(f"status({condition['component']!r}) == {condition['is']!r}")
        else:
            parts.append(f"learning({condition['module']!r}) == {condition['is']!r}")
    return " and ".join(parts) or None


def statechart(coordination: Coordination) -> Statechart:
    """The sismic statechart of a coordination document."""
    chart = Statechart(name="coordination")
    chart.add_state(CompoundState(ROOT, initial=coordination.initial), parent=None)
    for sid, state in coordination.states.items():  # pre-order: parents first
        parent = coordination.parent[sid] or ROOT
        entry, exit_ = _code(state.get("entry", [])), _code(state.get("exit", []))
        element: Any
        if state.get("final"):
            element = FinalState(sid, on_entry=entry, on_exit=exit_)
        elif state.get("states"):
            element = CompoundState(sid, initial=state["initial"], on_entry=entry, on_exit=exit_)
        else:
            element = BasicState(sid, on_entry=entry, on_exit=exit_)
        chart.add_state(element, parent=parent)
    for sid, state in coordination.states.items():
        transitions = state.get("transitions", [])
        for i, transition in enumerate(transitions):
            chart.add_transition(
                Transition(
                    sid,
                    transition["target"],
                    event=transition.get("event"),
                    guard=_guard(transition),
                    action=_code(transition.get("actions", [])),
                    priority=len(transitions) - i,  # document order among a state's transitions
                )
            )
    return chart


class Coordinator:
    def __init__(self, coordination: Coordination, runtime: Runtime, binder: Binder, simulated: bool) -> None:
        self.coordination = coordination
        self.runtime = runtime
        self.binder = binder
        self.simulated = simulated
        self.divider = max(1, round(runtime.rate / coordination.rate))
        self.clock = StatechartClock()
        self._events: list[str] = []
        self._lock = threading.Lock()
        self.history: list[tuple[float, int, str, str]] = []  # (time, tick, "entered"/"exited", state)
        self.finished: tuple[float, int, str] | None = None  # a top-level final state reached
        self.unsettled = False  # the chart kept moving without end, or its code failed: the run stopped
        self.interpreter = Interpreter(
            statechart(coordination), initial_context=self._context(), clock=self.clock
        )

    # -------------------------------------------------------- what guards and actions see
    def _context(self) -> dict[str, Any]:
        runtime = self.runtime

        def component(name: str) -> ComponentInstance | None:
            return next((c for c in runtime.assembly.components if c.id == name), None)

        def status(name: str) -> str:
            c = component(name)
            return "inactive" if c is None else str(c.status) if c.running else "stopped"

        def learning(name: str) -> str:
            module = runtime.assembly.modules.get(name)
            return "inactive" if module is None else str(module.state)

        def send(space: str, value: list[float]) -> None:
            if space not in runtime.assembly.values:
                runtime.note(f"coordination: send to {space} skipped: its feature is not active")
                return
            try:
                runtime.send(space, np.asarray(value))
            except ValueError as exc:  # a running component writes it
                runtime.note(f"coordination: send to {space} skipped: {exc}")

        def set_learning(name: str, state: str) -> None:
            module = runtime.assembly.modules.get(name)
            if module is None:
                runtime.note(f"coordination: learning of {name} skipped: its feature is not active")
                return
            module.set_state(state)

        def start_component(name: str) -> None:
            c = component(name)
            if c is None:
                runtime.note(f"coordination: start of {name} skipped: its feature is not active")
                return
            c.running = True

        def stop_component(name: str) -> None:
            c = component(name)
            if c is None:
                runtime.note(f"coordination: stop of {name} skipped: its feature is not active")
                return
            c.running, c.contribution = False, None

        def reconfigure(action: str, features: list[str]) -> None:
            try:
                request = requests.change(action, features)
            except requests.RequestError as exc:  # (the document's check admits none of these)
                runtime.note(f"coordination: {action} {' '.join(features)}: {exc}")
                return
            if self.simulated:
                outcome = self.binder.request_between_ticks(request)
                verdict = "accepted" if outcome.accepted else f"refused: {outcome.reason}"
                runtime.note(f"coordination: {request}: {verdict}")
            else:  # the outcome arrives later; it goes into the log then
                future = self.binder.submit(request)

                def report(done: Any) -> None:
                    outcome = done.result()
                    verdict = "accepted" if outcome.accepted else f"refused: {outcome.reason}"
                    runtime.note(f"coordination: {request}: {verdict}")

                future.add_done_callback(report)

        return {
            "status": status,
            "learning": learning,
            "log": lambda text: runtime.note(f"coordination: {text}"),
            "send": send,
            "set_learning": set_learning,
            "start_component": start_component,
            "stop_component": stop_component,
            "reconfigure": reconfigure,
        }

    # --------------------------------------------------------------------- driving
    def event(self, name: str) -> None:
        """Queue an external event (any thread); it is handled at the next step."""
        with self._lock:
            self._events.append(name)

    def step(self) -> None:
        """Advance the statechart (the runtime calls this after every tick)."""
        runtime = self.runtime
        if self.finished is not None or (runtime.ticks - 1) % self.divider:
            return
        self.clock.time = runtime.time
        with self._lock:
            events, self._events = self._events, []
        for name in events:
            self.interpreter.queue(name)
        for _ in range(MAX_STEPS):
            try:
                step = self.interpreter.execute_once()
            except Exception as exc:  # a guard or an action that cannot run: say so, stop the run
                cause = exc.__cause__ if isinstance(exc.__cause__, Exception) else exc  # sismic wraps it
                runtime.note(f"coordination failed: {describe_exception(cause)}: the run stops")
                self.unsettled = True
                runtime.stop()
                return
            if step is None:
                break
            for sid in step.exited_states:
                if sid != ROOT:
                    self.history.append((runtime.time, runtime.ticks, "exited", sid))
                    runtime.told.publish(StateChanged(runtime.ticks, False, sid))
            for sid in step.entered_states:
                if sid == ROOT:
                    continue
                self.history.append((runtime.time, runtime.ticks, "entered", sid))
                runtime.told.publish(StateChanged(runtime.ticks, True, sid))
                runtime.note(f"coordination: entered {sid}")
                state = self.coordination.states[sid]
                if state.get("final") and self.coordination.parent[sid] is None:
                    self.finished = (runtime.time, runtime.ticks, sid)
        else:
            runtime.note(
                f"coordination: did not settle within {MAX_STEPS} steps (a cycle of transitions?): the run stops"
            )
            self.unsettled = True
            runtime.stop()

    def configuration(self) -> list[str]:
        """The active states, outermost first."""
        active = set(self.interpreter.configuration)
        return [sid for sid in self.coordination.states if sid in active]
