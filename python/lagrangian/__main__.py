"""Command line: ``lagrangian report`` and ``lagrangian stability`` (also ``python -m lagrangian``).

    lagrangian report [--quick] [--out DIR] [--scenes a,b,…] [--no-peers] [--no-stability]
    lagrangian stability [--quick] [--cases a,b,…] [--methods a,b,…]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import List, Optional


def _names(text: Optional[str]) -> Optional[List[str]]:
    return None if text is None else [x.strip() for x in text.split(",") if x.strip()]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of the ``lagrangian`` console command; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="lagrangian",
        description="Error against run time and stability of lagrangian's integrators.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    report = sub.add_parser(
        "report",
        help="work–precision, long-run energy, SciPy peers and the stability matrix, written "
        "to a folder (Markdown, PNG, JSON)",
    )
    report.add_argument("--quick", action="store_true", help="finish in under a minute")
    report.add_argument("--out", default="lagrangian-report", help="output folder")
    report.add_argument("--scenes", help="comma-separated scene keys (default: all)")
    report.add_argument("--no-peers", action="store_true", help="skip the SciPy runs")
    report.add_argument("--no-stability", action="store_true", help="skip the stability matrix")
    stab = sub.add_parser("stability", help="print the stability matrix")
    stab.add_argument("--quick", action="store_true", help="shorter long runs and stiff spans")
    stab.add_argument("--cases", help="comma-separated case keys (default: all)")
    stab.add_argument("--methods", help="comma-separated methods (default: all)")
    args = parser.parse_args(argv)

    def progress(message: str) -> None:
        print(message, file=sys.stderr, flush=True)

    start = time.perf_counter()
    try:
        if args.command == "report":
            from ._report import run_report

            out = Path(args.out)
            run_report(out, quick=args.quick, scenes=_names(args.scenes),
                       peers=not args.no_peers, stability=not args.no_stability,
                       progress=progress)
            print(f"report written to {out}/ (README.md, report.json, one PNG per scene) in "
                  f"{time.perf_counter() - start:.1f} s")
            return 0
        from ._stability import run_stability

        matrix = run_stability(quick=args.quick, methods=_names(args.methods),
                               cases=_names(args.cases), progress=progress)
        print(matrix.table())
        return 1 if matrix.wrong() else 0
    except ValueError as e:
        parser.error(str(e))
    return 2


if __name__ == "__main__":
    sys.exit(main())
