#!/usr/bin/env python3
"""Writes a trigait dataflow YAML for N simulated (or replayed) sensors.

The committed graphs in dataflows/ were generated with it; the scale benchmark (scripts/scale.sh)
uses it for 3, 8 and 16 sensors. Every graph runs the same four binaries: adding sensors is YAML only.

  scripts/graph.py --sensors 5 --rig ring-5 > dataflows/five-sensors.yml

With --filter one-euro|lowpass|none a `filter` node (trigait-filter-node) goes between
`trilaterate` and `recorder`; the recorder then records the filtered poses:

  scripts/graph.py --filter one-euro --clocks 35:60,-50:-100,12:100 > dataflows/filtered.yml
"""
import argparse
import math
import sys


def data_input(name: str, source: str, queue_size: int) -> str:
    """An input on a result edge: lossless (`queue_policy: backpressure`).

    dora 1.1 sends an output straight to its consumers over zenoh once its start-up handshake
    succeeds, and that path drops silently under congestion (dora-rs/dora#3397, #3439): we lost
    seq 2-3 of a run that way. A backpressure consumer pins the producer's output to the daemon
    path, which queues (up to 10 x queue_size, then drops with an error) instead. Only the result chain after `sync` (sets, poses,
    timings) takes it: a source on the daemon path blocks on every send, which delays its NTP
    replies until the clock filter rejects them (with 8 sensors, only one was synchronised for
    the first 0.7 s). A lost frame is one sample fewer, which sync tolerates and the recorder
    counts (`frames_lost`); a lost exchange likewise.
    """
    return (
        f"      {name}:\n        source: {source}\n        queue_size: {queue_size}\n"
        "        queue_policy: backpressure\n"
    )


def source(i: int, args: argparse.Namespace, root: str) -> str:
    sid = f"k{i + 1}"
    env = [f"SENSOR_ID: {sid}", f"RIG: {args.rig}", f"BACKEND: {args.backend}"]
    if args.backend == "sim":
        offset = round(50.0 * math.sin(1.7 * i + 0.5), 1)
        drift = round(100.0 * math.cos(2.3 * i + 0.3), 1)
        if args.clocks:
            clocks = args.clocks.split(",")
            offset, drift = (c.strip() for c in clocks[i % len(clocks)].split(":"))
        env += [f'CLOCK_OFFSET_MILLIS: "{offset}"', f'CLOCK_DRIFT_PPM: "{drift}"']
    else:
        files = args.replay_files.split(",")
        env += [f"REPLAY_FILE: {files[i % len(files)]}", "REPLAY_SPEED: realtime"]
    lines = "\n".join(f"      {e}" for e in env)
    # The ground truth is the same world for every simulated source: the rig's first sends it.
    outputs = "[frame, ntp_reply, ground_truth]" if args.backend == "sim" and i == 0 else "[frame, ntp_reply]"
    return f"""  - id: {sid}
    build: cargo build --release --workspace --all-targets
    path: {root}target/release/trigait-kinect-source-node
    inputs:
      ntp_request: sync/ntp_request_{sid}
    outputs: {outputs}
    env:
{lines}
"""


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--sensors", type=int, default=3)
    p.add_argument("--rig", default="thesis")
    p.add_argument("--policy", default="interpolate")
    p.add_argument("--method", default="fusion")
    p.add_argument("--backend", default="sim", choices=["sim", "replay"])
    p.add_argument("--replay-files", default="")
    p.add_argument("--out-dir", default="out")
    p.add_argument("--root", default="../", help="path from the graph's folder to the workspace")
    p.add_argument("--title", default="")
    p.add_argument(
        "--clocks",
        default="",
        help="per-sensor OFFSET_MS:DRIFT_PPM list (comma-separated) instead of the generated ones",
    )
    p.add_argument(
        "--filter",
        default="",
        choices=["", "one-euro", "lowpass", "none"],
        help="put a filter node of this kind between trilaterate and recorder",
    )
    args = p.parse_args()
    n = args.sensors
    root = args.root
    ids = [f"k{i + 1}" for i in range(n)]
    # Frame queues hold a few seconds' worth (default 10): at start-up the consumers are still
    # setting up (the recorder opens its recording) while every source already sends.
    sync_inputs = "".join(
        f"      frame_{s}:\n        source: {s}/frame\n        queue_size: 100\n      ntp_{s}: {s}/ntp_reply\n"
        for s in ids
    )
    # One NTP request output per source: a request reaches only its sensor (see the sync node).
    sync_outputs = "".join(f"      - ntp_request_{s}\n" for s in ids)
    # The recorder gets every raw frame from sync (inside frame_timing), so its inputs do not
    # grow with the sensors: a sensor is its source block and its sync lines.
    rec_inputs = ""
    if args.backend == "sim":
        rec_inputs += f"      ground_truth:\n        source: {ids[0]}/ground_truth\n        queue_size: 1000\n"
    filter_node = ""
    pose_source = "trilaterate"
    if args.filter:
        pose_source = "filter"
        filter_env = {
            "one-euro": '      ONE_EURO_MIN_CUTOFF_HZ: "1.0"\n      ONE_EURO_BETA: "2.0"\n'
            '      ONE_EURO_DERIVATIVE_CUTOFF_HZ: "1.0"\n      MAX_GAP_SECS: "0.2"\n',
            "lowpass": '      LOWPASS_CUTOFF_HZ: "6"\n      LOWPASS_ORDER: "2"\n      MAX_GAP_SECS: "0.2"\n',
            "none": "",
        }[args.filter]
        filter_node = f"""
  - id: filter
    build: cargo build --release --workspace --all-targets
    path: {root}target/release/trigait-filter-node
    inputs:
{data_input("fused_pose", "trilaterate/fused_pose", 100)}    outputs: [fused_pose]
    env:
      FILTER: {args.filter}
{filter_env}"""
    out = []
    if args.title:
        out.append("".join(f"# {line}\n" for line in args.title.split("\\n")))
    if args.filter:
        out.append("# Generated by scripts/graph.py; the four binaries of dataflow.yml plus the filter node.\n")
    else:
        out.append("# Generated by scripts/graph.py; the same four binaries as dataflow.yml, only YAML differs.\n")
    out.append("nodes:\n")
    for i in range(n):
        out.append(source(i, args, root) + "\n")
    out.append(f"""  - id: sync
    build: cargo build --release --workspace --all-targets
    path: {root}target/release/trigait-sync-node
    inputs:
      tick: dora/timer/millis/10
{sync_inputs}    outputs:
      - aligned_set
      - frame_timing
{sync_outputs}    env:
      POLICY: {args.policy}
      FUSION_RATE_HZ: "30"

  - id: trilaterate
    build: cargo build --release --workspace --all-targets
    path: {root}target/release/trigait-trilaterate-node
    inputs:
{data_input("aligned_set", "sync/aligned_set", 100)}    outputs: [fused_pose]
    env:
      METHOD: {args.method}
      RIG: {args.rig}
{filter_node}
  - id: recorder
    build: cargo build --release --workspace --all-targets
    path: {root}target/release/trigait-recorder-node
    inputs:
{data_input("fused_pose", f"{pose_source}/fused_pose", 100)}{data_input("frame_timing", "sync/frame_timing", 100)}{rec_inputs}    env:
      OUTPUT_DIR: {args.out_dir}
      RIG: {args.rig}
""")
    sys.stdout.write("".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
