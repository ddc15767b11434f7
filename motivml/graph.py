"""Pictures of a robot: its feature model and its motion architecture, as DOT and GraphML.

The feature model is drawn like a FODA diagram: the tree from the root down, a filled dot
at a mandatory child and an empty one at an optional child, an OR group as a filled
triangle under its parent and an XOR group as an empty one, and `requires` / `excludes`
constraints as dashed edges that do not bend the tree. Each feature shows its name and the
binding it allows ("SLAM\\nDynamic · Late"); drawn for a resolved variant, a selected
feature shows its concrete binding ("Static Early") and an unselected one is greyed out.

The motion architecture shows spaces as ellipses (`id`, `Type(dim) [unit]`), mappings as
diamonds, and components as records holding their module (dynamical systems, learners) and
criterion, grouped in one cluster per feature that brings them. Goal edges run into a
component, dashed feedback edges too, output edges out of it. Edges follow the data as the
builder moves it: a free mapping (on no port) computes its `to` space from its `from`
space, while a port's mapping converts on that port only, so it sits between the port's
space and the component and its module-side end is recorded as data, not drawn. Drawn for
a set of active features, only their elements appear; a reference to an element left out
shows as a dashed placeholder rather than vanishing.

DOT is for people (`render_svg`); GraphML is for tools (yEd, Gephi, networkx) and carries
the same facts as data keys. Output is deterministic (pre-order for features, document
order for the architecture) and built in flat loops: 100,000 features nested 2,000 deep
need no recursion.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Protocol
from xml.sax.saxutils import escape, quoteattr

from .architecture.document import Architecture
from .architecture.elements import Element, Module
from .errors import EnvironmentProblem, Location, error
from .language.model import Binding, Feature, FeatureModel, token

Value = str | int | float | bool
GRAPHML_NS = "http://graphml.graphdrawing.org/xmlns"
_FILLS = {Binding.SE: "#dbe9f6", Binding.SL: "#d9f0d3", Binding.DE: "#fde9c9", Binding.DL: "#f6d5e5"}
_FADED = {"style": "dashed", "color": "grey60"}
_UNSELECTED = _FADED | {"style": "rounded,dashed,filled", "fillcolor": "#f2f2f2", "fontcolor": "grey50"}
_GROUP = {"shape": "invtriangle", "style": "filled", "width": "0.3", "height": "0.25", "fixedsize": "true"}
_REQUIRES = {"style": "dashed", "constraint": "false", "color": "#2166ac"}
_EXCLUDES = _REQUIRES | {"color": "#b2182b", "dir": "both", "arrowhead": "tee", "arrowtail": "tee"}
_MAPPING_SHAPES = {"mapping": "diamond", "transformation": "Mdiamond", "adaptiveMapping": "diamond"}
# Characters XML 1.0 cannot carry (and that have no business in a label): shown as U+FFFD.
_ILLEGAL = [*range(0x09), 0x0B, 0x0C, *range(0x0E, 0x20), 0x7F, *range(0xD800, 0xE000), 0xFFFE, 0xFFFF]
_CLEAN = dict.fromkeys(_ILLEGAL, "\ufffd")
# Graphviz decodes HTML entities before label escapes: `&` must become `&amp;`, and a
# backslash `\\` (never `&#92;`, which would turn back into an escape such as `\n`).
_DOT = _CLEAN | {ord("&"): "&amp;", ord("\\"): "\\\\", ord('"'): '\\"', ord("\n"): "\\n", ord("\r"): "\\n"}
_RECORD_SPECIAL = re.compile(r"([{}|<>])")


class DecisionLike(Protocol):
    """What the picture needs of a `configure.Decision` (configure sits on a floor above)."""

    @property
    def feature(self) -> Feature: ...
    @property
    def selected(self) -> bool: ...
    @property
    def binding(self) -> Binding: ...


class VariantLike(Protocol):
    """What the picture needs of a `configure.Variant`."""

    @property
    def decisions(self) -> Sequence[DecisionLike]: ...


@dataclass(slots=True)
class _Node:
    id: str
    label: str  # DOT label, already escaped
    dot: dict[str, str]
    data: dict[str, Value]
    cluster: str = ""
    only: str = ""  # "dot" or "graphml" when the element belongs to one picture only


@dataclass(slots=True)
class _Edge:
    source: str
    target: str
    dot: dict[str, str]
    data: dict[str, Value]
    only: str = ""


@dataclass
class _Graph:
    name: str
    attrs: dict[str, str]
    nodes: list[_Node] = field(default_factory=list)
    edges: list[_Edge] = field(default_factory=list)


def _clean(text: str) -> str:
    return text.translate(_CLEAN)


def _esc(text: str) -> str:
    """Text for inside a DOT double-quoted string, shown literally in a label."""
    return text.replace("\r\n", "\n").translate(_DOT)


def _lines(*lines: str) -> str:
    return r"\n".join(_esc(line) for line in lines)


def _record(*lines: str) -> str:
    """One field of a record label: its own special characters escaped too."""
    return r"\n".join(_RECORD_SPECIAL.sub(r"\\\1", _esc(line)) for line in lines)


def _to_dot(graph: _Graph) -> str:
    def attrs(label: str, dot: dict[str, str]) -> str:
        rest = "".join(f', {key}="{_esc(value)}"' for key, value in dot.items())
        return f'[label="{label}"{rest}]'

    out = [f'digraph "{_esc(graph.name)}" {{']
    out += [f'  {key}="{_esc(value)}";' for key, value in graph.attrs.items()]
    out.append('  node [fontname="Helvetica", fontsize=11];')
    out.append('  edge [fontname="Helvetica", fontsize=9];')
    clusters: dict[str, list[str]] = {}
    for node in graph.nodes:
        if node.only == "graphml":
            continue
        line = f'"{_esc(node.id)}" {attrs(node.label, node.dot)};'
        if node.cluster:
            clusters.setdefault(node.cluster, []).append(line)
        else:
            out.append("  " + line)
    for name, lines in clusters.items():
        out.append(f'  subgraph "cluster_{_esc(name)}" {{')
        out.append(f'    label="{_esc(name)}"; style="rounded"; color="grey60"; fontname="Helvetica";')
        out += ["    " + line for line in lines]
        out.append("  }")
    for edge in graph.edges:
        if edge.only != "graphml":
            label = _esc(str(edge.data.get("label", "")))
            out.append(f'  "{_esc(edge.source)}" -> "{_esc(edge.target)}" {attrs(label, edge.dot)};')
    out.append("}")
    return "\n".join(out) + "\n"


def _xml(value: Value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return escape(_clean(str(value)), {"\r": "&#13;"})


def _to_graphml(graph: _Graph) -> str:
    types = {bool: "boolean", int: "int", float: "double", str: "string"}
    keys: dict[str, tuple[set[str], str]] = {}  # name -> (domains, type), in order of first use
    body = [f'  <graph id={quoteattr(_clean(graph.name))} edgedefault="directed">']

    def data(values: dict[str, Value], domain: str) -> str:
        for name, value in values.items():
            kind = next(t for base, t in types.items() if isinstance(value, base))  # (an enum is its str)
            keys.setdefault(name, (set(), kind))[0].add(domain)
        return "".join(f'<data key="{name}">{_xml(value)}</data>' for name, value in values.items())

    for node in graph.nodes:
        if node.only != "dot":
            body.append(f"    <node id={quoteattr(_clean(node.id))}>{data(node.data, 'node')}</node>")
    edges = (e for e in graph.edges if e.only != "dot")
    for number, edge in enumerate(edges):
        ends = f"source={quoteattr(_clean(edge.source))} target={quoteattr(_clean(edge.target))}"
        body.append(f'    <edge id="e{number}" {ends}>{data(edge.data, "edge")}</edge>')
    head = ['<?xml version="1.0" encoding="UTF-8"?>', f'<graphml xmlns="{GRAPHML_NS}">']
    for name, (domains, kind) in keys.items():
        domain = domains.pop() if len(domains) == 1 else "all"
        head.append(f'  <key id="{name}" for="{domain}" attr.name="{name}" attr.type="{kind}"/>')
    return "\n".join(head + body + ["  </graph>", "</graphml>"]) + "\n"


def _feature_graph(model: FeatureModel, variant: VariantLike | None) -> _Graph:
    decisions: dict[str, DecisionLike] = {}
    if variant is not None:
        decisions = {d.feature.id: d for d in variant.decisions}
        if missing := [f.id for f in model.features if f.id not in decisions]:
            raise ValueError(f"the variant is not one of this model: no decision for {missing[0]!r}")
    graph = _Graph(model.name or model.root.id, {"rankdir": "TB", "nodesep": "0.3"})
    groups: dict[int, list[tuple[str, str]]] = {}  # parent -> (kind, DOT node), "/" is in no id
    for g in model.groups:
        groups.setdefault(g.parent, []).append((g.kind, f"{model.features[g.parent].id}/{g.kind}"))
    for f in model.features:
        decision = decisions.get(f.id)
        time_allowed, mode_allowed = token(f.time_allowed), token(f.mode_allowed)
        allowed = f"{mode_allowed} · {time_allowed}"
        data: dict[str, Value] = {"label": f.name, "kind": "feature", "timeAllowed": time_allowed}
        data |= {"modeAllowed": mode_allowed, "mandatory": f.mandatory, "group": f.group}
        dot = {"shape": "box", "style": "rounded,filled", "fillcolor": "white"}
        if f.parent is None:
            dot["penwidth"] = "2"
        if decision is None:
            label = _lines(f.name, allowed)
        elif decision.selected:
            data |= {"selected": True, "binding": decision.binding.value}
            label = _lines(f.name, decision.binding.words)
            dot["fillcolor"] = _FILLS[decision.binding]
        else:
            data["selected"] = False
            label = _lines(f.name, "not selected", allowed)
            dot |= _UNSELECTED
        graph.nodes.append(_Node(f.id, label, dot, data))
        for kind, group_id in groups.get(f.index, ()):
            fill = "black" if kind == "OR" else "white"  # FODA: a filled arc for OR, an empty one for XOR
            shape = _GROUP | {"fillcolor": fill, "xlabel": kind.lower(), "tooltip": f"{kind} group"}
            graph.nodes.append(_Node(group_id, "", shape, {}, only="dot"))
            graph.edges.append(_Edge(f.id, group_id, {"arrowhead": "none"}, {}, only="dot"))
        if f.parent is None:
            continue
        parent = model.features[f.parent]
        faded = _FADED if decision is not None and not decision.selected else {}
        if f.group:
            kind = f.group.lower()
            graph.edges.append(_Edge(parent.id, f.id, {}, {"kind": kind}, only="graphml"))
            source = f"{parent.id}/{f.group}"
            graph.edges.append(_Edge(source, f.id, {"arrowhead": "none"} | faded, {"kind": kind}, only="dot"))
        else:
            kind = "mandatory" if f.mandatory else "optional"
            head = {"arrowhead": "dot" if f.mandatory else "odot"}
            graph.edges.append(_Edge(parent.id, f.id, head | faded, {"kind": kind}))
    for f in model.features:
        for verb, targets in (("requires", f.includes), ("excludes", f.excludes)):
            style = _REQUIRES if verb == "requires" else _EXCLUDES
            for target in dict.fromkeys(targets):  # a repeated id counts once, as in the model
                if target in model.index and target != f.id:
                    graph.edges.append(_Edge(f.id, target, style, {"kind": verb, "label": verb}))
    return graph


def feature_model_dot(model: FeatureModel, variant: VariantLike | None = None) -> str:
    """The feature model as Graphviz DOT; with a variant, its selection and bindings."""
    return _to_dot(_feature_graph(model, variant))


def feature_model_graphml(model: FeatureModel, variant: VariantLike | None = None) -> str:
    """The feature model as GraphML: one node per feature, tree and constraint edges."""
    return _to_graphml(_feature_graph(model, variant))


def _systems(module: Module) -> str:
    return " + ".join(f"{s.type}({s.dimension})" for s in module.systems)


def _learners(module: Module) -> list[str]:
    return [f"learns: {x.type} {x.mode or ''}".strip() for x in module.learners]


def _element(element: Element, kind: str, **more: Value) -> dict[str, Value]:
    return dict(label=element.id, kind=kind, feature=element.feature, **more)


def _architecture_graph(arch: Architecture, features: Iterable[str] | None) -> _Graph:
    if features is not None:
        arch = arch.elements_of(set(features))
    graph = _Graph("architecture", {"rankdir": "LR"})
    used = {c.module.id for c in arch.components.values()}
    ports = [
        (name, port.through.id)
        for c in arch.components.values()
        for name, port in c.ports()
        if port.through is not None
    ]
    reads, writes = {m for p, m in ports if p != "output"}, {m for p, m in ports if p == "output"}
    for space in arch.spaces.values():
        unit = space.unit or ""
        shape = f"{space.type}({space.dimension})" + (f" [{unit}]" if unit else "")
        data = _element(space, "space", type=space.type, dimension=int(space.dimension), unit=unit)
        label = _lines(space.id, shape)
        graph.nodes.append(_Node(space.id, label, {"shape": "ellipse"}, data, space.feature))
    for mapping in arch.mappings.values():
        function = mapping.function.type if mapping.function is not None else ""
        learner = mapping.learner.type if mapping.learner is not None else ""
        kind = " · ".join(x for x in (mapping.kind, learner, function) if x)
        dot = {"shape": _MAPPING_SHAPES[mapping.kind]}
        dot |= {"peripheries": "2"} if mapping.kind == "adaptiveMapping" else {}
        data = _element(mapping, "mapping", type=mapping.kind, function=function)
        data |= {"from": mapping.source.id, "to": mapping.target.id}
        graph.nodes.append(_Node(mapping.id, _lines(mapping.id, kind), dot, data, mapping.feature))
        free = mapping.id not in reads | writes  # a port's mapping converts on the port only
        if free or mapping.id in reads:
            graph.edges.append(_Edge(mapping.source.id, mapping.id, {}, {"kind": "from"}))
        if free or mapping.id in writes:
            graph.edges.append(_Edge(mapping.id, mapping.target.id, {}, {"kind": "to"}))
    for module in arch.modules.values():
        data = _element(module, "module", systems=_systems(module), learners=", ".join(_learners(module)))
        label = _lines(module.id, _systems(module), *_learners(module))
        graph.nodes.append(
            _Node(module.id, label, {"shape": "component"}, data, module.feature)
            if module.id not in used
            else _Node(module.id, "", {}, data, only="graphml")  # drawn inside its component
        )
    for component in arch.components.values():
        cid, runs = component.id, component.module
        rate = f" @ {component.rate:g} Hz" if component.rate is not None else ""
        fields = [_record(cid, component.kind + rate)]
        if runs.id not in arch.modules:  # its feature is left out
            fields.append(_record(f"module {runs.id}", "(not present)"))
        else:
            fields.append(_record(runs.id, _systems(runs), *_learners(runs)))
        if (criterion := component.criterion) is not None:
            fields.append(_record(f"{criterion.type} ≤ {criterion.tolerance:g}"))
        data = _element(component, "component", type=component.kind, module=runs.id)
        data |= {"rate": float(component.rate)} if component.rate is not None else {}
        dot = {"shape": "record", "style": "rounded"}
        graph.nodes.append(_Node(cid, "|".join(fields), dot, data, component.feature))
        graph.edges.append(_Edge(cid, runs.id, {}, {"kind": "runs"}, only="graphml"))
        for name, port in component.ports():
            end = port.through.id if port.through is not None else port.space.id
            style = {"style": "dashed"} if name == "feedback" else {}
            source, target = (cid, end) if name == "output" else (end, cid)
            graph.edges.append(_Edge(source, target, style, {"kind": name, "label": name}))
    present = {node.id for node in graph.nodes}
    absent: dict[str, _Node] = {}
    for edge in graph.edges:  # references to elements of features left out: placeholders
        for end in (edge.source, edge.target):
            if end in present:
                continue
            if end not in absent:
                dot = {"shape": "box", "style": "dashed", "color": "grey60", "fontcolor": "grey50"}
                data = {"label": end, "kind": "absent"}
                absent[end] = _Node(end, _lines(end, "(not present)"), dot, data, only=edge.only)
            elif absent[end].only != edge.only:
                absent[end].only = ""  # drawn in both pictures
    graph.nodes += absent.values()
    return graph


def architecture_dot(arch: Architecture, features: Iterable[str] | None = None) -> str:
    """The motion architecture as Graphviz DOT, only the given features' elements if any."""
    return _to_dot(_architecture_graph(arch, features))


