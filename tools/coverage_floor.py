"""Fail when any module of motivml is covered by the tests below a floor (make test runs it).

    python tools/coverage_floor.py build/coverage.json 90

Reads the JSON report of `pytest --cov=motivml --cov-report=json:...`; prints the modules
under the floor, worst first, and exits 1 if there are any. Coverage.py's own
`fail_under` judges the total only; the project's rule is per module.
"""

from __future__ import annotations

import json
import sys


def main() -> int:
    report_path, floor = sys.argv[1], float(sys.argv[2])
    with open(report_path, encoding="utf-8") as handle:
        files = json.load(handle)["files"]
    below = sorted(
        (data["summary"]["percent_covered"], name)
        for name, data in files.items()
        if data["summary"]["num_statements"] and data["summary"]["percent_covered"] < floor
    )
    for percent, name in below:
        print(f"{name}: {percent:.1f}% covered, under the floor of {floor:g}%")
    lowest = min((data["summary"]["percent_covered"] for data in files.values()), default=100.0)
    print(f"coverage: {len(files)} modules, lowest {lowest:.1f}%, floor {floor:g}%: {'not met' if below else 'met'}")
    return 1 if below else 0


if __name__ == "__main__":
    sys.exit(main())
