"""The glovepose Python package against the C++ API and the tool, with unittest.

- The same rows give the same poses: a simulated session (raw readout rows) streamed through
  glovepose.Estimator with the protocol of capi/tests/cpp_reference.cpp (paper readout, 1-euro
  smoothing 60/1/0.5/1, joints on, calibration frames between start and finish) equals, exactly,
  the poses capi_cpp_reference prints from glovepose::GlovePoseEstimator (%.17g, a double's exact
  round trip): angles, raw angles, joints, sequences.
- A malformed model raises GloveposeError carrying the library's message.
- load_dataset gives the values `glovepose simulate --csv` writes for the same data.
- The ctypes structs have the C ABI's layout: the sizes the library's own *_init functions write
  and the sizes and offsets capi/ documents (its static_asserts, the header, the C test); the
  package's constants and enums are the header's #defines.
- Calibration ranges: the training range is the one in the model file's metadata; a range set is
  the range read back, saved and loaded exactly; cells() is the frame pushed.
- OpenXR joints are the joint list's joints in another frame (a rigid motion, the same for every
  pose), with constant bone lengths along XR_JOINT_PARENTS and velocities equal to the finite
  differences of the positions and orientations; a left hand mirrors the right one (x -> -x) for
  the same readings; pose_at equals the newest pose at its time, interpolates linearly between
  two poses, and extrapolates along the least-squares slope of the poses in prediction_window,
  for at most max_prediction.
- A Latest gives reader threads the hand the estimator published: its pose, joints and OpenXR
  joints, never torn while the writer streams.
- The pinch and aim state (XR_FB_hand_tracking_aim) follows the poses: strengths in [0, 1], a
  pinch flag only where the strength says the tips are closer than the 15 mm onset or the 18 mm
  release allows, VALID as the pose is trusted, the aim pose fixed in the wrist frame and mirrored
  on a left hand; a Latest gives readers the state published with the pose, with its sequence.
- The guided calibration steps are the sequence in the model file's metadata (read here with json),
  and the progress follows it step by step as frames arrive.

Environment (CTest sets it): GLOVEPOSE_LIBRARY, GLOVEPOSE_CPP_REFERENCE, GLOVEPOSE_CLI.
"""
import ctypes
import json
import os
import re
import struct
import subprocess
import tempfile
import threading
import unittest
from pathlib import Path

import numpy as np

import glovepose
from glovepose import _library

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "glovepose_fcn512.safetensors"


def stream(dataset: dict, *estimators):
    """Pushes a simulated session's cells through each estimator, calibrating on the fly over its
    calibration frames; yields the frame index after every frame all of them solved."""
    end = int(np.argmax(dataset["kind"] == 0))
    cells, stamps = dataset["cells"].astype(np.float64), dataset["timestamps"]
    for e in estimators:
        e.start_calibration()
    for f in range(len(cells)):
        if f == end:
            for e in estimators:
                e.finish_calibration()
        if [e.push_cells(cells[f], stamps[f]) for e in estimators] == [glovepose.SOLVED] * len(estimators) and f > end:
            yield f


def joint_limits():
    """The shipped model's joint limits (radians, DOF_NAMES order) from its file's metadata."""
    metadata = glovepose.load_dataset(MODEL)["metadata"]
    return np.array(json.loads(metadata["joint_limits_min"])), np.array(json.loads(metadata["joint_limits_max"]))


