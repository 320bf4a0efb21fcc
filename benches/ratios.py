#!/usr/bin/env python3
"""Print the ratios of `cargo bench -p lagrangian-benches --bench eom` as a Markdown table (AD
route ÷ closed form).

Reads criterion's estimates from target/criterion (or $CARGO_TARGET_DIR/criterion); all numbers
come from the same bench run, so the ratios are comparable even on a noisy machine.
"""
import json
import os
import sys
from pathlib import Path

root = Path(os.environ.get("CARGO_TARGET_DIR", "target")) / "criterion"


def median_ns(*parts):
    path = root.joinpath(*parts, "new", "estimates.json")
    if not path.exists():
        sys.exit(f"missing {path}: run `cargo bench -p lagrangian-benches --bench eom` first")
    return json.loads(path.read_text())["median"]["point_estimate"]


rows = [("double pendulum", ("double_pendulum", "{}"))]
rows += [(f"N-pendulum, N = {n}", ("n_pendulum", "{}", str(n))) for n in (2, 4, 8, 16, 32)]
print("| system | closed form | energy route | particle route |")
print("|---|---|---|---|")
for name, parts in rows:
    t = {k: median_ns(*(p.format(k) for p in parts)) for k in ("closed_form", "energy_route", "particle_route")}
    base = t["closed_form"]
    print(
        f"| {name} | {base:.0f} ns | {t['energy_route'] / base:.2f}× | {t['particle_route'] / base:.2f}× |"
    )
