"""The wheel carries the schemas, so an installed motivml validates without a checkout."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_wheel_contains_schemas_and_console_script(tmp_path: Path) -> None:
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(tmp_path), str(ROOT)],
        check=True,
    )
    (wheel,) = tmp_path.glob("motivml-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "motivml/schemas/feature-model.schema.json" in names
    assert "motivml/schemas/configuration.schema.json" in names
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "motivml = motivml.cli:main" in zipfile.ZipFile(wheel).read(entry_points).decode()
