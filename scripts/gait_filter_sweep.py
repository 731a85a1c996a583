#!/usr/bin/env python3
"""Which trajectory filter suits Kinect skeleton streams: the sweep behind `trigait gait`'s default.

For each filter (none, zero-lag Butterworth 4/6/8/10 Hz, One-Euro), every walk of
../shared/data with joint centres (CMU 07_01, OpenSim Rajagopal) is played through the simulated
three-Kinect pipeline (`trigait gait --kinect-sim`, seeds 1-10) and its stride length, cadence
and step width are compared with the walk's own; then the real Kinect SDK logs are analysed with
the same filter (`trigait gait --filter`) and their strides and steps listed. The filter runs
after the analysis rejects outliers.

Run from the repository, after the one release build:
    cargo build --release --workspace --all-targets
    python3 scripts/gait_filter_sweep.py
The shared data is read from $TRIGAIT_SHARED_DATA, else ../shared/data beside the clone, and
the binary from $CARGO_TARGET_DIR/release, else target/release. Standard library only.
"""

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "trigait"
DATA = Path(os.environ.get("TRIGAIT_SHARED_DATA", ROOT.parent / "shared" / "data"))
WALKS = {
    "CMU 07_01": DATA / "mocap-cmu-07_01" / "07_01.c3d",
    "Rajagopal": DATA / "mocap-opensim-rajagopal-walk" / "Rajagopal__motion_capture_walk.trc",
}
KINECT_LOGS = {
    "CHU": DATA / "kinect-v2-vicon-chu-walk" / "JointsInfo_before_CHU_test.txt",
    "Straight": DATA / "kinect-v2-skeleton-replay" / "JointsInfo_Straight.txt",
    "Cyrille": DATA / "kinect-v2-skeleton-replay" / "JointsInfo_Cyrille_v2_2.txt",
}
FILTERS = ["none", "butterworth:4hz", "butterworth:6hz", "butterworth:8hz", "butterworth:10hz", "one-euro"]
SEEDS = range(1, 11)


def gait(*args):
    out = subprocess.run([str(BIN), "gait", *map(str, args), "--json"], capture_output=True, text=True)
    if out.returncode != 0:
        lines = out.stderr.strip().splitlines()
        return None, lines[-1] if lines else f"exit status {out.returncode}"

    return json.loads(out.stdout), None


def simulated(flt):
    errors = {"stride": [], "cadence": [], "width": []}
    within = runs = 0
    for path in WALKS.values():
        for seed in SEEDS:
            doc, err = gait(path, "--kinect-sim", "--kinect-filter", flt, "--seed", seed)
            if doc is None:
                sys.exit(f"{path} seed {seed}: {err}")
            sim = doc["kinect_sim"]
            c = sim["comparison"]
            for key, field, scale in [("stride", "stride_length_m", 100), ("cadence", "cadence_pct", 1), ("width", "step_width_m", 100)]:
                if c[field] is not None:
                    errors[key].append(abs(c[field]) * scale)
            within += sim["within_tolerances"]
            runs += 1
    cells = [f"{statistics.mean(v):.2f} / {max(v):.2f}" for v in errors.values()]
    return cells + [f"{within}/{runs}"]


def real(flt):
    lines = []
    for name, path in KINECT_LOGS.items():
        doc, err = gait(path, "--filter", flt)
        if doc is None:
            lines.append(f"  {name}: {err.split(': ', 2)[-1][:90]}")
            continue
        strides = ", ".join(f"{s['foot'][0].upper()} {s['stride_length_m']:.2f} m {s['cadence_steps_per_min']:.0f}/min" for s in doc["strides"])
        steps = ", ".join(f"{s['foot'][0].upper()} {(s['step_length_m'] or 0):.2f} m {s['cadence_steps_per_min']:.0f}/min" for s in doc["steps"])
        flag = " (time base flagged)" if doc["timing"]["implausible"] else ""
        left_out = ", ".join(
            f"{s['foot'][0].upper()} {what} {s['cadence_steps_per_min']:.0f}/min"
            for what, key in [("stride", "inconsistent_strides"), ("step", "inconsistent_steps")]
            for s in doc.get(key, [])
        )
        if left_out:
            flag += f" left out, heel strikes off the body's travel: [{left_out}]"
        lines.append(f"  {name}: strides [{strides}] steps [{steps}]{flag}")
    return lines


def main():
    if not BIN.exists():
        sys.exit(f"{BIN} is missing: run the release build first (see the top of this script)")
    missing = [p for p in [*WALKS.values(), *KINECT_LOGS.values()] if not p.exists()]
    if missing:
        sys.exit(f"missing shared data: {', '.join(map(str, missing))}")
    print("simulated Kinect pipeline, |difference| from the walk's own joint centres, mean / max over")
    print(f"{len(WALKS)} walks x {len(SEEDS)} seeds; within = all of stride 3 cm, cadence 2 %, width 2 cm")
    print(f"{'filter':18} {'stride (cm)':>14} {'cadence (%)':>14} {'width (cm)':>14} {'within':>8}")
    for flt in FILTERS:
        stride, cadence, width, within = simulated(flt)
        print(f"{flt:18} {stride:>14} {cadence:>14} {width:>14} {within:>8}")
    print("\nreal Kinect v2 SDK logs (no reference: every figure should be a walking one)")
    for flt in FILTERS:
        print(flt)
        for line in real(flt):
            print(line)


if __name__ == "__main__":
    main()
