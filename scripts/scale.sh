#!/usr/bin/env bash
# Latency/scale benchmark: runs the graph with 3, 8 and 16 simulated sensors at 30 Hz on this
# host (ring-N rigs, interpolate + fusion) and prints end-to-end latency p50/p99 after the
# recorder's 1 s warm-up, the warm-up's worst latency, the pose age p50/p99 (fusion instant ->
# recorded), dropped sets and the share of raw frames that never reached the recorder.
#   scripts/scale.sh [seconds per run, default 12] [sensor counts, default "3 8 16"]
set -euo pipefail
cd "$(dirname "$0")/.."
SECS="${1:-12}"
COUNTS="${2:-3 8 16}"
scripts/venv.sh   # .venv/ with the pinned packages of scripts/requirements.txt
export PATH="$PWD/.venv/bin:$PATH"
cargo build --release --workspace --all-targets
ROOT="$PWD"
printf "%8s %8s %10s %10s %12s %12s %12s %9s %8s %10s %12s %12s\n" sensors sets "p50 ms" "p99 ms" "warm-up max" "age p50 ms" "age p99 ms" dropped incompl "NTP<1ms" "RMSE mm" "frames lost"
for n in $COUNTS; do
  dir="$ROOT/target/scale/$n"
  rm -rf "$dir"; mkdir -p "$dir"
  python3 scripts/graph.py --sensors "$n" --rig "ring-$n" --root "$ROOT/" --out-dir "$dir/out" > "$dir/graph.yml"
  # The sources end the run (STOP_AFTER_SECS), so every set reaches the recorder (dataflows/README.md).
  (cd "$dir" && STOP_AFTER_SECS="$SECS" dora run graph.yml --stop-after "$((SECS + 30))s" > "$dir/dora-run.log" 2>&1) || {
    echo "dora run failed for $n sensors; see $dir/dora-run.log"; exit 1; }
  python3 - "$dir/out/summary.json" "$n" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
share = min((v["share_below_1ms"] for v in s["ntp"].values()), default=0.0)
rmse = s.get("rmse_all_m")
lost = sum(s["frames_lost"].values())
total = lost + sum(s["frames_in"].values())
print(f"{sys.argv[2]:>8} {s['sets_fused']:>8} {s['latency_ms']['p50']:>10.2f} {s['latency_ms']['p99']:>10.2f} "
      f"{s['warmup']['latency_ms']['max']:>12.1f} {s['age_ms']['p50']:>12.1f} {s['age_ms']['p99']:>12.1f} {s['dropped_sets']:>9} {s['incomplete_sets']:>8} {100 * share:>9.1f}% {rmse * 1000 if rmse else float('nan'):>12.1f}"
      f" {100 * lost / max(total, 1):>11.1f}%")
PY
done
