#!/usr/bin/env python3
"""A trigait pipeline stage in Python: a centred three-point smoother of fused poses.

It goes between `trilaterate` and `recorder` (dataflows/python-stage.yml) and was written from
the language-neutral message reference, operators/schema/MESSAGES.md, alone: it uses no trigait
code, only pyarrow and dora's Python node API (`pip install dora-rs==1.1.0 pyarrow`), to show
that a stage in another language plugs in by YAML.

What it does. Each joint's world position in pose k becomes the weighted mean of poses k-1, k,
k+1:

    p'(k) = w * p(k-1) + (1 - 2w) * p(k) + w * p(k+1)

with w = NEIGHBOUR_WEIGHT (0.25 by default: the binomial kernel [1, 2, 1] / 4, which keeps a
straight-line motion exactly and cuts the frame-to-frame second difference of white noise to a
quarter). Being centred it adds no lag to the trajectory, at the price of emitting
pose k only when pose k+1 has arrived: one fusion period later (33 ms at 30 Hz). The pose keeps
its own stamp, set number and metadata, so the recorder scores it against the ground truth at
the right instant and measures its latency (`trigait.trigger_sent_nanos`) honestly, wait
included.

A joint is smoothed only when the three poses are consecutive aligned sets (`set_seq` k-1, k,
k+1) and all three have the joint with a finite position; otherwise, as for the first and the
last pose of a run, it passes unchanged. Everything but the position (covariance, sensors used,
residual, estimator, skipped joints, missing sensors) is pose k's: the covariance stays the
single-instant fusion's, which does not count the smoothing's gain or its bias at a sharp turn.

A message that is not a one-row `fused_pose` (wrong Arrow type, nulls, a point of the wrong
length, a repeated joint) is logged and skipped, never fatal; the counts are printed when the
node stops.

env:
  NEIGHBOUR_WEIGHT   w above, 0 <= w <= 1/3 (default 0.25; 0 passes poses through, 1/3 is a
                     three-point moving mean)
"""

import logging
import math
import os
import sys

import pyarrow as pa

NODE = "python-stage"
INPUT = "fused_pose"
OUTPUT = "fused_pose"
WEIGHT_KEY = "NEIGHBOUR_WEIGHT"

log = logging.getLogger(NODE)

# ---- the message, as MESSAGES.md's `fused_pose` table gives it ------------------------------
# Every field is non-nullable and every list item is a non-null field named `item`.


def _item(data_type: pa.DataType) -> pa.Field:
    return pa.field("item", data_type, nullable=False)


def _field(name: str, data_type: pa.DataType) -> pa.Field:
    return pa.field(name, data_type, nullable=False)


POINT = pa.list_(_item(pa.float64()), 3)  # FixedSizeList<Float64, 3>, metres
MATRIX = pa.list_(_item(pa.float64()), 9)  # FixedSizeList<Float64, 9>, row-major, m²
FUSED_JOINT = pa.struct(
    [
        _field("joint", pa.uint8()),
        _field("position_in_world_m", POINT),
        _field("covariance_in_world_m2", MATRIX),
        _field("sensors_used", pa.list_(_item(pa.utf8()))),
        _field("residual_m", pa.float64()),
        _field("condition_number", pa.float64()),
        _field("estimator", pa.utf8()),
    ]
)
SKIPPED_JOINT = pa.struct([_field("joint", pa.uint8()), _field("reason", pa.utf8())])
FUSED_POSE = pa.struct(
    [
        _field("set_seq", pa.uint64()),
        _field("stamp_nanos", pa.int64()),
        _field("joints", pa.list_(_item(FUSED_JOINT))),
        _field("skipped", pa.list_(_item(SKIPPED_JOINT))),
        _field("missing_sensors", pa.list_(_item(pa.utf8()))),
    ]
)
JOINT_COUNT = 25  # Kinect v2 JointType numbers 0..=24


class Malformed(ValueError):
    """An input that is not a valid one-row `fused_pose`."""


def _no_nulls(value, path: str) -> None:
    """Every field of `fused_pose` is non-nullable, but Arrow does not enforce that on data."""
    if value is None:
        raise Malformed(f"{path}: null")
    if isinstance(value, dict):
        for key, item in value.items():
            _no_nulls(item, f"{path}.{key}")
    elif isinstance(value, list):
        for item in value:
            _no_nulls(item, path)


def _joint_codes(items: list, path: str) -> None:
    """Joint numbers are 0..=24 and each appears at most once in a list."""
    seen = set()
    for item in items:
        code = item["joint"]
        if code >= JOINT_COUNT:
            raise Malformed(f"{path}.joint: {code} is not a joint number 0..=24")
        if code in seen:
            raise Malformed(f"{path}.joint: joint {code} twice")
        seen.add(code)


def _fields(data_type: pa.DataType) -> list:
    return [data_type.field(i) for i in range(data_type.num_fields)]


def type_difference(got: pa.DataType, want: pa.DataType, path: str = "fused_pose") -> str:
    """The first place where `got` differs from `want`, short enough for a log line."""
    both = lambda test: test(got) and test(want)  # noqa: E731
    if both(pa.types.is_struct):
        names, wanted = [f.name for f in _fields(got)], [f.name for f in _fields(want)]
        if names != wanted:
            return f"{path}: fields {names}, expected {wanted}"
        for g, w in zip(_fields(got), _fields(want)):
            if g.nullable != w.nullable:
                return f"{path}.{g.name}: nullable {g.nullable}, expected {w.nullable}"
            if not g.type.equals(w.type):
                return type_difference(g.type, w.type, f"{path}.{g.name}")
    elif both(pa.types.is_list) or both(pa.types.is_fixed_size_list):
        if pa.types.is_fixed_size_list(got) and got.list_size != want.list_size:
            return f"{path}: {got.list_size} values, expected {want.list_size}"
        g, w = got.value_field, want.value_field
        if g.name != w.name or g.nullable != w.nullable:
            return f"{path}: items {g}, expected {w}"
        return type_difference(g.type, w.type, path)
    return f"{path}: {got}, expected {want}"


