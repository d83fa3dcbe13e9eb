"""The glovepose Python package against the C++ API and the tool, with unittest.

- The same rows give the same poses: a simulated session (raw readout rows) streamed through
  glovepose.Estimator with the protocol of capi/tests/cpp_reference.cpp (paper readout, 1-euro
  smoothing 60/1/0.5/1, joints on, calibration frames between start and finish) equals, exactly,
  the poses capi_cpp_reference prints from glovepose::GlovePoseEstimator (%.17g, a double's exact
  round trip): angles, raw angles, joints, sequences.
- A malformed model raises GloveposeError carrying the library's message.
- load_dataset gives the values `glovepose simulate --csv` writes for the same data.

Environment (CTest sets it): GLOVEPOSE_LIBRARY, GLOVEPOSE_CPP_REFERENCE, GLOVEPOSE_CLI.
"""
import os
import subprocess
import tempfile
import unittest
from pathlib import Path

import numpy as np

import glovepose

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "glovepose_fcn512.safetensors"


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
                if estimator.push_row(r, rows[f][r], stamps[f] - (179 - r) / (180 * 60.0)) == glovepose.SOLVED:
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
        self.assertEqual(estimator.calibration_progress()["source"], 1)  # calibrated on the fly
        estimator.close()
        model.close()


class Errors(unittest.TestCase):
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
        status = estimator.push_cells(np.ones(3), 0.0)  # a status, not an exception; the C header's numbers
        self.assertIs(status, glovepose.Status.SIZE_MISMATCH)
        self.assertEqual((status, str(status)), (7, "size mismatch"))
        self.assertEqual(estimator.push_measurements(np.ones(100), 0.0), glovepose.Status.SIZE_MISMATCH)
        self.assertIs(estimator.push_row(0, float("nan"), 0.0), glovepose.Status.NON_FINITE)
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
