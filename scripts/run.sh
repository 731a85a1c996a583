#!/usr/bin/env bash
# The README's run command: the default graph (3 simulated Kinects on the thesis rig, NTP sync,
# interpolation, fusion, headless rerun recording) for 15 s, then a readable summary.
#   scripts/run.sh            # then: .venv/bin/rerun out/trigait.rrd
#   scripts/run.sh dataflows/python-stage.yml   # any other graph; the summary of its OUTPUT_DIR
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/venv.sh   # .venv/ with the pinned packages of scripts/requirements.txt
export PATH="$PWD/.venv/bin:$PATH"

echo "==> building the nodes (release)"
cargo build --release --workspace --all-targets
GRAPH="${1:-dataflow.yml}"
# The recorder's OUTPUT_DIR, relative to the graph's folder (where dora starts the nodes); a
# graph without a recorder (depth.yml) has no summary to print.
OUT_DIR="$(python3 - "$GRAPH" <<'PY'
import sys, yaml
graph = yaml.safe_load(open(sys.argv[1]))
for node in graph.get("nodes", []):
    if "recorder" in str(node.get("path", "")):
        print((node.get("env") or {}).get("OUTPUT_DIR", "out"))
        break
PY
)"
if [ -z "$OUT_DIR" ]; then
  echo "$GRAPH has no recorder node: run it with \`dora run $GRAPH\` (no summary to print)" >&2
  exit 2
fi
OUT="$(dirname "$GRAPH")/$OUT_DIR"
OUT="$(realpath --relative-to=. -m "$OUT")"
rm -f "$OUT/summary.json"
# The sources end the run after STOP_AFTER (their STOP_AFTER_SECS, inherited from this
# environment), so the graph shuts down source first and every set reaches the recorder;
# --stop-after is only a safety net.
secs="${STOP_AFTER:-15s}"
secs="${secs%s}"
echo "==> dora run $GRAPH (${secs} s)"
STOP_AFTER_SECS="$secs" dora run "$GRAPH" --stop-after "$((secs + 30))s"

python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
s = json.load(open(f"{out}/summary.json"))
print()
print(f"trigait summary ({out}/summary.json)")
lost = s.get("frames_lost", {})
print(f"  frames in        : {', '.join(f'{k} {v} (lost {lost.get(k, 0)})' for k, v in s['frames_in'].items())}")
impossible = {k: v for k, v in s.get("impossible_joints", {}).items() if v}
if impossible:
    print(f"  impossible joints: {', '.join(f'{k} {v}' for k, v in impossible.items())} (not finite, behind the sensor or beyond 20 m: recorded, not fused)")
print(f"  sets fused       : {s['sets_fused']}  (dropped {s['dropped_sets']}, incomplete {s['incomplete_sets']})")
if s.get("estimators"):
    print(f"  estimator        : {', '.join(f'{k} ({v} joints)' for k, v in s['estimators'].items())}")
if s.get("rmse_all_m") is not None:
    print(f"  RMSE vs truth    : {s['rmse_all_m'] * 1000:.1f} mm over {s['truth_samples']} joint samples")
    for j, r in s["rmse_m"].items():
        print(f"      {j:<12} {r * 1000:6.1f} mm")
for k, n in s["ntp"].items():
    e = n["abs_error_ms"]
    print(f"  NTP {k:<4}         : offset {n['offset_ms'] or 0:+.3f} ms, drift {n['drift_ppm'] or 0:+.1f} ppm, "
          f"|error| p50 {e['p50']:.3f} ms p99 {e['p99']:.3f} ms, {100 * n['share_below_1ms']:.1f} % < 1 ms")
l = s["latency_ms"]
if l.get("count", 1):
    print(f"  latency          : p50 {l['p50']:.2f} ms, p99 {l['p99']:.2f} ms (frame sent -> pose recorded)")
else:
    print("  latency          : n/a (no pose was timed from its frames' sending: a replay as fast as possible)")
w = s["warmup"]
print(f"  warm-up          : {w['poses']} poses in the first {w['secs']:g} s, latency max {w['latency_ms']['max']:.1f} ms (not in the above)")
d = s.get("wind_down", {})
if d.get("poses"):
    print(f"  wind-down        : {d['poses']} poses after a source's last frame, latency max {d['latency_ms']['max']:.1f} ms (not in the above)")
a = s["age_ms"]
print(f"  pose age         : p50 {a['p50']:.1f} ms, p99 {a['p99']:.1f} ms (fusion instant -> recorded)")
wait = s.get("sync_wait", {})
if wait.get("deadline_ms") is not None:
    why = ", ".join(f"{k} {v}" for k, v in sorted(wait["released"].items()))
    print(f"  sets handed on   : {why} (a set waits for each sensor's next frame, at most "
          f"{wait['frame_wait_margin_ms']:g} ms past its expected arrival, {wait['deadline_ms']:g} ms in all)")
print(f"  gaps             : {len(s['gaps'])}")
g = s.get("gait") or {}
if g.get("cadence_steps_per_min") is not None:
    num = lambda key, digits: "n/a" if g.get(key) is None else f"{g[key]:.{digits}f}"
    print(f"  gait             : {g['strides']} strides, cadence {num('cadence_steps_per_min', 1)} steps/min, "
          f"stride {num('stride_length_m', 3)} m, speed {num('speed_mps', 3)} m/s, "
          f"step width {num('step_width_m', 3)} m (filter {g.get('filter') or 'none'})")
elif g:
    print(f"  gait             : no parameters ({g.get('reason')})")
print(f"  recording        : {out}/trigait.rrd  (view: .venv/bin/rerun {out}/trigait.rrd)")
print(f"  exports          : {out}/trajectory.txt (thesis format), {out}/trajectory.csv/.trc/.c3d (trigait gait/export read them)")
import os
if os.path.exists(f"{out}/report.html"):
    print(f"  gait report      : {out}/report.html (open it in a browser)")
PY
