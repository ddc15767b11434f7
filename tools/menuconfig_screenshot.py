"""Regenerate guidelines/images/menuconfig.svg: menuconfig on SimpleBot's warehouse decisions,
in an 80x24 terminal, after making amcl Dynamic (a conflict, with its repairs).

    .venv/bin/python tools/menuconfig_screenshot.py
"""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
from pathlib import Path

from motivml.cli.menuconfig import MenuConfig, open_session

ROOT = Path(__file__).resolve().parent.parent
TARGET = ROOT / "guidelines" / "images" / "menuconfig.svg"


async def shoot(work: Path) -> None:
    session, path = open_session("simplebot", "warehouse", None)  # (relative: the title shows it)
    app = MenuConfig(session, path)
    async with app.run_test(size=(80, 24)) as pilot:
        tree = app.query_one("#features")
        while tree.cursor_node is None or tree.cursor_node.data != "amcl":
            await pilot.press("down")
        await pilot.press("m", "m")  # Static, then Dynamic: amcl allows only Static
        await pilot.pause()
        app.save_screenshot(filename=TARGET.name, path=str(TARGET.parent))


def main() -> None:
    with tempfile.TemporaryDirectory() as work:
        shutil.copytree(ROOT / "feature_models" / "simplebot", Path(work) / "simplebot")
        here = os.getcwd()
        os.chdir(work)
        try:
            asyncio.run(shoot(Path(work)))
        finally:
            os.chdir(here)
    print(f"wrote {TARGET.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
