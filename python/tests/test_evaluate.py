"""glovepose.evaluate (the library's train::evaluate through libglovepose_eval's glovepose_evaluate) against
`glovepose eval --json` on the same model and dataset files: the same report, key for key, every
string and count equal, every other number within a relative 1e-4 and every share of angles within
one angle's step (the C library is built for baseline x86-64, the tool for this machine's instruction
set, both with the networks of the instruction set this CPU runs best: sums of floats in another
order, which can move one angle of thousands across a histogram bin's edge), with
the default options and with eval's selection, calibration, row replay, contact and weight-storage
options (the report naming the storage); another glove's description refused by both, naming both
gloves; bad options and files raise GloveposeError with the library's message. The tool's
old spellings (train --model ARCH, --calibration MODE, --dtype) do what the new ones do and say so.
The package finds libglovepose_eval beside libglovepose_c and reaches all of glovepose_eval.h;
libglovepose_c itself has no glovepose_evaluate (the engines' library holds no evaluation).

Environment (CTest sets it): GLOVEPOSE_LIBRARY, GLOVEPOSE_CLI.
"""
import ctypes
import json
import os
import re
import struct
import subprocess
import tempfile
import unittest
from pathlib import Path

import glovepose
from glovepose import _library

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "glovepose_fcn512.safetensors"


def cli_eval(*args: str) -> dict:
    done = subprocess.run([os.environ["GLOVEPOSE_CLI"], "eval", *args, "--json"], check=True, capture_output=True, text=True)
    return json.loads(done.stdout)


def differences(a, b, path: str = "", share_step: float = 0.0) -> list:
    """Where two reports differ: keys, types, strings and whole numbers exactly; shares (a fraction
    of the report's frames x 25 angles) beyond one angle; other numbers beyond a relative 1e-4."""
    if isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            return [f"{path}: keys {list(a)} != {list(b)}"]
        if isinstance(a.get("frames"), int) and a["frames"] > 0:
            share_step = 1.0 / (a["frames"] * 25)
        return [d for k in a for d in differences(a[k], b[k], f"{path}/{k}", share_step)]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} != {len(b)} items"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]", share_step)]
    if isinstance(a, float) or isinstance(b, float):
        numbers = isinstance(a, (int, float)) and isinstance(b, (int, float))
        if numbers and "/share" in path and share_step > 0.0:
            ok = abs(a - b) <= share_step * 1.000001
        else:
            ok = numbers and abs(a - b) <= 1e-4 * max(abs(a), abs(b), 1e-9)
    else:
        ok = type(a) is type(b) and a == b
    return [] if ok else [f"{path}: {a!r} != {b!r}"]