def decode(value: pa.Array) -> dict:
    """The one pose in `value` as a plain dict (field names as in MESSAGES.md).

    Raises Malformed with the reason when the type, the row count or a value is not what
    MESSAGES.md says, so that what this stage sends is always a pose the recorder accepts.
    """
    if not isinstance(value, pa.Array):
        raise Malformed(f"expected an Arrow array, got {type(value).__name__}")
    # equals() compares field names, types and nullability, nested ones included.
    if not value.type.equals(FUSED_POSE):
        raise Malformed(f"not a fused_pose: {type_difference(value.type, FUSED_POSE)}")
    if len(value) != 1:
        raise Malformed(f"expected exactly one row, got {len(value)}")
    (pose,) = value.to_pylist()
    if pose is None:
        raise Malformed("fused_pose: null row")
    _no_nulls(pose, "fused_pose")
    _joint_codes(pose["joints"], "fused_pose.joints")
    _joint_codes(pose["skipped"], "fused_pose.skipped")
    return pose


def encode(pose: dict) -> pa.Array:
    """`pose` as the one-row `fused_pose` array the recorder decodes."""
    return pa.array([pose], type=FUSED_POSE)


# ---- the smoother ---------------------------------------------------------------------------


def _positions(pose: dict) -> dict:
    """Joint number -> finite world position of `pose`."""
    out = {}
    for joint in pose["joints"]:
        p = joint["position_in_world_m"]
        if all(math.isfinite(v) for v in p):
            out[joint["joint"]] = p
    return out


class CentredSmoother:
    """Holds the last two poses; each new pose releases the one before it, smoothed."""

    def __init__(self, neighbour_weight: float):
        self.w = neighbour_weight
        self.prev = None  # (pose, metadata) of set k-1
        self.cur = None  # (pose, metadata) of set k, waiting for k+1
        self.joints_smoothed = 0
        self.joints_passed = 0

    def push(self, pose: dict, metadata: dict) -> list:
        """Takes pose k+1; returns the (pose, metadata) pairs ready to send (pose k, if any)."""
        ready = []
        if self.cur is not None:
            ready.append((self._smooth(self.prev, self.cur, pose), self.cur[1]))
        self.prev, self.cur = self.cur, (pose, metadata)
        return ready

    def flush(self) -> list:
        """The held pose, unchanged (it has no successor): at the end of the stream."""
        ready = []
        if self.cur is not None:
            pose = self.cur[0]
            self.joints_passed += len(pose["joints"])
            ready.append(self.cur)
        self.prev = self.cur = None
        return ready

    def _smooth(self, prev, cur, nxt: dict) -> dict:
        pose = cur[0]
        seq = pose["set_seq"]
        consecutive = (
            prev is not None
            and prev[0]["set_seq"] + 1 == seq
            and nxt["set_seq"] == seq + 1
        )
        before = _positions(prev[0]) if consecutive else {}
        after = _positions(nxt) if consecutive else {}
        here = _positions(pose)
        w = self.w
        joints = []
        for joint in pose["joints"]:
            code = joint["joint"]
            if code in before and code in after and code in here:
                a, b, c = before[code], here[code], after[code]
                joint = dict(joint)
                joint["position_in_world_m"] = [
                    w * a[i] + (1.0 - 2.0 * w) * b[i] + w * c[i] for i in range(3)
                ]
                self.joints_smoothed += 1
            else:
                self.joints_passed += 1
            joints.append(joint)
        return dict(pose, joints=joints)


# ---- the node -------------------------------------------------------------------------------


def neighbour_weight(env) -> float:
    """NEIGHBOUR_WEIGHT from `env`; a bad value stops the node with the key and the value."""
    text = env.get(WEIGHT_KEY, "0.25")
    try:
        w = float(text)
    except ValueError:
        w = math.nan
    if not (0.0 <= w <= 1.0 / 3.0):
        raise SystemExit(
            f"{NODE}: {WEIGHT_KEY}={text!r} is invalid: expected a number from 0 to 1/3"
        )
    return w


def forwarded(metadata: dict) -> dict:
    """The metadata parameters to send on: all of them but dora's own `timestamp`."""
    return {k: v for k, v in (metadata or {}).items() if k != "timestamp"}


def main() -> int:
    logging.basicConfig(
        stream=sys.stderr, level=logging.INFO, format=f"%(levelname)s {NODE}: %(message)s"
    )
    smoother = CentredSmoother(neighbour_weight(os.environ))
    from dora import Node  # here, so the unit tests need only pyarrow

    node = Node()
    received = sent = malformed = 0

    def send(ready):
        nonlocal sent
        for pose, metadata in ready:
            node.send_output(OUTPUT, encode(pose), metadata)
            sent += 1

    for event in node:
        kind = event["type"]
        if kind == "STOP":
            break
        if kind != "INPUT":
            continue
        if event["id"] != INPUT:
            log.warning("ignoring unknown input %r", event["id"])
            continue
        received += 1
        try:
            pose = decode(event["value"])
        except Malformed as e:
            malformed += 1
            log.warning("skipping a malformed fused pose: %s", e)
            continue
        send(smoother.push(pose, forwarded(event["metadata"])))
    send(smoother.flush())
    log.info(
        "stopped: %d poses in, %d out, %d malformed; %d joints smoothed, %d passed unchanged",
        received,
        sent,
        malformed,
        smoother.joints_smoothed,
        smoother.joints_passed,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
