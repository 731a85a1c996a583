"""Unit tests of pose_smoother.py without a running graph (pyarrow only):
`python -m unittest discover -s nodes/python-stage` (run by tests/python_stage.rs).

What could be wrong and is checked: the kernel is not the documented one or lags; a gap in the
set sequence, a missing joint or a NaN gets smoothed across; a field other than the position
changes; the metadata is lost; a malformed message (another type, a nullable field, two rows, a
null, a bad joint number, a repeated joint, a short point) crashes the stage or gets through;
a bad NEIGHBOUR_WEIGHT is accepted.
"""

import math
import unittest

import pyarrow as pa

import pose_smoother as ps


def joint(code, position, sensors=("k1", "k2", "k3")):
    return {
        "joint": code,
        "position_in_world_m": list(position),
        "covariance_in_world_m2": [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4],
        "sensors_used": list(sensors),
        "residual_m": 0.002,
        "condition_number": 3.5,
        "estimator": "fusion",
    }


def pose(seq, joints, skipped=(), missing=()):
    return {
        "set_seq": seq,
        "stamp_nanos": 1_000_000_000 + seq * 33_333_333,
        "joints": joints,
        "skipped": [{"joint": j, "reason": r} for j, r in skipped],
        "missing_sensors": list(missing),
    }


def run(smoother, poses):
    out = []
    for i, p in enumerate(poses):
        out += smoother.push(p, {"trigait.trigger_sent_nanos": i})
    return out + smoother.flush()


class Smoother(unittest.TestCase):
    def test_binomial_kernel_centred_one_pose_late(self):
        # Knee (13) on a parabola x = t² plus a straight line in y: [1, 2, 1]/4 keeps the line
        # exactly and adds w·x'' = 0.25·2 = 0.5 to the parabola; no lag.
        poses = [pose(k, [joint(13, [k * k, 2.0 * k, 0.5])]) for k in range(5)]
        out = run(ps.CentredSmoother(0.25), poses)
        self.assertEqual([p["set_seq"] for p, _ in out], [0, 1, 2, 3, 4])
        self.assertEqual([m["trigait.trigger_sent_nanos"] for _, m in out], [0, 1, 2, 3, 4])
        xs = [p["joints"][0]["position_in_world_m"] for p, _ in out]
        self.assertEqual(xs[0], [0.0, 0.0, 0.5])  # first: no predecessor, unchanged
        for k in (1, 2, 3):
            self.assertAlmostEqual(xs[k][0], k * k + 0.5)
            self.assertAlmostEqual(xs[k][1], 2.0 * k)
            self.assertAlmostEqual(xs[k][2], 0.5)
        self.assertEqual(xs[4], [16.0, 8.0, 0.5])  # last: flushed unchanged

    def test_each_pose_is_released_by_its_successor(self):
        s = ps.CentredSmoother(0.25)
        self.assertEqual(s.push(pose(0, []), {}), [])
        self.assertEqual([p["set_seq"] for p, _ in s.push(pose(1, []), {})], [0])

    def test_only_the_position_changes(self):
        a, b, c = (pose(k, [joint(12, [k, 0, 0])], [(3, "too few sensors")], ["k2"]) for k in range(3))
        b["joints"][0]["sensors_used"] = ["k1"]
        out = run(ps.CentredSmoother(0.25), [a, b, c])
        got = out[1][0]
        expected = dict(b, joints=[dict(b["joints"][0], position_in_world_m=[1.0, 0.0, 0.0])])
        self.assertEqual(got, expected)

    def test_no_smoothing_across_a_gap_a_missing_joint_or_a_nan(self):
        poses = [
            pose(0, [joint(12, [0, 0, 0]), joint(13, [0, 0, 0])]),
            pose(1, [joint(12, [1, 0, 0]), joint(13, [1, 0, 0]), joint(14, [1, 0, 0])]),
            pose(2, [joint(12, [4, 0, 0]), joint(13, [math.nan, 0, 0])]),
            pose(4, [joint(12, [9, 0, 0])]),  # set 3 never came
            pose(5, [joint(12, [9, 0, 0])]),
        ]
        s = ps.CentredSmoother(0.25)
        out = {p["set_seq"]: p for p, _ in run(s, poses)}
        at = lambda seq, code: next(
            j["position_in_world_m"] for j in out[seq]["joints"] if j["joint"] == code
        )
        self.assertEqual(at(1, 12), [1.5, 0.0, 0.0])  # 0.25·0 + 0.5·1 + 0.25·4
        self.assertEqual(at(1, 13), [1.0, 0.0, 0.0])  # NaN in the next pose
        self.assertEqual(at(1, 14), [1.0, 0.0, 0.0])  # absent from both neighbours
        self.assertEqual(at(2, 12), [4.0, 0.0, 0.0])  # its successor is set 4, not 3
        self.assertTrue(math.isnan(at(2, 13)[0]))  # passed on as is
        self.assertEqual(at(4, 12), [9.0, 0.0, 0.0])  # its predecessor is set 2
        self.assertEqual((s.joints_smoothed, s.joints_passed), (1, 8))

    def test_weight_zero_passes_through(self):
        poses = [pose(k, [joint(12, [k * k, 0, 0])]) for k in range(4)]
        out = run(ps.CentredSmoother(0.0), poses)
        self.assertEqual([p for p, _ in out], poses)