def architecture_graphml(arch: Architecture, features: Iterable[str] | None = None) -> str:
    """The motion architecture as GraphML: spaces, mappings, modules, components, wiring."""
    return _to_graphml(_architecture_graph(arch, features))


def render_svg(dot_text: str, dot_binary: str | None = None, timeout: float = 120.0) -> bytes | None:
    """SVG from DOT text by Graphviz `dot -Tsvg`; None when `dot` is not installed.

    `dot_binary` defaults to `dot` on the PATH, looked up at call time. A binary that
    cannot run, fails or takes longer than `timeout` seconds raises EnvironmentProblem.
    """
    binary = dot_binary if dot_binary is not None else shutil.which("dot")
    if binary is None:
        return None
    where = Location(binary)
    try:
        done = subprocess.run(
            [binary, "-Tsvg"], input=dot_text.encode(), capture_output=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        message = f"Graphviz took longer than {timeout:g} s to lay out the picture (try fewer features, or the .dot file with sfdp)"
        raise EnvironmentProblem(error(where, message, "graphviz")) from None
    except OSError as exc:
        message = f"cannot run Graphviz: {exc.strerror or exc}"
        raise EnvironmentProblem(error(where, message, "graphviz")) from None
    if done.returncode != 0:
        said = "; ".join(done.stderr.decode("utf-8", "replace").strip().splitlines()[:3]) or "no message"
        message = f"Graphviz failed (exit status {done.returncode}): {said}"
        raise EnvironmentProblem(error(where, message, "graphviz"))
    return done.stdout
