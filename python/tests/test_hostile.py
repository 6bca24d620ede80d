"""Arguments a caller can get wrong (issue 34): a closed scene, counts that
ctypes would wrap, non-finite budgets, scene files that never end, images
with NaN. Each is refused with volux.Error (or TypeError for a wrong type)
before it reaches the library. Run as test_volux.py says."""
import math
import os
import tempfile
import threading
import unittest

import numpy as np

import volux

SCENE = {
    "volume": {"procedural": "sphere", "dims": [8, 8, 8]},
    "transfer_function": {"opacity": [[0, 0], [1, 0.5]]},
    "render": {"width": 8, "height": 8, "technique": "ea"},
}


class ClosedScene(unittest.TestCase):
    def test_a_closed_scene_raises_instead_of_crashing(self):
        s = volux.Scene.from_json(SCENE, threads=1)
        s.render()
        s.close()
        for call in (s.render, lambda: s.set("render.width", 4), lambda: s.settings, s.memory_bytes):
            with self.assertRaises(volux.Error) as cm:
                call()
            self.assertIn("closed", str(cm.exception))
        s.close()  # twice is fine


class Counts(unittest.TestCase):
    def setUp(self):
        self.scene = volux.Scene.from_json(SCENE, threads=1)

    def tearDown(self):
        self.scene.close()

    def test_spp_out_of_range_or_wrong_type(self):
        for bad in (-1, 0, 2 ** 24 + 1, 2 ** 40):
            with self.assertRaises(volux.Error) as cm:
                self.scene.render(spp=bad)
            self.assertIn("spp", str(cm.exception))
            self.assertIn("16777216", str(cm.exception))
        for bad in (1.5, "4", True):
            with self.assertRaises(TypeError):
                self.scene.render(spp=bad)
        self.assertEqual(self.scene.render(spp=np.int64(2)).shape, (8, 8, 3))

    def test_time_ms_must_be_finite(self):
        for bad in (math.nan, math.inf, -1.0):
            with self.assertRaises(volux.Error) as cm:
                self.scene.render(time_ms=bad)
            self.assertIn("time_ms", str(cm.exception))


class SceneFiles(unittest.TestCase):
    def test_a_device_is_not_read(self):
        with self.assertRaises(volux.Error) as cm:
            volux.Scene.from_json("/dev/zero")
        self.assertIn("not a regular file", str(cm.exception))

    def test_a_fifo_is_refused_at_once(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "scene.json")
            os.mkfifo(path)
            result = []
            t = threading.Thread(target=lambda: result.append(self._load_error(path)), daemon=True)
            t.start()
            t.join(20)
            self.assertFalse(t.is_alive(), "from_json blocked on a FIFO")
            self.assertIn("not a regular file", result[0])

    def test_a_huge_file_is_refused_before_reading(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "big.json")
            with open(path, "wb") as f:
                f.truncate((16 << 20) + 1)  # sparse: no 16 MiB written
            with self.assertRaises(volux.Error) as cm:
                volux.Scene.from_json(path)
            self.assertIn("16 MiB", str(cm.exception))

    @staticmethod
    def _load_error(path):
        try:
            volux.Scene.from_json(path)
        except volux.Error as e:
            return str(e)
        return ""


class NonFiniteImages(unittest.TestCase):
    def test_compare_refuses_nan(self):
        ref = np.ones((2, 2, 3), np.float32)
        img = ref.copy()
        img[1, 0, 2] = np.nan
        with self.assertRaises(volux.Error) as cm:
            volux.compare(img, ref)
        self.assertIn("non-finite", str(cm.exception))
        self.assertEqual(volux.compare(ref, ref)["max_abs"], 0.0)


if __name__ == "__main__":
    unittest.main()
