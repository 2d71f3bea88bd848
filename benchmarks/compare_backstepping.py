"""LPV state feedback against backstepping on the exact two-mass plant.

The controllers and scenarios are those of `ctrl_lpv.twomass.comparison`
(``ctrl-lpv reproduce`` runs the paper's four scenarios). This script adds
the 24 robustness scenarios (alpha, Td and load-inertia mismatch) unless
``--quick`` is given.

Usage::

    python benchmarks/compare_backstepping.py [--quick] [--json PATH] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ctrl_lpv.twomass import comparison


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="paper scenarios only")
    parser.add_argument("--json", help="write the rows to this JSON file")
    parser.add_argument("--out", help="write table.md to this folder")
    args = parser.parse_args(argv)

    def progress(done, total, label):
        print(f"[{done}/{total}] {label}", file=sys.stderr, flush=True)

    scenarios = comparison.comparison_scenarios(robustness=not args.quick)
    rows, _ = comparison.compare(scenarios=scenarios, progress=progress)
    text = comparison.markdown_table(rows)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2, default=lambda v: None))
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "table.md").write_text(text + "\n")
    return rows


if __name__ == "__main__":
    main()