class Evaluate(unittest.TestCase):
    def assertSameReport(self, a: dict, b: dict):
        self.assertEqual(differences(a, b), [])

    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.TemporaryDirectory()
        cls.data = Path(cls.work.name) / "corpus.safetensors"
        subprocess.run([os.environ["GLOVEPOSE_CLI"], "simulate", "--seed", "43", "--subjects", "2", "--sessions", "1", "--gloves", "1",
                        "--minutes", "0.1", "--calibration-seconds", "3", "--raw-rows", "--threads", "1", "--out", str(cls.data)],
                       check=True, stdout=subprocess.DEVNULL)

    @classmethod
    def tearDownClass(cls):
        cls.work.cleanup()

    def test_the_defaults_give_the_tools_report(self):
        report = glovepose.evaluate(MODEL, self.data, threads=1)
        self.assertSameReport(report, cli_eval("--model", str(MODEL), "--data", str(self.data), "--threads", "1"))
        self.assertEqual(report["format"], "glovepose-angle-errors")
        self.assertGreater(report["frames"], 100)
        self.assertEqual(report["calibration"], "onthefly")
        self.assertIsNotNone(report["vs_truth"])  # simulated data: the truth behind the labels too

    def test_the_options_are_evals(self):
        report = glovepose.evaluate(MODEL, self.data, subjects=[1], sessions=[0], calibration_mode="onthefly", replay_rows=True, mean_window=3,
                                    contact=True, threads=1)
        self.assertSameReport(report, cli_eval("--model", str(MODEL), "--data", str(self.data), "--subjects", "1", "--sessions", "0",
                                               "--calibration-mode", "onthefly", "--replay-rows", "--mean-window", "3", "--contact",
                                               "--threads", "1"))
        self.assertEqual(report["mean_window"], 3)
        self.assertIsNotNone(report["contact"])
        whole = glovepose.evaluate(MODEL, self.data, threads=1)
        self.assertLess(report["frames"], whole["frames"] * 0.6)  # one of two people
        excluded = glovepose.evaluate(MODEL, self.data, exclude_subjects=[0], threads=1)
        self.assertEqual(excluded, glovepose.evaluate(MODEL, self.data, subjects=[1], threads=1))  # the same library: equal

    def test_weights_and_glove_are_evals(self):
        cli = ["--model", str(MODEL), "--data", str(self.data), "--subjects", "1", "--threads", "1"]
        f32 = glovepose.evaluate(MODEL, self.data, subjects=[1], threads=1)
        self.assertEqual(f32["weights"], "f32")
        for weights in ("f16", "bf16", "fixed16"):
            with self.subTest(weights=weights):
                report = glovepose.evaluate(MODEL, self.data, subjects=[1], weights=weights, threads=1)
                tool = cli_eval(*cli, "--weights", weights)
                if weights == "fixed16":  # acc - 1.5 * sum(x) cancels: the instruction sets' float orders differ by ~1e-4 deg
                    self.assertEqual((report["weights"], report["frames"]), (tool["weights"], tool["frames"]))
                    self.assertLess(abs(report["mean_deg"] - tool["mean_deg"]), 1e-3)
                else:
                    self.assertSameReport(report, tool)
                self.assertEqual(report["weights"], weights)
                self.assertNotEqual(report["mean_deg"], f32["mean_deg"])  # the storage is in use
                self.assertLess(abs(report["mean_deg"] - f32["mean_deg"]), 0.2)  # rounding only (BF16 the most)
        # Another glove's description (the fixture's): refused as eval --glove refuses it, naming both.
        other = Path(self.work.name) / "other_glove.json"
        other.write_text(glovepose.load_dataset(ROOT / "tests" / "fixtures" / "unet_w4_e2.safetensors")["metadata"]["glove_description"])
        both = r"'fixture-e2', \d+ cells\) is not the one the model .*'glauser2019-44', 44 cells"
        refused = subprocess.run([os.environ["GLOVEPOSE_CLI"], "eval", *cli, "--glove", str(other)], capture_output=True, text=True)
        self.assertEqual(refused.returncode, 1)
        self.assertRegex(refused.stderr, both)
        with self.assertRaisesRegex(glovepose.GloveposeError, both):
            glovepose.evaluate(MODEL, self.data, glove=other)
        with self.assertRaisesRegex(ValueError, "weights 'f64', expected one of"):
            glovepose.evaluate(MODEL, self.data, weights="f64")
        report = ctypes.c_char_p()  # the C library's own check, below the package's
        lib = glovepose._eval_library()
        self.assertEqual(lib.glovepose_evaluate(str(MODEL).encode(), str(self.data).encode(), b'{"weights": "F16"}', ctypes.byref(report)),
                         -1)  # GLOVEPOSE_ERROR_INVALID_ARGUMENT
        self.assertIsNone(report.value)
        self.assertIn('"weights" is "F16", expected "f32", "f16", "bf16" or "fixed16"', lib.glovepose_eval_last_error().decode())

    def test_the_evaluation_library_is_found_beside_the_c_library(self):
        if os.environ.get("GLOVEPOSE_EVAL_LIBRARY"):
            self.skipTest("GLOVEPOSE_EVAL_LIBRARY names the library")
        here = Path(glovepose._lib._name).parent
        self.assertEqual(Path(glovepose._eval_library()._name), here / "libglovepose_eval.so")
        with self.assertRaises(AttributeError):  # evaluation is not the engines' library's
            glovepose._lib.glovepose_evaluate
        header = (ROOT / "capi" / "glovepose_eval.h").read_text()
        functions = set(re.findall(r"GLOVEPOSE_EVAL_API[^;(]*?\b(glovepose_\w+)\(", header))
        self.assertEqual(functions, set(_library._EVAL_SIGNATURES))  # the package reaches the whole header
        self.assertEqual(len(functions), 2)

    def test_bad_options_and_files_raise_with_the_librarys_message(self):
        with self.assertRaisesRegex(glovepose.GloveposeError, "calibration 'sideways', expected none, training, onthefly, guided or continuous"):
            glovepose.evaluate(MODEL, self.data, calibration_mode="sideways")
        with self.assertRaisesRegex(glovepose.GloveposeError, "mean_window.*needs.*replay_rows"):
            glovepose.evaluate(MODEL, self.data, mean_window=3)
        with self.assertRaisesRegex(glovepose.GloveposeError, "stride.*expected a whole number >= 1"):
            glovepose.evaluate(MODEL, self.data, stride=0)
        with self.assertRaisesRegex(glovepose.GloveposeError, "file not found"):
            glovepose.evaluate(MODEL, Path(self.work.name) / "missing.safetensors")
        with self.assertRaisesRegex(glovepose.GloveposeError, "records no guided calibration"):
            glovepose.evaluate(MODEL, self.data, calibration_mode="guided")

    def test_the_old_spellings_do_what_the_new_ones_do(self):
        cli = os.environ["GLOVEPOSE_CLI"]
        models = {}
        for name, spelling in {"new": ["--architecture", "linear", "--calibration-mode", "onthefly", "--weights", "f16"],
                               "old": ["--model", "linear", "--calibration", "onthefly", "--dtype", "f16"]}.items():
            models[name] = Path(self.work.name) / f"linear_{name}.safetensors"
            done = subprocess.run([cli, "train", "--data", str(self.data), *spelling, "--exclude-subjects", "1", "--threads", "1", "--out",
                                   str(models[name])], check=True, capture_output=True, text=True)
            said = [line for line in done.stderr.splitlines() if "is now" in line]
            self.assertEqual(said, [] if name == "new" else ["train: --model is now --architecture (the old spelling still works)",
                                                              "train: --calibration is now --calibration-mode (the old spelling still works)"])
            with open(models[name], "rb") as f:
                header = json.loads(f.read(struct.unpack("<Q", f.read(8))[0]))
            self.assertEqual({t["dtype"] for k, t in header.items() if k != "__metadata__"}, {"F16"})
            self.assertEqual(header["__metadata__"]["architecture"], "linear")
        self.assertEqual(glovepose.evaluate(models["old"], self.data, subjects=[1], threads=1),
                         glovepose.evaluate(models["new"], self.data, subjects=[1], threads=1))
        self.assertSameReport(glovepose.evaluate(models["new"], self.data, subjects=[1], calibration_mode="none", threads=1),
                              cli_eval("--model", str(models["new"]), "--data", str(self.data), "--subjects", "1", "--calibration", "none",
                                       "--threads", "1"))


if __name__ == "__main__":
    unittest.main()
