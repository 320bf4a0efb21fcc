"""Command line: ``lagrangian report`` and ``lagrangian stability`` (also ``python -m lagrangian``).

    lagrangian --version
    lagrangian report [--quick] [--out DIR] [--scenes a,b,…] [--no-peers] [--no-stability]
    lagrangian stability [--quick] [--cases a,b,…] [--methods a,b,…]

``--help`` on each command lists its scenes or cases and the methods; a bad name is rejected
before any run starts.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
import time
from pathlib import Path
from typing import Iterable, List, Optional, Tuple

from . import _lagrangian
from ._cases import report_scenes
from ._stability import stability_cases

#: Where ``lagrangian report`` writes without ``--out``.
DEFAULT_OUT = "lagrangian-report"


def _listing(title: str, entries: Iterable[Tuple[str, str]]) -> str:
    """An epilog section: ``title`` and one ``key  description`` line per entry."""
    rows = list(entries)
    width = max(len(k) for k, _ in rows)
    lines = [f"  {k.ljust(width)}  {v}" for k, v in rows]
    return f"{title}:\n" + "\n".join(lines)


def _methods_listing() -> str:
    names = [m for m in _lagrangian.methods() if m != "auto"]
    return "methods:\n" + textwrap.fill(", ".join(names), width=78, initial_indent="  ",
                                         subsequent_indent="  ")


def _names(text: Optional[str]) -> Optional[List[str]]:
    return None if text is None else [x.strip() for x in text.split(",") if x.strip()]


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of the ``lagrangian`` console command; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="lagrangian",
        description="Error against run time and stability of lagrangian's integrators.",
    )
    parser.add_argument("--version", action="version",
                        version=f"lagrangian {_lagrangian.__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    scenes = [(s.key, s.title) for s in report_scenes()]
    report = sub.add_parser(
        "report",
        help="work–precision, long-run energy, SciPy peers and the stability matrix, written "
        "to a folder (Markdown, PNG, JSON)",
        description=textwrap.fill(
            "Work–precision of every method on each scene, long-run energy, SciPy peers and "
            f"the stability matrix, written to a folder (default: {DEFAULT_OUT}/): README.md, "
            "report.json and one PNG per scene.", width=78),
        epilog=_listing("scenes (--scenes)", scenes),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    report.add_argument("--quick", action="store_true", help="finish in under a minute")
    report.add_argument("--out", default=DEFAULT_OUT, help="output folder (default: %(default)s)")
    report.add_argument("--scenes", help="comma-separated scene keys, listed below (default: all)")
    report.add_argument("--no-peers", action="store_true", help="skip the SciPy runs")
    report.add_argument("--no-stability", action="store_true", help="skip the stability matrix")
    cases = [(c.key, c.title) for c in stability_cases()]
    stab = sub.add_parser(
        "stability",
        help="print the stability matrix",
        description=textwrap.fill(
            "Every method on stiff and extreme cases, each run classified (solved, error, "
            "chaotic, coarse or WRONG); the matrix is printed as Markdown. Exit status 1 when "
            "a run is WRONG.", width=78),
        epilog=_listing("cases (--cases)", cases) + "\n\n" + _methods_listing(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    stab.add_argument("--quick", action="store_true", help="shorter long runs and stiff spans")
    stab.add_argument("--cases", help="comma-separated case keys, listed below (default: all)")
    stab.add_argument("--methods", help="comma-separated methods, listed below (default: all)")
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
