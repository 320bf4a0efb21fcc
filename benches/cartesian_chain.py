#!/usr/bin/env python3
"""Run `cargo bench -p lagrangian-benches --bench cartesian_chain` and print its tables (issue 41:
the N-link chain in Cartesian coordinates under rod constraints against the same chain in its
angles, ≤ 2× per unit of simulated time at equal error).

The first table is per unit of simulated time at the DOP853 tolerance the bench chose for an
end-position error of at most 1e-7 at t = 5 (from `cartesian_chain_meta.json`, which the bench
writes beside criterion's estimates), with the right-hand-side evaluations and projections of
that run; the second is one evaluation of each right-hand side and of the Cartesian one's parts.
All numbers come from the same bench run, so the ratios are comparable on a noisy machine.

    python3 benches/cartesian_chain.py [--no-run] [criterion arguments ...]

`--no-run` reads a finished run; anything else is passed to criterion (the docs' numbers come
from `--warm-up-time 1 --measurement-time 3`).
"""
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
criterion = target / "criterion"
SIZES = (2, 4, 8)
TARGET_RATIO = 2.0


def median_ns(*parts):
    path = criterion.joinpath(*parts, "new", "estimates.json")
    if not path.exists():
        sys.exit(f"missing {path}: run `cargo bench -p lagrangian-benches --bench cartesian_chain`")
    return json.loads(path.read_text())["median"]["point_estimate"]


def main():
    args = sys.argv[1:]
    if "--no-run" in args:
        args.remove("--no-run")
    else:
        command = ["cargo", "bench", "-p", "lagrangian-benches", "--bench", "cartesian_chain"]
        subprocess.run(command + (["--"] + args if args else []), cwd=ROOT, check=True)
    meta = json.loads((criterion / "cartesian_chain_meta.json").read_text())

    print("| N | formulation | rtol | end-position error | RHS evaluations | projections | time per unit time | Cartesian ÷ minimal |")
    print("|---|---|---|---|---|---|---|---|")
    worst = 0.0
    for n in SIZES:
        m = meta[str(n)]
        times = {f: median_ns("cartesian_chain", f, str(n)) / m["t_end"] for f in ("minimal", "cartesian")}
        ratio = times["cartesian"] / times["minimal"]
        worst = max(worst, ratio)
        for f in ("minimal", "cartesian"):
            s = m[f]["stats"]
            cell = f"{ratio:.2f}×" if f == "cartesian" else ""
            print(
                f"| {n} | {f} | {m[f]['rtol']:.1e} | {m[f]['error']:.1e} | {s['rhs_evaluations']} "
                f"| {s['projections']} | {times[f] / 1e3:.0f} µs | {cell} |"
            )
    verdict = "met" if worst <= TARGET_RATIO else "not met"
    print(f"\nworst ratio {worst:.2f}× (target ≤ {TARGET_RATIO:.0f}×: {verdict})\n")

    parts = ("minimal", "cartesian", "cartesian_free", "jacobian", "gamma", "mass_matrix")
    print("| N | " + " | ".join(parts) + " | Cartesian ÷ minimal |")
    print("|---" * (len(parts) + 2) + "|")
    for n in SIZES:
        t = {p: median_ns("cartesian_chain_rhs", p, str(n)) for p in parts}
        cells = " | ".join(f"{t[p]:.0f} ns" for p in parts)
        print(f"| {n} | {cells} | {t['cartesian'] / t['minimal']:.2f}× |")


if __name__ == "__main__":
    main()
