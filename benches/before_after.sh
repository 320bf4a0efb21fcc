#!/usr/bin/env bash
# Before and after, side by side, for the Rust criterion benches (issue 49), short form:
#   eom          the AD accelerations (energy and particle routes) against the closed forms
#   integrators  step_double_pendulum and error_1e-8_double_pendulum (every method on the AD
#                double pendulum and on its closed form; the n-pendulum sweep left out for time)
#   constrained  andrews_1e-7 and andrews_evaluation (the constrained route)
#
#   benches/before_after.sh build BEFORE_TREE AFTER_TREE   # compile the bench binaries (slow)
#   benches/before_after.sh run   BEFORE_TREE AFTER_TREE   # time them (about 4.5 min a round)
#
# BEFORE_TARGET and AFTER_TARGET (default /work/targets/before, /work/targets/after) are the
# trees' CARGO_TARGET_DIRs, one each so that neither rebuilds the other's crate; the ones the
# trees' wheels were built in (`pip install .`) share their release dependencies. The bench
# profile is the release one (fat LTO, one codegen unit), as the published numbers: a tree's
# build takes several minutes on the 2-core machine, hence `build` before `run`. `run` deletes
# and rewrites $TARGET/criterion in both (BEFORE_TARGET = AFTER_TARGET is fine: a noise check).
#
# `run` runs every bench in BEFORE then in AFTER (ROUNDS rounds, default 1, the order swapped
# each round; criterion's --save-baseline <side>_<round>), then prints per benchmark the best
# over the rounds of criterion's median on each side, after ÷ before, and each tree's AD ÷
# closed-form ratio (the ratio docs/site/crate.rst and integrators.rst quote, both measured by
# the same binary in the same run). Criterion times wall clock: on the shared 2-core machine at
# load 5–7 the same build against itself gave after ÷ before 0.60–1.51 in one run and 0.45–1.29
# in another (geometric means 0.99 and 0.86 over 56 benchmarks), so read it on a quiet machine
# only; benches/before_after.py (CPU time) is the robust check. Not a test.
set -euo pipefail

mode=${1:?usage: before_after.sh build|run BEFORE_TREE AFTER_TREE}
before=$(cd "${2:?BEFORE_TREE}" && pwd)
after=$(cd "${3:?AFTER_TREE}" && pwd)
before_target=${BEFORE_TARGET:-/work/targets/before}
after_target=${AFTER_TARGET:-/work/targets/after}

# name;criterion filter (regex; empty: all);warm-up and measurement seconds (groups that set
# their own keep theirs)
benches=(
  "eom;;--warm-up-time 1 --measurement-time 2"
  "integrators;^(step_double_pendulum|error_1e-8_double_pendulum)/;"
  "constrained;;"
)

cargo_bench() {  # tree target name [args after --]
  local tree=$1 target=$2 name=$3
  shift 3
  (cd "$tree" && CARGO_TARGET_DIR=$target cargo bench -q -p lagrangian-benches --bench "$name" "$@")
}

case $mode in
build)
  for side in before after; do
    tree=$before target=$before_target
    [ $side = after ] && tree=$after target=$after_target
    start=$SECONDS
    for entry in "${benches[@]}"; do
      cargo_bench "$tree" "$target" "${entry%%;*}" --no-run
    done
    echo "$side: bench binaries built in $((SECONDS - start)) s ($tree, $target)"
  done
  ;;
run)
  start=$SECONDS
  echo "load average at start: $(cut -d' ' -f1 /proc/loadavg)"
  rm -rf "$before_target/criterion" "$after_target/criterion"
  for round in $(seq 1 "${ROUNDS:-1}"); do
    order="before after"
    [ $((round % 2)) = 0 ] && order="after before"
    for side in $order; do
      tree=$before target=$before_target
      [ "$side" = after ] && tree=$after target=$after_target
      for entry in "${benches[@]}"; do
        IFS=';' read -r name filter timing <<<"$entry"
        # shellcheck disable=SC2086  # $timing is a list of flags
        cargo_bench "$tree" "$target" "$name" -- --noplot $timing \
          --save-baseline "${side}_$round" ${filter:+"$filter"} \
          >"$target/before_after_$name.log" 2>&1 \
          || { cat "$target/before_after_$name.log"; exit 1; }
      done
      echo "round $round, $side done ($((SECONDS - start)) s)"
    done
  done
  echo "load average at end: $(cut -d' ' -f1 /proc/loadavg)"
  python3 - "$before_target/criterion" "$after_target/criterion" <<'EOF'
import json, math, sys
from pathlib import Path

before, after = (Path(p) for p in sys.argv[1:3])


def medians(root, side):
    """{benchmark: the best over the rounds of criterion's median}."""
    out = {}
    for f in root.rglob(f"{side}_*/estimates.json"):
        key = str(f.parent.parent.relative_to(root))
        m = json.loads(f.read_text())["median"]["point_estimate"]
        out[key] = min(m, out.get(key, m))
    return out


b, a = medians(before, "before"), medians(after, "after")


def closed(d, key):
    """The closed-form (or hand-written) sibling measured in the same run: the AD ratio's base."""
    parts = key.split("/")
    for i, p in enumerate(parts):
        if p in ("energy_route", "particle_route"):
            sib = "closed_form"
        elif p.startswith("ad_"):
            sib = "closed_" + p[3:]
        elif p.startswith("dop853_model"):
            sib = "dop853_hand"
        else:
            continue
        return d.get("/".join(parts[:i] + [sib] + parts[i + 1:]))
    return None


def ns(x):
    return f"{x / 1e3:.2f} µs" if x >= 1e3 else f"{x:.1f} ns"


print("\n| benchmark | before | after | after ÷ before | ÷ closed form: before → after |")
print("|---|---|---|---|---|")
ratios = []
for key in sorted(set(b) & set(a)):
    r = a[key] / b[key]
    ratios.append(r)
    cb, ca = closed(b, key), closed(a, key)
    rel = f"{b[key] / cb:.2f} → {a[key] / ca:.2f}" if cb and ca else ""
    flag = " **" if r > 1.10 else ""
    print(f"| {key} | {ns(b[key])} | {ns(a[key])} | {r:.3f}{flag} | {rel} |")
only = sorted(set(b) ^ set(a))
if only:
    print(f"\nin one tree only (renamed or new): {', '.join(only)}")
if ratios:
    geo = math.exp(sum(map(math.log, ratios)) / len(ratios))
    print(f"\ngeometric mean of after ÷ before: {geo:.3f}; range {min(ratios):.3f} – "
          f"{max(ratios):.3f} over {len(ratios)} benchmarks (** > 1.10)")
EOF
  echo "total $((SECONDS - start)) s"
  ;;
*)
  echo "usage: before_after.sh build|run BEFORE_TREE AFTER_TREE" >&2
  exit 2
  ;;
esac
