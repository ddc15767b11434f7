"""W3C SCXML of a coordination statechart.

The structure is plain SCXML 1.0 with the null data model. Each part maps as follows:
- states: `<state>`, or `<final>`;
- compound states: an `initial` attribute;
- entry and exit actions: `<onentry>` and `<onexit>`;
- transitions: `<transition>`, in document order;
- `log` actions: `<log label="...">`;
- `after`: the usual SCXML timer, a delayed `<send>` on entry and a `<cancel>` on exit,
  with the transition waiting for the timer's event (`motivml.after.<state>.<n>`).

What SCXML has no word for is in the namespace `urn:motivml:coordination:1` (prefix `m`),
which SCXML engines accept and ignore:
- domain conditions: `m:when` on the transition, e.g. `component Reacher is converged`;
  the transition waits for the event `motivml.condition`, which the runtime raises whenever
  a component's status or a module's learning state changes, and which the state raises
  itself on entry (`<raise>`), so that a condition already true is seen;
- a transition that needs several of event, time and condition: `m:requires="all"` (SCXML
  reads an event list as alternatives);
- domain actions: `<m:send space= value=>`, `<m:learning module= state=>`, `<m:start>`,
  `<m:stop>`, `<m:load>`, `<m:unload>`, `<m:swap>`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

from .document import Coordination

SCXML = "http://www.w3.org/2005/07/scxml"
MOTIVML = "urn:motivml:coordination:1"
CONDITION_EVENT = "motivml.condition"


def _q(tag: str) -> str:
    return f"{{{SCXML}}}{tag}"


def _m(tag: str) -> str:
    return f"{{{MOTIVML}}}{tag}"


def _actions(parent: ET.Element, actions: list[dict[str, Any]]) -> None:
    for action in actions:
        ((kind, value),) = action.items()
        if kind == "log":
            ET.SubElement(parent, _q("log"), label=value)
        elif kind == "send":
            attributes = {"space": value["space"], "value": " ".join(repr(float(v)) for v in value["value"])}
            ET.SubElement(parent, _m("send"), attributes)
        elif kind == "learning":
            ET.SubElement(parent, _m("learning"), module=value["module"], state=value["state"])
        elif kind in ("start", "stop"):
            ET.SubElement(parent, _m(kind), component=value)
        else:
            ET.SubElement(parent, _m(kind), features=" ".join(value))


def _condition(condition: dict[str, Any]) -> str:
    if "component" in condition:
        return f"component {condition['component']} is {condition['is']}"
    return f"module {condition['module']} is {condition['is']}"


def to_scxml(coordination: Coordination, name: str = "coordination") -> str:
    """The statechart as an SCXML document (UTF-8 text)."""
    ET.register_namespace("", SCXML)
    ET.register_namespace("m", MOTIVML)
    root = ET.Element(
        _q("scxml"), {"version": "1.0", "initial": coordination.initial, "name": name, "datamodel": "null"}
    )
    elements: dict[str | None, ET.Element] = {None: root}
    for sid, state in coordination.states.items():  # pre-order: parents first
        attributes = {"id": sid}
        if state.get("initial"):
            attributes["initial"] = state["initial"]
        element = ET.SubElement(
            elements[coordination.parent[sid]], _q("final" if state.get("final") else "state"), attributes
        )
        elements[sid] = element
        timers = [(i, t) for i, t in enumerate(state.get("transitions", [])) if "after" in t]
        waits = any("when" in t for t in state.get("transitions", []))
        if state.get("entry") or timers or waits:
            entry = ET.SubElement(element, _q("onentry"))
            _actions(entry, state.get("entry", []))
            if waits:  # a condition that already holds on entry must be looked at once
                ET.SubElement(entry, _q("raise"), event=CONDITION_EVENT)
            for i, transition in timers:
                ET.SubElement(
                    entry,
                    _q("send"),
                    event=f"motivml.after.{sid}.{i}",
                    delay=f"{max(1, round(float(transition['after']) * 1000))}ms",  # whole ms: what engines parse
                    id=f"motivml.after.{sid}.{i}",  # an xsd:ID no state id (no dots) can take
                )
        if state.get("exit") or timers:
            leave = ET.SubElement(element, _q("onexit"))
            _actions(leave, state.get("exit", []))
            for i, _ in timers:
                ET.SubElement(leave, _q("cancel"), sendid=f"motivml.after.{sid}.{i}")
        for i, transition in enumerate(state.get("transitions", [])):
            events = [transition["event"]] if "event" in transition else []
            if "after" in transition:
                events.append(f"motivml.after.{sid}.{i}")
            attributes = {"target": transition["target"]}
            if "when" in transition:
                events.append(CONDITION_EVENT)
                attributes[_m("when")] = " and ".join(_condition(c) for c in transition["when"])
            if events:
                attributes["event"] = " ".join(events)
            if len(events) > 1:  # SCXML reads event lists as alternatives; ours must all hold
                attributes[_m("requires")] = "all"
            _actions(ET.SubElement(element, _q("transition"), attributes), transition.get("actions", []))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=False) + "\n"
