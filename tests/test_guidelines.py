"""The guidelines show real output: every ```text block that starts with `$ ` is re-run.

Each block runs in bash from a scratch copy of the repository's examples (so commands
that write files do not touch the checkout), with this interpreter's `motivml` first on
PATH, and its output must match the page byte for byte. `$ echo $?` prints the exit code
of the command before it.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import ROOT

PAGES = [*sorted((ROOT / "guidelines").glob("*.md")), ROOT / "README.md"]
BLOCK = re.compile(r"```text\n(\$ .*?)```", re.S)


def blocks() -> list[tuple[str, int, str]]:
    found = []
    for page in PAGES:
        text = page.read_text()
        for match in BLOCK.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            found.append((page.name, line, match.group(1)))
    return found


def script(block: str) -> str:
    lines = ["rc=0"]
    for line in block.splitlines():
        if not line.startswith("$ "):
            continue
        command = line[2:]
        lines.append("printf '%s\\n' " + _quote("$ " + command))
        lines.append("echo $rc" if command == "echo $?" else f"{{ {command} ; }} 2>&1; rc=$?")
    return "\n".join(lines)


def _quote(text: str) -> str:
    return "'" + text.replace("'", "'\\''") + "'"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    work = tmp_path_factory.mktemp("guide")
    shutil.copytree(ROOT / "feature_models", work / "feature_models")
    shutil.copytree(ROOT / "guidelines", work / "guidelines")
    shutil.copytree(ROOT / "schemas", work / "schemas")
    shutil.copytree(ROOT / "cpp_static", work / "cpp_static")
    shutil.copytree(ROOT / "plugins", work / "plugins")
    return work


@pytest.mark.parametrize(("page", "line", "block"), blocks(), ids=[f"{p}:{n}" for p, n, _ in blocks()])
def test_block_output_is_real(workdir: Path, page: str, line: int, block: str) -> None:
    env = dict(
        os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}", COLUMNS="80"
    )
    result = subprocess.run(
        ["bash", "-c", script(block)], cwd=workdir, env=env, capture_output=True, text=True
    )
    assert result.stdout == block, f"{page}:{line} differs from what the commands print now"


def update() -> None:
    """Rewrite every block with what its commands print now (review the diff afterwards)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ("feature_models", "guidelines", "schemas", "cpp_static", "plugins"):
            shutil.copytree(ROOT / name, work / name)
        env = dict(
            os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}", COLUMNS="80"
        )
        for page in PAGES:
            text = page.read_text()

            def real(match: re.Match[str]) -> str:
                result = subprocess.run(
                    ["bash", "-c", script(match.group(1))], cwd=work, env=env, capture_output=True, text=True
                )
                return f"```text\n{result.stdout}```"

            page.write_text(BLOCK.sub(real, text))


if __name__ == "__main__":  # python tests/test_guidelines.py --update
    if sys.argv[1:] == ["--update"]:
        update()


def test_the_reference_explains_every_rule_messages_cite() -> None:
    """guidelines/reference.md: each rule number a message of motivml cites (rule 2.2,
    binding rule 3.1, section 4, ...) has its own paragraph (bold) or section (heading)."""
    cited: set[str] = set()
    for source in (ROOT / "motivml").rglob("*.py"):
        text = source.read_text()
        pattern = r"\((?:binding )?rules? ([0-9.]+)(?: and ([0-9.]+))?(?:, section ([0-9]))?\)"
        for match in re.finditer(pattern, text):
            cited |= {number for number in match.groups() if number}
        cited |= set(re.findall(r"\(section ([0-9])\)", text))
    assert {"2.1", "2.2", "2.3", "2.4", "3.1", "3.2", "3.3", "3", "4"} <= cited  # (the pattern reads them)
    reference = (ROOT / "guidelines" / "reference.md").read_text()
    for number in cited:
        if "." in number:
            assert f"\n**{number} " in reference, number
        else:
            assert f"\n## Section {number}:" in reference, number