class Wire(unittest.TestCase):
    def test_round_trip_with_the_documented_type(self):
        p = pose(7, [joint(12, [1.0, 2.0, 0.9])], [(14, "too few sensors")], ["k3"])
        array = ps.encode(p)
        self.assertTrue(array.type.equals(ps.FUSED_POSE))
        self.assertEqual(ps.decode(array), p)

    def assert_malformed(self, value, why):
        with self.assertRaises(ps.Malformed) as e:
            ps.decode(value)
        self.assertIn(why, str(e.exception))

    def test_malformed_inputs_are_refused_with_a_reason(self):
        good = pose(1, [joint(12, [1.0, 2.0, 0.9])])
        self.assert_malformed(pa.array([1, 2, 3]), "not a fused_pose: fused_pose: int64, expected struct")
        self.assert_malformed(pa.array([good, good], type=ps.FUSED_POSE), "exactly one row")
        self.assert_malformed(pa.array([None], type=ps.FUSED_POSE), "null row")
        nulls = pose(1, [joint(12, [1.0, 2.0, 0.9], sensors=("k1", None))])
        self.assert_malformed(ps.encode(nulls), "fused_pose.joints.sensors_used: null")
        nulls = pose(1, [joint(12, [1.0, 2.0, 0.9])])
        nulls["joints"][0]["covariance_in_world_m2"][4] = None
        self.assert_malformed(ps.encode(nulls), "covariance_in_world_m2: null")
        self.assert_malformed(
            ps.encode(pose(1, [], skipped=[(3, "a"), (3, "b")])), "fused_pose.skipped.joint"
        )
        self.assert_malformed(ps.encode(pose(1, [joint(30, [0, 0, 0])])), "not a joint number")
        self.assert_malformed(
            ps.encode(pose(1, [joint(12, [0, 0, 0]), joint(12, [1, 0, 0])])), "twice"
        )
        self.assert_malformed(
            ps.encode(pose(1, [joint(12, [0, None, 0])])), "position_in_world_m: null"
        )
        self.assert_malformed("not arrow", "expected an Arrow array")
        # The same fields with `set_seq` nullable is another type.
        fields = [ps.FUSED_POSE.field(i) for i in range(ps.FUSED_POSE.num_fields)]
        fields[0] = fields[0].with_nullable(True)
        self.assert_malformed(
            pa.array([good], type=pa.struct(fields)),
            "fused_pose.set_seq: nullable True, expected False",
        )
        # Another message, e.g. an aligned_set, names its fields.
        other = pa.struct([pa.field("seq", pa.uint64(), nullable=False)])
        self.assert_malformed(
            pa.array([{"seq": 1}], type=other), "fused_pose: fields ['seq'], expected ['set_seq'"
        )

    def test_type_difference_names_the_nested_field(self):
        def fused_pose_with_point(point):
            joint = pa.struct(
                [point if f.name == "position_in_world_m" else f for f in ps._fields(ps.FUSED_JOINT)]
            )
            return pa.struct(
                [
                    pa.field("joints", pa.list_(ps._item(joint)), nullable=False)
                    if f.name == "joints"
                    else f
                    for f in ps._fields(ps.FUSED_POSE)
                ]
            )

        short = pa.field("position_in_world_m", pa.list_(ps._item(pa.float64()), 2), nullable=False)
        self.assertEqual(
            ps.type_difference(fused_pose_with_point(short), ps.FUSED_POSE),
            "fused_pose.joints.position_in_world_m: 2 values, expected 3",
        )
        f32 = pa.field("position_in_world_m", pa.list_(ps._item(pa.float32()), 3), nullable=False)
        self.assertEqual(
            ps.type_difference(fused_pose_with_point(f32), ps.FUSED_POSE),
            "fused_pose.joints.position_in_world_m: float, expected double",
        )


class Config(unittest.TestCase):
    def test_neighbour_weight(self):
        self.assertEqual(ps.neighbour_weight({}), 0.25)
        self.assertEqual(ps.neighbour_weight({"NEIGHBOUR_WEIGHT": "0"}), 0.0)
        for bad in ("0.5", "-0.1", "nan", "quarter"):
            with self.assertRaises(SystemExit) as e:
                ps.neighbour_weight({"NEIGHBOUR_WEIGHT": bad})
            self.assertIn(f"NEIGHBOUR_WEIGHT={bad!r}", str(e.exception))

    def test_dora_timestamp_is_not_forwarded(self):
        self.assertEqual(
            ps.forwarded({"timestamp": object(), "trigait.trigger_sent_nanos": 5}),
            {"trigait.trigger_sent_nanos": 5},
        )
        self.assertEqual(ps.forwarded(None), {})


if __name__ == "__main__":
    unittest.main()
