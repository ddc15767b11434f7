"""validate's result for machines: JSON, SARIF 2.1.0 (code scanning) and JUnit XML (test reports).

Each format says what the text output says, from the same reports: every error and warning
with its place, rule and facts. SARIF gives one result per diagnostic, at the place the text
output names first, with the facts of an explanation as related locations; JUnit gives one
test case per document checked, failed by its errors. When validate stops before checking
anything (a missing folder, an unknown variant), each format still prints a whole document
holding that problem, so that a CI step that keeps the output has something to show.

Output is the same for the same input (no times, no absolute paths added), so that it can be
diffed and shown in the guidelines as it is.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import PurePath
from typing import TYPE_CHECKING
from urllib.parse import quote

from .. import __version__
from ..errors import Diagnostic, Location, MotivmlError, Severity, repair_text

if TYPE_CHECKING:
    from xml.etree.ElementTree import Element

    from ..validate import Report

FORMATS = ("json", "sarif", "junit")  # besides text

SARIF_SCHEMA = "https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/sarif-schema-2.1.0.json"

# The rules of the language reference (guidelines/reference.md), by the number messages cite.
REFERENCE_RULES = {
    "2.1": "The root and the tree (reference rule 2.1)",
    "2.2": "Mandatory children and groups (reference rule 2.2)",
    "2.3": "Includes and excludes (reference rule 2.3)",
    "2.4": "Formulas (reference rule 2.4)",
    "3": "How each selected feature is bound (reference section 3)",
    "3.1": "What a feature requires is there whenever it is (reference binding rule 3.1)",
    "3.2": "A sub-feature is part of its parent (reference binding rule 3.2)",
    "3.3": "Run-time alternatives (reference binding rule 3.3)",
    "section 4": "Variants, the start state, and changes at run time (reference section 4)",
}
# Other rules are named FAMILY or FAMILY.DETAIL ("model.dead-feature", "schema.enum"): the
# family says which check, the detail which of its findings.
FAMILIES = {
    "json": "The document is read as JSON",
    "limits": "A document within motivml's limits (size, nesting)",
    "schema": "The document follows its JSON Schema",
    "io": "A file or folder that cannot be read",
    "compile": "A compiled form that could not be made in time",
    "record": "A run record (motivml run --record) that motivml plot can read",
    "plot": "A picture motivml plot can draw from a run record",
    "usage": "The command line names something that is not there",
    "model": "The feature model",
    "config": "A configuration (variant) of the model",
    "architecture": "The motion architecture",
    "build": "Building the motion architecture",
    "coordination": "The coordination statechart",
    "plugins": "The plugin manifests of robot.json",
    "codegen": "The generated files",
    "control": "The control socket of a run",
    "count": "Counting the model's variants",
    "query": "A question asked of the model",
    "request": "A request made at run time",
    "reconfigure": "A reconfiguration at run time",
    "run": "Running a robot",
    "ros2": "ROS 2",
    "uvl": "UVL",
    "featureide": "FeatureIDE XML",
    "sxfm": "S.P.L.O.T.'s SXFM",
    "import": "Importing another tool's model",
    "fleet": "A fleet file",
    "graphviz": "Drawing with Graphviz",
}
CONFLICT = "conflict"  # the rule of an explanation whose facts no single rule joins


def describe(rule: str) -> str:
    """A rule's short description, for SARIF's rule list."""
    if rule in REFERENCE_RULES:
        return REFERENCE_RULES[rule]
    if rule == CONFLICT:
        return "Facts of the model and the configuration that contradict each other"
    family, _, detail = rule.partition(".")
    base = FAMILIES.get(family, f"motivml's check {family}")
    return f"{base}: {detail.replace('-', ' ')}" if detail else base


def checked(fmt: str, reports: Sequence[Report], valid: bool) -> str:
    """What validate found in the documents it checked, in a machine format of FORMATS."""
    if fmt == "json":
        return _json(
            valid,
            [d for r in reports for d in r.errors],
            [d for r in reports for d in r.warnings],
            [
                {
                    "file": r.file,
                    "kind": r.kind,
                    "valid": r.valid,
                    "errors": len(r.errors),
                    "warnings": len(r.warnings),
                }
                for r in reports
            ],
        )
    if fmt == "sarif":
        return sarif([d for r in reports for d in r.diagnostics], 0 if valid else 1)
    return junit([(r.file, r.kind, r.diagnostics) for r in reports])


def unchecked(fmt: str, target: str, problem: MotivmlError) -> str:
    """The problem that stopped validate before it checked any document, in a machine format."""
    if fmt == "json":
        return _json(False, problem.diagnostics, [], [])
    if fmt == "sarif":
        return sarif(problem.diagnostics, problem.exit_code)
    return junit([], unchecked=(target, problem.diagnostics))


def _json(valid: bool, errors: list[Diagnostic], warnings: list[Diagnostic], documents: list[object]) -> str:
    payload = {
        "valid": valid,
        "errors": [d.as_dict() for d in errors],
        "warnings": [d.as_dict() for d in warnings],
        "documents": documents,
    }
    return json.dumps(payload, indent=2)


def sarif(diagnostics: Sequence[Diagnostic], exit_code: int) -> str:
    """A SARIF 2.1.0 log: one run of motivml, one result per diagnostic (errors and warnings).

    The run's invocation says whether validate could check at all (exit code 0 or 1) and
    with which exit code it ended; code scanning shows the results either way.
    """
    rules: dict[str, int] = {}
    results = []
    for d in diagnostics:
        rule = d.rule or CONFLICT
        index = rules.setdefault(rule, len(rules))
        result: dict[str, object] = {
            "ruleId": rule,
            "ruleIndex": index,
            "level": "error" if d.severity is Severity.ERROR else "warning",
            "message": {"text": d.message},
            "locations": [{"physicalLocation": _physical(d.location)}],
            "properties": {"jsonPath": d.location.path}
            | ({"feature": d.feature} if d.feature is not None else {})
            | ({"repairs": [repair_text(r) for r in d.repairs]} if d.repairs else {}),
        }
        if d.facts:
            result["relatedLocations"] = [
                {
                    "id": n,
                    "physicalLocation": _physical(fact.location),
                    "message": {"text": fact.text},
                    "properties": {"jsonPath": fact.location.path, "rule": fact.rule},
                }
                for n, fact in enumerate(d.facts, 1)
            ]
        results.append(result)
    log = {
        "$schema": SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "motivml",
                        "version": __version__,
                        "rules": [
                            {"id": rule, "shortDescription": {"text": describe(rule)}} for rule in rules
                        ],
                    }
                },
                "invocations": [{"executionSuccessful": exit_code in (0, 1), "exitCode": exit_code}],
                "columnKind": "unicodeCodePoints",  # columns count characters of the JSON text
                "results": results,
            }
        ],
    }
    return json.dumps(log, indent=2)


def _physical(location: Location) -> dict[str, object]:
    """A SARIF physicalLocation: the file as a URI reference, and the line and column if known."""
    physical: dict[str, object] = {"artifactLocation": {"uri": _uri(location.file)}}
    if location.line is not None:
        region = {"startLine": location.line}
        if location.column is not None:
            region["startColumn"] = location.column
        physical["region"] = region
    return physical


def _uri(file: str) -> str:
    """A path as a URI reference: relative paths stay relative (code scanning resolves them
    against the checkout), absolute ones become file: URIs; bytes a file name could not
    decode (surrogate escapes) are percent-encoded as the bytes they were."""
    path = PurePath(file)
    if path.is_absolute():
        return "file://" + quote(path.as_posix(), errors="surrogateescape")
    return quote(path.as_posix(), errors="surrogateescape")


def junit(
    documents: Sequence[tuple[str, str, Sequence[Diagnostic]]],
    unchecked: tuple[str, Sequence[Diagnostic]] | None = None,
) -> str:
    """JUnit XML: one test suite for the run, one test case per document (file, kind, diagnostics).

    A document with errors fails (the failure's message is its first error, its text every
    error as the text output prints it); warnings go to the case's system-out. `unchecked`
    (the target and the problem that stopped validate) is one test case in error instead.
    """
    import xml.etree.ElementTree as ET  # (here only: validate's other formats do without it)

    suites = ET.Element("testsuites", name="motivml validate")
    suite = ET.SubElement(suites, "testsuite", name="motivml validate")
    failures = errors = 0
    for file, kind, diagnostics in documents:
        case = ET.SubElement(suite, "testcase", classname=kind, name=_xml_text(file))
        found = [d for d in diagnostics if d.severity is Severity.ERROR]
        if found:
            failures += 1
            _problem(case, "failure", found)
        said = [d for d in diagnostics if d.severity is not Severity.ERROR]
        if said:
            ET.SubElement(case, "system-out").text = _lines(said)
    if unchecked is not None:
        target, diagnostics = unchecked
        case = ET.SubElement(suite, "testcase", classname="validate", name=_xml_text(target))
        errors += 1
        _problem(case, "error", diagnostics)
    counts = {"tests": str(len(suite)), "failures": str(failures), "errors": str(errors), "skipped": "0"}
    for element in (suites, suite):
        element.attrib.update(counts)
    ET.indent(suites)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suites, encoding="unicode")


def _problem(case: Element, tag: str, diagnostics: Sequence[Diagnostic]) -> None:
    from xml.etree.ElementTree import SubElement

    first = diagnostics[0]
    element = SubElement(
        case, tag, message=_xml_text(f"{first.location}: {first.message}"), type=first.rule or CONFLICT
    )
    element.text = _lines(diagnostics)


def _lines(diagnostics: Sequence[Diagnostic]) -> str:
    """Diagnostics as the text output prints them: a located line each, its facts indented."""
    lines = []
    for d in diagnostics:
        lines.append(f"{d.location}: {d.location.path}: {d.severity.value}: {d.message}")
        lines += [f"    {fact.location}: {fact.text}" for fact in d.facts]
    return _xml_text("\n".join(lines) + "\n")


# What XML 1.0 cannot hold, even escaped: C0 controls but tab and newlines, surrogates, U+FFFE/F.
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _xml_text(text: str) -> str:
    """Text from a document as XML can carry it: what it cannot is spelled out (\\x01, \\udc80)."""
    return _NOT_XML.sub(lambda m: m.group().encode("unicode_escape").decode(), text)
