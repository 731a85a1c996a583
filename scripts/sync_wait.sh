#!/usr/bin/env bash
# Pose freshness against the old waiting rule, paired in one run: the simulated sources of
# scripts/graph.py feed two `sync` nodes, each with its own `trilaterate` and `recorder`. One has
# the defaults (a set goes out once every sensor's frame after its instant is in, or that frame
# is overdue by FRAME_WAIT_MARGIN_MILLIS); the other waits the way sync did before: for every
# joint's samples after the instant, for a lost frame until the 100 ms deadline
# (FRAME_WAIT_MARGIN_MILLIS 100, BRIDGE_GAPS true). Both see the same frames and the same NTP
# replies (the second sync completes the exchanges the first one started, on the same host
# clock), so the RMSE difference is the rule's, not the run's. Prints pose age p50/p99 and RMSE
# of both and their ratios.
#   scripts/sync_wait.sh [seconds per run, default 15] [sensor counts, default "3 16"]
set -euo pipefail
cd "$(dirname "$0")/.."
SECS="${1:-15}"
COUNTS="${2:-3 16}"
scripts/venv.sh   # .venv/ with the pinned packages of scripts/requirements.txt
export PATH="$PWD/.venv/bin:$PATH"
cargo build --release --workspace --all-targets
ROOT="$PWD"
printf "%8s %-8s %8s %12s %12s %10s %10s %10s %10s\n" sensors rule sets "age p50 ms" "age p99 ms" "RMSE mm" overdue deadline incompl
for n in $COUNTS; do
  dir="$ROOT/target/sync-wait/$n"
  rm -rf "$dir"; mkdir -p "$dir"
  rig="ring-$n"; [ "$n" = 3 ] && rig=thesis
  python3 scripts/graph.py --sensors "$n" --rig "$rig" --root "$ROOT/" --out-dir "$dir/new" > "$dir/single.yml"
  python3 - "$dir/single.yml" "$dir/old" > "$dir/graph.yml" <<'PY'
import copy, sys, yaml
graph = yaml.safe_load(open(sys.argv[1]))
nodes = {n["id"]: n for n in graph["nodes"]}
twins = []
for node in graph["nodes"]:
    if node["id"] not in ("sync", "trilaterate", "recorder"):
        continue
    twin = copy.deepcopy(node)
    twin["id"] = node["id"] + "_old"
    for name, spec in list(twin.get("inputs", {}).items()):
        src = spec["source"] if isinstance(spec, dict) else spec
        head, _, port = src.partition("/")
        if head in ("sync", "trilaterate"):
            src = f"{head}_old/{port}"
        if isinstance(spec, dict):
            spec["source"] = src
        else:
            twin["inputs"][name] = src
    env = twin.setdefault("env", {})
    if node["id"] == "sync":
        # Only the first sync asks; this one completes the exchanges from the sources' replies.
        twin["outputs"] = [o for o in twin["outputs"] if not o.startswith("ntp_request")] + ["ntp_request"]
        env["FRAME_WAIT_MARGIN_MILLIS"] = "100"
        env["BRIDGE_GAPS"] = "true"
    if node["id"] == "recorder":
        env["OUTPUT_DIR"] = sys.argv[2]
    twins.append(twin)
graph["nodes"].extend(twins)
print(yaml.safe_dump(graph, sort_keys=False))
PY
  (cd "$dir" && STOP_AFTER_SECS="$SECS" dora run graph.yml --stop-after "$((SECS + 30))s" > "$dir/dora-run.log" 2>&1) || {
    echo "dora run failed for $n sensors; see $dir/dora-run.log"; exit 1; }
  python3 - "$dir" "$n" <<'PY'
import json, sys
d, n = sys.argv[1], sys.argv[2]
rows = {}
for rule in ("new", "old"):
    s = json.load(open(f"{d}/{rule}/summary.json"))
    r = s["sync_wait"]["released"]
    rows[rule] = s
    print(f"{n:>8} {rule:<8} {s['sets_fused']:>8} {s['age_ms']['p50']:>12.1f} {s['age_ms']['p99']:>12.1f} "
          f"{s['rmse_all_m'] * 1000:>10.2f} {r.get('overdue', 0):>10} {r.get('deadline', 0):>10} {s['incomplete_sets']:>10}")
new, old = rows["new"], rows["old"]
print(f"{n:>8} {'new/old':<8} {'':>8} {new['age_ms']['p50'] / old['age_ms']['p50']:>12.2f} "
      f"{new['age_ms']['p99'] / old['age_ms']['p99']:>12.2f} {new['rmse_all_m'] / old['rmse_all_m']:>10.3f}")
PY
done