def rigid_fit(a: np.ndarray, b: np.ndarray):
    """Kabsch: the rotation R and translation t minimising |R a + t - b| over the rows, and the
    largest residual."""
    ca, cb = a.mean(0), b.mean(0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    translation = cb - rotation @ ca
    return rotation, translation, float(np.abs(a @ rotation.T + translation - b).max())


def quaternion_product(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton products of rows x, y, z, w."""
    x1, y1, z1, w1 = p.T
    x2, y2, z2, w2 = q.T
    return np.stack([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2], axis=1)


class Session(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.TemporaryDirectory()
        cls.dataset = Path(cls.work.name) / "session.safetensors"
        cls.csv = Path(cls.work.name) / "session.csv"
        subprocess.run([os.environ["GLOVEPOSE_CLI"], "simulate", "--seed", "41", "--subjects", "1", "--sessions", "1", "--gloves", "1",
                        "--minutes", "0.1", "--calibration-seconds", "3", "--raw-rows", "--threads", "1", "--out", str(cls.dataset),
                        "--csv", str(cls.csv)], check=True, stdout=subprocess.DEVNULL)

    @classmethod
    def tearDownClass(cls):
        cls.work.cleanup()

    def test_isa_is_the_tools_and_realtime_loads(self):
        # The library and the tool choose alike (glovepose::compiled, the best set this CPU executes).
        version = subprocess.run([os.environ["GLOVEPOSE_CLI"], "--version"], check=True, capture_output=True, text=True).stdout
        self.assertIn(f"\nnetworks: {glovepose.isa} (", version)
        model = glovepose.PoseModel(MODEL, weights="realtime")
        self.assertEqual(model.cell_count, 44)
        with self.assertRaisesRegex(ValueError, "realtime"):
            glovepose.PoseModel("unused.safetensors", weights="fast")

    def test_load_dataset_gives_the_tools_values(self):
        data = glovepose.load_dataset(self.dataset)
        table = np.loadtxt(self.csv, delimiter=",", skiprows=1)
        self.assertEqual(data["cells"].shape, (len(table), 44))
        np.testing.assert_array_equal(data["cells"], table[:, 3:47].astype(np.float32))
        np.testing.assert_array_equal(data["angles"], table[:, 47:72].astype(np.float32))
        np.testing.assert_array_equal(data["timestamps"], table[:, 2])
        np.testing.assert_array_equal(data["subject"], table[:, 0].astype(np.int32))
        self.assertEqual(data["raw_rows"].shape, (len(table), 180))
        self.assertEqual(data["metadata"]["glove_layout"], "glauser2019-44")

    def test_estimator_poses_equal_the_cpp_api(self):
        data = glovepose.load_dataset(self.dataset)
        rows, stamps, kind = data["raw_rows"].tolist(), data["timestamps"].tolist(), data["kind"]
        rate = float(data["metadata"]["frame_rate"])  # the row clock of capi/tests/cpp_reference.cpp
        reference = subprocess.run([os.environ["GLOVEPOSE_CPP_REFERENCE"], "session", str(MODEL), str(self.dataset)],
                                   check=True, capture_output=True, text=True).stdout
        expected = [line.split() for line in reference.splitlines() if line.startswith("pose")]
        model = glovepose.PoseModel(MODEL)
        self.assertEqual((model.cell_count, model.row_count, model.glove_id), (44, 180, "glauser2019-44"))
        estimator = glovepose.Estimator(model, smoothing=True, smoothing_frequency=60.0, smoothing_min_cutoff=1.0, smoothing_beta=0.5,
                                        smoothing_d_cutoff=1.0, joint_transforms=True)
        calibration_end = int(np.argmax(kind == 0))
        self.assertGreater(calibration_end, 0)
        estimator.start_calibration()
        got = []
        for f in range(len(rows)):
            if f == calibration_end:
                estimator.finish_calibration()
            for r in range(180):
                if estimator.push_row(r, rows[f][r], glovepose.row_time(stamps[f], r, 180, rate)) == glovepose.SOLVED:
                    pose, joints = estimator.pose(), estimator.joints()
                    self.assertEqual(pose.angles.shape, (25,))
                    self.assertEqual(joints.shape, (21, 7))
                    got.append((f, r, pose, joints))
        self.assertGreater(len(got), 100)
        self.assertEqual(len(got), len(expected))
        worst = 0.0
        for (f, r, pose, joints), e in zip(got, expected):
            self.assertEqual([f, r, pose.sequence], [int(x) for x in e[1:4]])
            numbers = np.array([float(x) for x in e[8:]])
            self.assertEqual(len(numbers), 25 + 25 + 21 * 7)
            worst = max(worst, float(np.abs(pose.angles - numbers[:25]).max()), float(np.abs(pose.raw_angles - numbers[25:50]).max()),
                        float(np.abs(joints.ravel() - numbers[50:]).max()))
        self.assertEqual(worst, 0.0)
        self.assertIs(estimator.calibration_progress().source, glovepose.CalibrationSource.ON_THE_FLY)
        self.assertEqual(glovepose.CalibrationSource.ON_THE_FLY, 1)  # the C header's GLOVEPOSE_CALIBRATION_ON_THE_FLY
        estimator.close()
        model.close()

    def test_xr_joints_are_the_joint_lists_in_the_wrist_frame(self):
        data = glovepose.load_dataset(self.dataset)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model, joint_transforms=True) as estimator:
            before = estimator.xr_joints(0.0)  # no pose yet: inactive, nothing valid
            self.assertFalse(before.active)
            self.assertEqual(int(before.location_flags.max()), 0)
            # The joints both lists have (the joint list's "pinky" is OpenXR's "little"; the palms differ).
            names = [n.replace("pinky", "little") for n in glovepose.JOINT_NAMES]
            shared = [n for n in names if n in glovepose.XR_JOINT_NAMES and n != "palm"]
            self.assertEqual(len(shared), 20)
            ours, xr = [names.index(n) for n in shared], [glovepose.XR_JOINT_NAMES.index(n) for n in shared]
            bones = [(j, p) for j, p in enumerate(glovepose.XR_JOINT_PARENTS) if p >= 0]
            self.assertEqual(len(bones), 25)  # a tree: every joint but the wrist has a parent
            rotations, lengths, worst = [], [], 0.0
            for _ in stream(data, estimator):
                pose, joints = estimator.pose(), estimator.joints()
                hand = estimator.xr_joints(pose.timestamp)
                self.assertEqual(hand.positions.shape, (26, 3))
                self.assertEqual(hand.orientations.shape, (26, 4))
                self.assertEqual((hand.radii.shape, hand.location_flags.shape, hand.linear_velocities.shape,
                                  hand.angular_velocities.shape, hand.velocity_flags.shape), ((26,), (26,), (26, 3), (26, 3), (26,)))
                self.assertTrue(hand.active)
                self.assertFalse(hand.predicted)
                self.assertEqual((hand.hand, hand.time, hand.horizon), ("right", pose.timestamp, 0.0))
                valid = glovepose.XR_POSITION_VALID | glovepose.XR_ORIENTATION_VALID
                self.assertTrue(all(int(f) & valid == valid for f in hand.location_flags))
                self.assertTrue(np.all((hand.radii > 0.003) & (hand.radii < 0.02)))
                wrist = glovepose.XR_JOINT_NAMES.index("wrist")
                np.testing.assert_array_equal(hand.positions[wrist], [0, 0, 0])
                np.testing.assert_allclose(hand.orientations[wrist], [0, 0, 0, 1], rtol=0, atol=1e-7)
                np.testing.assert_allclose(np.linalg.norm(hand.orientations, axis=1), 1.0, atol=1e-6)
                rotation, translation, residual = rigid_fit(joints[ours, :3], hand.positions[xr])
                worst = max(worst, residual)
                self.assertGreater(np.linalg.det(rotation), 0.0)  # a rotation, not a mirror
                rotations.append(np.concatenate([rotation.ravel(), translation]))
                lengths.append([np.linalg.norm(hand.positions[j] - hand.positions[p]) for j, p in bones])
            self.assertGreater(len(rotations), 100)
            self.assertLess(worst, 2e-6)  # metres: float32 positions of a hand 0.2 m long
            # One fixed frame change for every pose, and bones that keep their length.
            self.assertLess(float(np.ptp(rotations, axis=0).max()), 1e-5)
            self.assertLess(float(np.ptp(lengths, axis=0).max()), 1e-6)
            self.assertLess(hand.positions[glovepose.XR_JOINT_NAMES.index("middle_proximal"), 2], -0.05)  # fingers along -Z

    def test_latest_gives_readers_the_published_hand(self):
        data = glovepose.load_dataset(self.dataset)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model, joint_transforms=True, hand="left") as estimator, \
                glovepose.Latest() as latest:
            self.assertIsNone(latest.read())  # nothing published yet
            self.assertFalse(latest.xr_joints(estimator, 0.0).active)
            published, read, stop = {}, [], threading.Event()

            def reader():  # another thread, reading while the writer streams
                while not stop.is_set():
                    hand = latest.read()
                    if hand is not None:
                        read.append((hand.number, hand.pose.sequence, hand.pose.angles, hand.joints))

            thread = threading.Thread(target=reader)
            thread.start()
            try:
                for number, _ in enumerate(stream(data, estimator), start=1):
                    latest.publish(estimator)
                    pose, joints = estimator.pose(), estimator.joints()
                    published[number] = (pose.sequence, pose.angles, joints)
                    hand = latest.read()
                    self.assertEqual((hand.number, hand.pose.sequence, hand.pose.timestamp), (number, pose.sequence, pose.timestamp))
                    np.testing.assert_array_equal(hand.pose.angles, pose.angles)
                    np.testing.assert_array_equal(hand.joints, joints)
                    t = pose.timestamp + 0.01
                    mine, theirs = estimator.xr_joints(t), latest.xr_joints(estimator, t)
                    self.assertEqual((theirs.active, theirs.predicted, theirs.hand), (True, True, "left"))
                    for name in ("positions", "orientations", "radii", "location_flags", "linear_velocities", "angular_velocities"):
                        np.testing.assert_array_equal(getattr(theirs, name), getattr(mine, name), name)
            finally:
                stop.set()
                thread.join()
            self.assertGreater(len(published), 100)
            self.assertGreater(len(read), 10)
            numbers = [n for n, *_ in read]
            self.assertEqual(numbers, sorted(numbers))  # never older than what was read before
            for number, sequence, angles, joints in read:  # each read is one published hand, whole
                self.assertEqual(sequence, published[number][0])
                np.testing.assert_array_equal(angles, published[number][1])
                np.testing.assert_array_equal(joints, published[number][2])
            with self.assertRaises(ValueError):
                latest.xr_joints(estimator, float("nan"))

    def test_xr_aim_follows_the_poses(self):
        data = glovepose.load_dataset(self.dataset)
        # Strength of a distance d (mm), pinch.hpp's definition: 1 up to 15, 0 from 40, smoothstep between.
        u = (40.0 - 18.0) / 25.0
        at_release = u * u * (3.0 - 2.0 * u)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as right, glovepose.Estimator(model, hand="left") as left:
            before = right.xr_aim()
            self.assertFalse(before.active)
            self.assertEqual((before.status, before.pinching), (0, (False,) * 4))
            np.testing.assert_array_equal(before.pinch_strength, np.zeros(4))
            self.assertAlmostEqual(float(np.linalg.norm(before.aim_orientation)), 1.0, places=6)
            was, poses, pinching, onsets = (False,) * 4, 0, 0, 0  # onsets: off -> on
            for _ in stream(data, right, left):
                aim, mirror, pose = right.xr_aim(), left.xr_aim(), right.pose()
                poses += 1
                self.assertTrue(aim.active)
                self.assertIsNone(aim.sequence)
                self.assertEqual(aim.valid, pose.trusted)
                self.assertEqual(int(aim.status) & ~0x3E, 0)  # VALID and the four pinching bits only
                self.assertTrue(np.all((aim.pinch_strength >= 0.0) & (aim.pinch_strength <= 1.0)))
                for k in range(4):
                    if aim.pinching[k]:  # closer than 18 mm: strength above its value at 18 mm
                        self.assertGreater(aim.pinch_strength[k], at_release - 1e-6)
                        if not was[k]:  # an onset: closer than 15 mm, strength 1
                            self.assertEqual(aim.pinch_strength[k], 1.0)
                            onsets += 1
                    elif was[k]:  # a release: 18 mm or farther, strength at most its value at 18 mm
                        self.assertLess(aim.pinch_strength[k], at_release + 1e-6)
                pinching += any(aim.pinching)
                was = aim.pinching
                np.testing.assert_array_equal(aim.aim_position, before.aim_position)  # fixed in the wrist frame
                np.testing.assert_array_equal(aim.aim_orientation, before.aim_orientation)
                np.testing.assert_array_equal(mirror.aim_position, aim.aim_position * [-1, 1, 1])  # mirrored: x -> -x
            self.assertGreater(poses, 100)
            # This short session happens not to pinch (onsets stays 0): the checks above guard the
            # flags' relation to the strengths; tests/test_pinch.cpp follows pinches pose by pose.
            self.assertLess(before.aim_position[2], -0.04)  # the index knuckle, towards the fingers (-Z)

    def test_latest_gives_readers_the_published_aim(self):
        data = glovepose.load_dataset(self.dataset)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator, glovepose.Latest() as latest:
            nothing = latest.xr_aim()
            self.assertEqual((nothing.active, nothing.sequence, nothing.status), (False, 0, 0))
            count = 0
            for _ in stream(data, estimator):
                latest.publish(estimator)
                mine, theirs = estimator.xr_aim(), latest.xr_aim()
                self.assertEqual((theirs.active, theirs.sequence), (True, estimator.pose().sequence))
                self.assertEqual((theirs.status, theirs.pinching), (mine.status, mine.pinching))
                for name in ("pinch_strength", "aim_position", "aim_orientation"):
                    np.testing.assert_array_equal(getattr(theirs, name), getattr(mine, name), name)
                count += 1
            self.assertGreater(count, 100)

    def test_left_hand_mirrors_the_right_one(self):
        data = glovepose.load_dataset(self.dataset)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model, joint_transforms=True) as right, \
                glovepose.Estimator(model, hand="left", joint_transforms=True) as left:
            self.assertEqual((right.hand, left.hand), ("right", "left"))
            mirror_q = np.array([1.0, -1.0, -1.0, 1.0])  # S R S, S = diag(-1, 1, 1): the quaternion's y and z negate
            count = 0
            for _ in stream(data, right, left):
                count += 1
                np.testing.assert_array_equal(left.angles(), right.angles())  # the same model, the same readings
                r, l = right.joints(), left.joints()
                np.testing.assert_array_equal(l[:, 0], -r[:, 0])
                np.testing.assert_array_equal(l[:, 1:3], r[:, 1:3])
                same_rotation = np.abs((l[:, 3:] * r[:, 3:] * mirror_q).sum(axis=1))  # |<q_l, mirrored q_r>|: 1 when equal up to sign
                np.testing.assert_allclose(same_rotation, 1.0, atol=1e-6)
                t = right.pose().timestamp + 0.01
                rx, lx = right.xr_joints(t), left.xr_joints(t)
                self.assertEqual((rx.hand, lx.hand), ("right", "left"))
                np.testing.assert_array_equal(lx.positions, rx.positions * [-1, 1, 1])
                np.testing.assert_array_equal(lx.orientations, rx.orientations * mirror_q)
                np.testing.assert_array_equal(lx.linear_velocities, rx.linear_velocities * [-1, 1, 1])
                np.testing.assert_array_equal(lx.angular_velocities, rx.angular_velocities * [1, -1, -1])  # an axis: a pseudovector
                np.testing.assert_array_equal(lx.radii, rx.radii)
                thumb = glovepose.XR_JOINT_NAMES.index("thumb_tip")
                self.assertGreater(rx.positions[thumb, 0], 0.0)  # the thumb towards +X on a right hand
                self.assertLess(lx.positions[thumb, 0], 0.0)
            self.assertGreater(count, 100)
        with glovepose.PoseModel(MODEL) as model, self.assertRaises(ValueError):
            glovepose.Estimator(model, hand="both")

    def test_pose_at_interpolates_and_predicts_along_the_recent_slope(self):
        data = glovepose.load_dataset(self.dataset)
        window, bound = 0.09, 0.03  # 5.4 frames of 60 Hz: no pose on the window's edge
        low, high = joint_limits()
        with glovepose.PoseModel(MODEL) as model, \
                glovepose.Estimator(model, prediction_window=window, max_prediction=bound) as estimator:
            with self.assertRaises(glovepose.GloveposeError) as caught:
                estimator.pose_at(0.0)
            self.assertEqual(caught.exception.code, glovepose.NOT_READY)
            history, checked, unclamped = [], 0, 0
            for _ in stream(data, estimator):
                pose = estimator.pose()
                history.append((pose.timestamp, pose.angles))
                now = estimator.pose_at(pose.timestamp)
                np.testing.assert_array_equal(now.angles, pose.angles)
                self.assertEqual((now.predicted, now.clamped, now.horizon, now.time), (False, False, 0.0, pose.timestamp))
                (t0, a0), (t1, a1) = history[-2:] if len(history) > 1 else history * 2
                if t1 - history[0][0] <= window:
                    continue  # the trend also holds the first pose, taken before stream() yields
                between = estimator.pose_at(0.25 * t0 + 0.75 * t1)
                np.testing.assert_allclose(between.angles, 0.25 * a0 + 0.75 * a1, rtol=0, atol=1e-12)
                self.assertFalse(between.predicted)
                # The rate: the least-squares line through the poses of the last `window` seconds.
                times = np.array([t for t, _ in history if t1 - t <= window])
                values = np.array([a for t, a in history if t1 - t <= window])
                slope = np.polyfit(times - t1, values, 1)[0]
                self.assertTrue(now.has_rate)
                np.testing.assert_allclose(now.rate, slope, rtol=1e-6, atol=1e-6)
                ahead = estimator.pose_at(t1 + 0.02)
                self.assertTrue(ahead.predicted)
                self.assertFalse(ahead.clamped)
                self.assertAlmostEqual(ahead.horizon, 0.02, delta=1e-12)
                # Along the rate, held within the model's joint limits (its metadata, read here without the library).
                along = a1 + ahead.rate * ahead.horizon
                np.testing.assert_allclose(ahead.angles, np.clip(along, low, high), rtol=0, atol=1e-12)
                unclamped += bool(np.all((along > low) & (along < high)))
                far = estimator.pose_at(t1 + 100.0)
                self.assertTrue(far.clamped)
                self.assertEqual(far.horizon, bound)
                checked += 1
            self.assertGreater(checked, 100)
            self.assertGreater(unclamped, 20)
            for bad in (float("nan"), float("inf")):
                with self.assertRaises(glovepose.InputError) as caught:
                    estimator.pose_at(bad)
                self.assertEqual(caught.exception.code, glovepose.Status.NON_FINITE)
                self.assertIsInstance(caught.exception, ValueError)
                with self.assertRaises(ValueError):
                    estimator.xr_joints(bad)

    def test_xr_velocities_are_the_joints_rates_of_change(self):
        data = glovepose.load_dataset(self.dataset)
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator:
            checked, dt = 0, 1e-4
            low, high = joint_limits()
            for _ in stream(data, estimator):
                pose = estimator.pose()
                t = pose.timestamp + 0.02
                ahead = estimator.pose_at(t)
                if not all(np.all((a > low + 1e-3) & (a < high - 1e-3)) for a in (ahead.angles, pose.angles + ahead.rate * (0.02 + dt))):
                    continue  # held at a joint limit near t: not moving along the rate
                before, hand, after = estimator.xr_joints(t - dt), estimator.xr_joints(t), estimator.xr_joints(t + dt)
                self.assertTrue(all(int(f) == glovepose.XR_LINEAR_VELOCITY_VALID | glovepose.XR_ANGULAR_VELOCITY_VALID
                                    for f in hand.velocity_flags))
                linear = (after.positions - before.positions) / (2 * dt)
                turn = quaternion_product(after.orientations, before.orientations * [-1, -1, -1, 1])  # after * before^-1
                angular = turn[:, :3] * np.sign(turn[:, 3:]) / dt  # 2 sin(angle / 2) axis / (2 dt)
                # Up to 0.4 m/s and 11 rad/s here; float32 positions differenced over 0.2 ms leave ~1e-4.
                self.assertLess(float(np.abs(linear - hand.linear_velocities).max()), 5e-4)
                self.assertLess(float(np.abs(angular - hand.angular_velocities).max()), 5e-3)
                checked += 1
            self.assertGreater(checked, 20)


class GuidedCalibration(unittest.TestCase):
    @staticmethod
    def sequence() -> list:
        """The steps of the guided sequence in the shipped model file's metadata (read without the library)."""
        return json.loads(glovepose.load_dataset(MODEL)["metadata"]["pose_offset"])["sequence"]["steps"]

    def test_steps_are_the_model_files_sequence(self):
        expected = self.sequence()
        with glovepose.PoseModel(MODEL) as model:
            steps = model.calibration_steps
            self.assertEqual(len(steps), 10)
            self.assertEqual(len(steps), len(expected))
            self.assertEqual(len(steps), glovepose._lib.glovepose_model_calibration_step_count(model._handle))
            start = 0.0
            for k, (step, e) in enumerate(zip(steps, expected)):
                self.assertIsInstance(step, glovepose.CalibrationStep)
                self.assertEqual((step.index, step.step_count, step.name, step.instruction), (k, 10, e["name"], e["instruction"]))
                self.assertEqual(step.seconds, e["seconds"])
                self.assertAlmostEqual(step.start_seconds, start, delta=1e-12)
                start += e["seconds"]
                degrees = np.array([e["pose_degrees"][name] for name in glovepose.DOF_NAMES])
                self.assertEqual(step.pose.shape, (25,))
                np.testing.assert_allclose(step.pose, np.radians(degrees), rtol=0, atol=1e-7)  # float32 in the C struct
            self.assertEqual(steps[0].name, "flat_on_table")
            self.assertIn("flat_on_table", repr(steps[0]))

    def test_progress_follows_the_sequence_as_frames_arrive(self):
        expected = self.sequence()
        ends = np.cumsum([e["seconds"] for e in expected])
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator:
            self.assertTrue(model.has_range_map)
            self.assertTrue(model.has_pose_error)  # the shipped model measured its own errors: the confidence
            self.assertEqual(estimator.confidence().shape, (25,))
            self.assertTrue((estimator.confidence() == 0.0).all())  # no pose yet
            progress = estimator.calibration_progress()
            self.assertEqual((progress.collecting, progress.frames, progress.ready, progress.step, progress.sequence_seconds),
                             (False, 0, False, None, 0.0))
            self.assertIs(progress.source, glovepose.CalibrationSource.CONTINUOUS)  # the shipped model carries a range map
            estimator.clear_calibration()  # poses only once calibrated
            self.assertIs(estimator.calibration_progress().source, glovepose.CalibrationSource.NONE)
            estimator.start_calibration()
            progress = estimator.calibration_progress()
            self.assertTrue(progress.collecting)
            self.assertIsNone(progress.step)  # before the first frame
            cells, start, seen = 20.0 + np.arange(44.0), 100.0, []
            for k in range(int(ends[-1] * 60) + 60):  # the whole sequence at 60 Hz, and a second more
                t = start + k / 60.0
                cells[k % 44] += 0.5 if k % 2 else -0.5
                self.assertIs(estimator.push_cells(cells, t), glovepose.UNCALIBRATED)  # no range yet: no pose
                progress = estimator.calibration_progress()
                self.assertEqual(progress.frames, k + 1)  # one frame per 1/60 s (calibration_sample_period)
                self.assertEqual(progress.ready, progress.frames >= progress.frames_needed)
                self.assertAlmostEqual(progress.sequence_seconds, t - start, delta=1e-9)
                under_way = int(np.searchsorted(ends, t - start, side="right"))  # the step whose [start, end) holds the time
                if under_way < len(expected):
                    self.assertIs(progress.step, model.calibration_steps[under_way])
                    seen.append(under_way)
                else:
                    self.assertIsNone(progress.step)  # past the last step
            self.assertEqual(sorted(set(seen)), list(range(10)))
            self.assertGreater(progress.frames_needed, 1)
            estimator.finish_calibration()
            progress = estimator.calibration_progress()
            self.assertEqual((progress.collecting, progress.step), (False, None))
            self.assertIs(progress.source, glovepose.CalibrationSource.ON_THE_FLY)


class Ranges(unittest.TestCase):
    def test_training_range_is_the_model_files(self):
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator:
            self.assertNotIn("calibration_min", glovepose.load_dataset(MODEL)["metadata"])
            self.assertFalse(model.has_training_range)
            with self.assertRaises(glovepose.GloveposeError) as caught:
                estimator.use_training_calibration()
            self.assertEqual(caught.exception.code, -7)  # GLOVEPOSE_ERROR_CALIBRATION_STATE
        # The shipped model with a training range added to its metadata (weights_format.md: calibration_min/max).
        low, high = [10.0 + 0.25 * c for c in range(44)], [30.0 + 0.5 * c for c in range(44)]
        raw = MODEL.read_bytes()
        size = struct.unpack("<Q", raw[:8])[0]
        header = json.loads(raw[8:8 + size])
        header["__metadata__"].update(calibration_min=json.dumps(low), calibration_max=json.dumps(high))
        text = json.dumps(header).encode()
        text += b" " * (-len(text) % 8)
        with tempfile.TemporaryDirectory() as work:
            path = Path(work) / "trained.safetensors"
            path.write_bytes(struct.pack("<Q", len(text)) + text + raw[8 + size:])
            with glovepose.PoseModel(path) as model, glovepose.Estimator(model) as estimator:
                self.assertTrue(model.has_training_range)
                estimator.use_training_calibration()
                self.assertIs(estimator.calibration_progress().source, glovepose.CalibrationSource.TRAINING)
                got_low, got_high = estimator.calibration_range()
                self.assertEqual((got_low.tolist(), got_high.tolist()), (low, high))
                self.assertIs(estimator.push_cells(np.full(44, 20.0), 0.0), glovepose.SOLVED)
                pose = estimator.pose()
                self.assertEqual(pose.flags, glovepose.PoseFlag.TRAINING_CALIBRATION)
                self.assertTrue(pose.trusted)

    def test_a_range_set_is_the_range_used_saved_and_loaded(self):
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator, glovepose.Estimator(model) as other:
            self.assertEqual(np.shape(estimator.calibration_range()[0]), (44,))  # the continuous calibration's prior
            estimator.clear_calibration()
            other.clear_calibration()
            with self.assertRaises(glovepose.GloveposeError) as caught:
                estimator.calibration_range()  # none now
            self.assertEqual(caught.exception.code, glovepose.UNCALIBRATED)
            np.testing.assert_array_equal(estimator.cells(), np.zeros(44))  # no frame yet
            low, high = 15.0 + np.arange(44) / 7.0, 25.0 + np.arange(44) / 3.0
            estimator.set_calibration_range(low, high)
            self.assertIs(estimator.calibration_progress().source, glovepose.CalibrationSource.USER)
            got = estimator.calibration_range()
            np.testing.assert_array_equal(got[0], low)
            np.testing.assert_array_equal(got[1], high)
            with tempfile.TemporaryDirectory() as work:
                estimator.save_calibration(Path(work) / "range.txt")
                other.load_calibration(Path(work) / "range.txt")
            np.testing.assert_array_equal(other.calibration_range()[0], low)  # an exact round trip
            np.testing.assert_array_equal(other.calibration_range()[1], high)
            with self.assertRaises(glovepose.InputError) as caught:
                estimator.set_calibration_range(low[:40], high)
            self.assertIn("expected 44 values", str(caught.exception))
            bad = high.copy()
            bad[7] = low[7] - 1.0
            with self.assertRaises(glovepose.GloveposeError) as caught:
                estimator.set_calibration_range(low, bad)
            self.assertIn(model.cell_names[7], str(caught.exception))
            cells = 20.0 + np.sin(np.arange(44.0))
            self.assertIs(estimator.push_cells(cells, 1.0), glovepose.SOLVED)
            np.testing.assert_array_equal(estimator.cells(), cells)
            self.assertTrue(estimator.pose().trusted)
            self.assertEqual(estimator.pose().flags & glovepose.PoseFlag.TRAINING_CALIBRATION, 0)


class Abi(unittest.TestCase):
    HEADER = (ROOT / "capi" / "glovepose_c.h").read_text()
    STRUCTS = {"glovepose_estimator_config": _library.EstimatorConfig, "glovepose_hand_options": _library.HandOptions,
               "glovepose_pose": _library.Pose, "glovepose_joint": _library.Joint, "glovepose_predicted_pose": _library.PredictedPose,
               "glovepose_calibration_progress": _library.CalibrationProgress, "glovepose_calibration_step": _library.CalibrationStep,
               "glovepose_xr_joint_location": _library.XrJointLocation, "glovepose_xr_joint_velocity": _library.XrJointVelocity,
               "glovepose_xr_hand": _library.XrHand, "glovepose_xr_aim_state": _library.XrAimState}

    def define(self, name: str) -> int:
        found = re.search(rf"#define GLOVEPOSE_{name} \(?(-?(?:0x[0-9A-Fa-f]+|\d+))u?\)?\s", self.HEADER)
        self.assertIsNotNone(found, name)
        return int(found.group(1), 0)

    def test_row_time_is_the_readout_clock(self):
        # The last row of a cycle at its end; rows one slot of 1 / (rows * rate) apart; invalid input refused.
        self.assertEqual(glovepose.row_time(2.0, 179, 180, 60.0), 2.0)
        self.assertAlmostEqual(glovepose.row_time(2.0, 0, 180, 60.0), 2.0 - 179 / 10800, delta=1e-12)
        self.assertAlmostEqual(glovepose.row_time(2.0, 90, 180, 60.0) - glovepose.row_time(2.0, 89, 180, 60.0), 1 / 10800, delta=1e-12)
        for bad in [(2.0, 180, 180, 60.0), (2.0, -1, 180, 60.0), (2.0, 0, 0, 60.0), (2.0, 0, 180, 0.0)]:
            with self.assertRaisesRegex(ValueError, "expected 0 <= row < rows"):
                glovepose.row_time(*bad)

    def test_constants_are_the_headers(self):
        self.assertEqual((_library.DOF_COUNT, _library.JOINT_COUNT, _library.XR_JOINT_COUNT),
                         (self.define("DOF_COUNT"), self.define("JOINT_COUNT"), self.define("XR_JOINT_COUNT")))
        self.assertEqual((len(glovepose.DOF_NAMES), len(glovepose.JOINT_NAMES), len(glovepose.XR_JOINT_NAMES)), (25, 21, 26))
        self.assertEqual((_library.HAND_RIGHT, _library.HAND_LEFT), (self.define("HAND_RIGHT"), self.define("HAND_LEFT")))
        for name in ("ORIENTATION_VALID", "POSITION_VALID", "ORIENTATION_TRACKED", "POSITION_TRACKED", "LINEAR_VELOCITY_VALID",
                     "ANGULAR_VELOCITY_VALID"):
            self.assertEqual(getattr(glovepose, "XR_" + name), self.define("XR_" + name), name)
        for status in glovepose.Status:
            self.assertEqual(status, self.define(status.name), status.name)
        for source in glovepose.CalibrationSource:
            self.assertEqual(source, self.define("CALIBRATION_" + source.name), source.name)
        flags = re.findall(r"#define GLOVEPOSE_POSE_(\w+) ", self.HEADER)
        self.assertEqual(sorted(flags), sorted(glovepose.PoseFlag.__members__))  # every flag, no more
        for name, flag in glovepose.PoseFlag.__members__.items():
            self.assertEqual(flag, self.define("POSE_" + name), name)
        aim_flags = re.findall(r"#define GLOVEPOSE_XR_AIM_(\w+) ", self.HEADER)
        self.assertEqual(sorted(aim_flags), sorted(glovepose.XrAimFlag.__members__))  # every flag, no more
        for name, flag in glovepose.XrAimFlag.__members__.items():
            self.assertEqual(flag, self.define("XR_AIM_" + name), name)
        self.assertEqual(_library.XR_TYPE_HAND_TRACKING_AIM_STATE_FB, self.define("XR_TYPE_HAND_TRACKING_AIM_STATE_FB"))
        self.assertEqual(glovepose.JOINT_PARENTS[0], -1)
        self.assertEqual(glovepose.XR_JOINT_PARENTS[glovepose.XR_JOINT_NAMES.index("wrist")], -1)

    def test_every_function_of_the_header_is_declared_here(self):
        functions = set(re.findall(r"GLOVEPOSE_C_API[^;(]*?\b(glovepose_\w+)\(", self.HEADER))
        self.assertGreaterEqual(len(functions), 52)
        self.assertEqual(functions, set(_library._SIGNATURES))  # the package reaches the whole C ABI

    def test_structs_have_the_libraries_sizes(self):
        for layout, function in _library._INITS.items():
            self.assertEqual(ctypes.sizeof(layout), _library.library_size(glovepose._lib, layout), function)
        self.assertEqual(len(_library._INITS), 7)  # every struct with a struct_size

    def test_structs_have_the_documented_sizes_and_offsets(self):
        capi = ROOT / "capi"
        text = "\n".join((capi / name).read_text() for name in ("glovepose_c.h", "glovepose_c.cpp", "tests/test_capi.c"))
        sizes = re.findall(r"sizeof\((glovepose_\w+)\) (?:== |\()(\d+)", text)
        offsets = re.findall(r"offsetof\((glovepose_\w+), (\w+)\) == (\d+)", text)
        self.assertEqual({name for name, _ in sizes}, set(self.STRUCTS))  # every struct of the ABI is documented, and here
        self.assertGreaterEqual(len(offsets), 8)
        for name, size in sizes:
            self.assertEqual(ctypes.sizeof(self.STRUCTS[name]), int(size), name)
        for name, field, offset in offsets:
            self.assertEqual(getattr(self.STRUCTS[name], field).offset, int(offset), f"{name}.{field}")
        self.assertEqual(_library.XrHand.locations.offset + 26 * 40, _library.XrHand.velocities.offset)


class Errors(unittest.TestCase):
    def test_arrays_of_the_wrong_length_raise_naming_the_expected_length(self):
        with glovepose.PoseModel(MODEL) as model, glovepose.Estimator(model) as estimator:
            estimator.clear_calibration()  # no range: frames are refused or give no pose
            self.assertEqual((model.cell_count, model.row_count), (44, 180))
            calls = [(lambda a: estimator.push_cells(a, 0.0), model.cell_count),
                     (lambda a: estimator.push_measurements(a, 0.0), model.row_count)]
            for push, expected in calls:
                for wrong in (np.ones(3), np.ones(expected + 1), np.ones((1, expected)), [], 5.0):
                    with self.assertRaises(glovepose.InputError) as caught:
                        push(wrong)
                    self.assertIsInstance(caught.exception, ValueError)
                    self.assertIsInstance(caught.exception, glovepose.GloveposeError)
                    self.assertEqual(caught.exception.code, glovepose.Status.SIZE_MISMATCH)
                    self.assertIn(f"expected {expected} values", str(caught.exception))
                    self.assertIn(str(np.shape(wrong)), str(caught.exception))
            self.assertEqual(estimator.pose().rejected, 0)  # refused before the library saw them: nothing counted
            # Bad values in an array of the right length stay per-frame statuses (the real-time contract).
            cells = np.full(44, 20.0)
            cells[5] = np.nan
            self.assertIs(estimator.push_cells(cells, 0.0), glovepose.Status.NON_FINITE)
            self.assertIs(estimator.push_cells(np.full(44, 20.0), float("inf")), glovepose.Status.NON_FINITE)
            self.assertIs(estimator.push_cells(np.full(44, 20.0), 1.0), glovepose.UNCALIBRATED)
            self.assertIs(estimator.push_cells(np.full(44, 20.0), 0.5), glovepose.Status.TIMESTAMP_BACKWARDS)
            self.assertIs(estimator.push_row(180, 1.0, 2.0), glovepose.Status.UNKNOWN_INDEX)
            # Lists, tuples and float32 arrays of the right length are taken as they are.
            self.assertIs(estimator.push_cells([20.0] * 44, 3.0), glovepose.UNCALIBRATED)
            self.assertIn(estimator.push_measurements(np.full(180, 5.0, dtype=np.float32), 3.1), (glovepose.NOT_READY, glovepose.UNCALIBRATED))

    def test_malformed_model_raises_with_the_librarys_message(self):
        with tempfile.NamedTemporaryFile(suffix=".safetensors") as f:
            f.write(b"\x10\x00\x00\x00\x00\x00\x00\x00{not json at all")
            f.flush()
            with self.assertRaises(glovepose.GloveposeError) as caught:
                glovepose.PoseModel(f.name)
        message = str(caught.exception)
        self.assertIn(f.name, message)
        self.assertIn("header", message)
        self.assertEqual(caught.exception.code, -5)  # GLOVEPOSE_ERROR_INVALID_FILE
        with self.assertRaises(glovepose.GloveposeError) as caught:
            glovepose.PoseModel("/nonexistent/model.safetensors")
        self.assertEqual(caught.exception.code, -4)
        self.assertIn("/nonexistent/model.safetensors", str(caught.exception))

    def test_bad_settings_and_inputs(self):
        model = glovepose.PoseModel(MODEL)
        with self.assertRaises(TypeError):
            glovepose.Estimator(model, no_such_setting=1)
        with self.assertRaises(glovepose.GloveposeError) as caught:
            glovepose.Estimator(model, readout_mean_window=0)
        self.assertIn("mean", str(caught.exception))
        estimator = glovepose.Estimator(model)
        with self.assertRaises(glovepose.GloveposeError) as caught:
            estimator.angles()  # no pose yet: not zeros
        self.assertEqual(caught.exception.code, glovepose.NOT_READY)
        self.assertEqual((glovepose.Status.SIZE_MISMATCH, str(glovepose.Status.SIZE_MISMATCH)), (7, "size mismatch"))  # the C header's
        self.assertIs(estimator.push_row(0, float("nan"), 0.0), glovepose.Status.NON_FINITE)  # a per-frame status, not an exception
        self.assertEqual(glovepose.Status.NON_FINITE, 3)
        self.assertEqual(glovepose.Status.TIMESTAMP_BACKWARDS, 6)
        self.assertEqual(glovepose.Status.UNCALIBRATED, 8)
        with self.assertRaises(glovepose.GloveposeError):
            estimator.finish_calibration()  # none started
        with self.assertRaises(glovepose.GloveposeError) as caught:
            estimator.joints()  # joint_transforms is off
        self.assertEqual(caught.exception.code, -8)


if __name__ == "__main__":
    unittest.main()
