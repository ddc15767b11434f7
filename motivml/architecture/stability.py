"""When a component's integration diverges: the rule the builder refuses a build by, on the
typed elements alone (no numpy), so that `validate` can apply it before anything runs.

A component steps every `divider` loop ticks, `divider = max(1, round(loop rate / its rate))`;
semi-implicit Euler diverges once alpha * step / tau >= 2, where tau is 1 for a point
attractor and a DMP's duration (its `duration`, else its demonstration's length, else 1 s).
"""

from __future__ import annotations

from ..errors import Diagnostic, error
from .document import Architecture
from .elements import Component, DMPParameters, PointAttractorParameters

DEFAULT_RATE = 1000.0  # Hz: the loop rate of `motivml run` when --rate is not given


def divider(loop_rate: float, component: Component) -> int:
    """Every how many loop ticks the component steps (its rate, or every tick)."""
    rate = component.rate if component.rate is not None else loop_rate
    return max(1, round(loop_rate / rate))


def unstable(
    architecture: Architecture, component: Component, loop_rate: float, every: int | None = None
) -> list[Diagnostic]:
    """An error per system of the component's module that its step would make diverge."""
    step = (every if every is not None else divider(loop_rate, component)) / loop_rate
    found: list[Diagnostic] = []
    module = component.module
    for system in module.systems:
        if isinstance(system, PointAttractorParameters):
            tau = 1.0
        elif isinstance(system, DMPParameters):
            shown = system.demonstration
            tau = (
                system.duration
                if system.duration is not None
                else (len(shown.samples) - 1) * shown.dt
                if shown is not None
                else 1.0
            )
        else:
            continue
        if system.alpha * step / tau >= 2.0:
            found.append(
                error(
                    architecture.locate(
                        "components", component.id, "rate" if component.rate is not None else "module"
                    ),
                    f"{component.id} steps every {step:g} s, too coarse for module {module.id} "
                    f"(alpha {system.alpha:g}{f', duration {tau:g} s' if tau != 1.0 else ''}): the "
                    f"integration diverges unless alpha * step / duration < 2",
                    "build.stability",
                    component.feature,
                )
            )
    return found


def stability(architecture: Architecture, loop_rate: float = DEFAULT_RATE) -> list[Diagnostic]:
    """The stability errors of every component at a loop rate: what `validate` reports, so that
    no variant it passes (nor a reconfiguration bringing any component) is refused at build."""
    found: list[Diagnostic] = []
    for component in architecture.components.values():
        found += unstable(architecture, component, loop_rate)
    return found
