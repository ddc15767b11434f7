"""What a plugin's fault does to a running robot.

A Dynamic plugin that raises in its step has already left the loop's stepping (the loop
marks it faulted). `FaultPolicy` then unloads its feature with its subtree, or, if the model
does not allow that, the nearest Dynamic ancestor whose unload it allows, each try checked
like any request. If no unload is allowed, the run ends with the fault as its failure. A
Static plugin's fault ends the run at once (the loop's own `Runtime.failure`).

The unloads are requests of the run's transaction (`binder.py`), made quietly: a refused
try is not news, only what the tries came to goes into the run's notes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .loop import Fault, Runtime
from .requests import Unload

if TYPE_CHECKING:
    from .binder import Binder


class FaultPolicy:
    """Unloads after a Dynamic plugin's fault, on the binder's thread (real clock) or at once
    on the control thread (simulated clock: between two ticks)."""

    def __init__(self, binder: Binder, runtime: Runtime) -> None:
        self.binder = binder
        self.runtime = runtime

    def on_fault(self, fault: Fault) -> None:
        """Called on the control thread. Between ticks (simulated clock) the unload happens
        right here; otherwise on the binder's thread, while the loop goes on."""
        if self.binder.between_ticks:
            self.unload_faulty(fault)
        else:
            self.binder.on_its_thread(self.unload_faulty, fault)

    def unload_faulty(self, fault: Fault) -> None:
        binder, runtime = self.binder, self.runtime
        running = runtime.plugins.get(fault.feature)
        if running is None or not running.faulted or fault.feature not in binder.active:
            runtime.note(f"the fault of {fault.feature}: it has already left the loop")
            return
        model = binder.variant.model
        node: int | None = model.index[fault.feature]
        reasons = []
        while node is not None:
            feature = model.features[node].id
            if feature in binder.active and not binder.static[feature]:
                outcome = binder.quietly(Unload((feature,), cause=f"after the fault of {fault.feature}"))
                if outcome.accepted:
                    runtime.note(f"unloaded {feature} after the fault of {fault.feature}")
                    return
                if binder.closing.is_set():  # the run has ended: nothing to keep safe any more
                    runtime.note(f"the fault of {fault.feature}: the run ended before its unload")
                    return
                reasons.append(outcome.reason)
                if not outcome.breaks_relations:
                    break  # refused for another reason than the model: an ancestor would not help
            node = model.features[node].parent
        runtime.note(f"cannot unload {fault.feature} after its fault: {'; '.join(reasons) or 'it is Static'}")
        runtime.fail(fault)
