"""The specification lives in the repository (guidelines/reference.md): every citation of
it in the code, the schemas, the tests and the benches names a section or rule it has."""

from __future__ import annotations

import re

from paths import ROOT

SPEC = ROOT / "guidelines" / "reference.md"
CITATION = re.compile(r"reference\.md,? (?:(sections?) ((?:\d+(?:-\d+)?(?:, | and )?)+)|(\d+\.\d+))")


def _cited() -> list[tuple[str, str]]:
    """(where, what) for every citation: "section 4", "rule 2.4"."""
    found = []
    files = [*ROOT.glob("motivml/**/*.py"), *ROOT.glob("schemas/*.json"), *ROOT.glob("tests/*.py")]
    for path in [*files, *ROOT.glob("bench/*.py"), ROOT / "README.md", *ROOT.glob("guidelines/*.md")]:
        text = path.read_text(encoding="utf-8")
        for match in CITATION.finditer(text):
            where = f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, match.start()) + 1}"
            if match.group(3):
                found.append((where, f"rule {match.group(3)}"))
                continue
            for part in re.split(r", | and ", match.group(2)):
                if not part:
                    continue
                first, _, last = part.partition("-")
                found += [(where, f"section {k}") for k in range(int(first), int(last or first) + 1)]
    return found


def test_every_citation_of_the_specification_names_what_it_has() -> None:
    spec = SPEC.read_text(encoding="utf-8")
    sections = {f"section {n}" for n in re.findall(r"^## Section (\d+):", spec, re.MULTILINE)}
    rules = {f"rule {n}" for n in re.findall(r"^\*\*(\d+\.\d+) ", spec, re.MULTILINE)}
    cited = _cited()
    assert len(cited) > 30  # (the code cites it throughout)
    missing = [(where, what) for where, what in cited if what not in sections | rules]
    assert not missing, missing


def test_no_citation_points_outside_the_repository() -> None:
    for path in [*ROOT.glob("motivml/**/*.py"), *ROOT.glob("schemas/*.json"), *ROOT.glob("guidelines/*.md")]:
        assert "semantics.md" not in path.read_text(encoding="utf-8"), path
