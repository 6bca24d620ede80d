"""Tests of the Python package (python/volux) against the built or installed
libvolux.so: physics through numpy (Beer–Lambert), edits == fresh renders,
errors with the library's messages, no leak over 1000 renders, progress,
cancellation and threads. Run: python3 -m unittest discover -s python/tests
(VOLUX_LIBRARY=<build>/libvolux.so for an uninstalled build)."""
import math
import os
import threading
import unittest

import numpy as np

import volux

N = 33          # odd: the centre node column lies on the image's centre pixel
SPACING = 0.5   # world units
SIGMA = 0.3     # extinction at value 1, 1/world unit


def sphere(n=N, radius=12.0):
    """A soft ball: value 1 inside, falling linearly to 0 over one voxel."""
    c = (n - 1) / 2
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32) - c
    return np.clip(radius - np.sqrt(x * x + y * y + z * z), 0.0, 1.0).astype(np.float32)


def absorber_scene(size=N):
    """Black absorber of σt = SIGMA·value against a white background, seen
    by an orthographic camera whose pixels are one voxel wide, so pixel
    (i, j) looks straight down the node column (i, j)."""
    return {
        "transfer_function": {"color": [[0, 0, 0, 0], [1, 0, 0, 0]], "extinction": [[0, 0], [1, SIGMA]]},
        "camera": {"type": "orthographic", "eye": [0, 0, 100], "look_at": [0, 0, 0], "up": [0, 1, 0],
                   "height": size * SPACING},
        "background": [1, 1, 1],
        "render": {"technique": "ea", "width": size, "height": size, "spp": 1},
    }


def lit_scene():
    return {
        "transfer_function": {"color": [[0, 1, 0.7, 0.4], [1, 0.4, 0.7, 1]], "opacity": [[0, 0], [1, 0.3]],
                              "albedo": 0.8},
        "lights": [{"type": "directional", "direction": [-1, -0.5, -1], "irradiance": 2.0}],
        "background": [0.05, 0.05, 0.05],
        "render": {"technique": "shaded", "width": 40, "height": 30, "spp": 1},
    }


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


class BeerLambert(unittest.TestCase):
    def test_numpy_sphere_transmittance(self):
        field = sphere()
        vol = volux.Volume.from_numpy(field, spacing=(SPACING,) * 3)
        self.assertEqual(vol.dims, (N, N, N))
        img = volux.Scene.from_json(absorber_scene(), volume=vol).render()
        self.assertEqual(img.shape, (N, N, 3))
        self.assertEqual(img.dtype, np.float32)
        # Along a node column the trilinear field is piecewise linear in z,
        # so the optical depth is exactly the trapezoid sum of the nodes.
        checked = 0
        for i, j in [(16, 16), (20, 16), (16, 10), (24, 22), (8, 9)]:
            col = field[:, N - 1 - j, i].astype(np.float64)   # image rows go down, +y up
            tau = SIGMA * SPACING * (col.sum() - 0.5 * (col[0] + col[-1]))
            expected = math.exp(-tau)
            # Optical depths agree to float/table precision (measured up to
            # 1.4e-4 relative, at the ball's rim).
            for ch in range(3):
                self.assertAlmostEqual(-math.log(img[j, i, ch]), tau, delta=3e-4 * max(1.0, tau),
                                       msg="pixel (%d,%d): %g vs exp(-%g) = %g" % (i, j, img[j, i, ch], tau,
                                                                                   expected))
            checked += tau > 1.0
        self.assertGreaterEqual(checked, 3)  # the ball is really in the way
        # A corner column holds only zeros: nothing is absorbed (up to the
        # same precision: 5e-5 measured along the box's edge).
        self.assertAlmostEqual(-math.log(img[0, 0, 0]), 0.0, delta=1e-4)

    def test_borrowed_equals_copied(self):
        field = sphere()
        a = volux.Volume.from_numpy(field, spacing=(SPACING,) * 3, copy=False)
        b = volux.Volume.from_numpy(field.astype(np.float64)[:, :, ::-1][:, :, ::-1], spacing=(SPACING,) * 3)
        del field  # the borrowed Volume keeps the array alive
        ia = volux.Scene.from_json(absorber_scene(), volume=a).render()
        ib = volux.Scene.from_json(absorber_scene(), volume=b).render()
        self.assertTrue(np.array_equal(ia, ib))

    def test_wide_integers_equal_float32(self):
        # int32 / uint64 data are kept as float32: the same image as the
        # float32 array of the same (integer) values
        field = np.rint(sphere() * 1000.0)
        ref = volux.Volume.from_numpy(field.astype(np.float32), spacing=(SPACING,) * 3)
        scene = absorber_scene()
        scene["transfer_function"] = {"color": [[0, 0, 0, 0], [1000, 0, 0, 0]],
                                      "extinction": [[0, 0], [1000, SIGMA]]}
        iref = volux.Scene.from_json(scene, volume=ref).render()
        for dtype in (np.int32, np.uint64):
            v = volux.Volume.from_numpy(field.astype(dtype), spacing=(SPACING,) * 3)
            self.assertTrue(np.array_equal(volux.Scene.from_json(scene, volume=v).render(), iref), dtype)


class Edits(unittest.TestCase):
    EDITS = [("camera.orbit.azimuth", 70), ("lights.0.irradiance", 3.5),
             ("transfer_function.color", [[0, 1, 0, 0], [1, 0, 0, 1]]), ("background", [0.3, 0.2, 0.1]),
             ("transfer_function.opacity", [[0, 0], [1, 0.6]]), ("render.technique", "single"),
             ("clip.planes", [{"origin": [0, 0, 0], "normal": [1, 0.2, 0]}]),
             ("clip.box", {"min": [-9, -9, -9], "max": [9, 9, 3]})]

    def test_edit_sequence_equals_fresh(self):
        vol = volux.Volume.from_numpy(sphere(24, 9.0))
        live = volux.Scene.from_json(lit_scene(), volume=vol)
        expected = lit_scene()
        live.render()
        previous = None
        for path, value in self.EDITS:
            live.set(path, value)
            node = expected
            keys = path.split(".")
            for k in keys[:-1]:
                node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
            if isinstance(node, list):
                node[int(keys[-1])] = value
            else:
                node[keys[-1]] = value
            got = live.render()
            fresh = volux.Scene.from_json(expected, volume=vol).render()
            self.assertTrue(np.array_equal(got, fresh), "after set(%r): incremental != fresh" % path)
            if previous is not None:
                self.assertFalse(np.array_equal(got, previous), "set(%r) changed nothing" % path)
            previous = got

    def test_edit_of_one_light_among_many(self):
        # 1000 point lights (the cap was 256): the edit of light 999 through
        # its dotted path renders like a fresh scene and changes the image
        scene = lit_scene()
        scene["lights"] = [{"type": "point", "position": [30 * math.cos(i), 20, 30 * math.sin(i)],
                            "intensity": 2.0} for i in range(1000)]
        vol = volux.Volume.from_numpy(sphere(16, 6.0))
        live = volux.Scene.from_json(scene, volume=vol)
        before = live.render()
        live.set("lights.999.intensity", 500.0)
        scene["lights"][999]["intensity"] = 500.0
        got = live.render()
        self.assertTrue(np.array_equal(got, volux.Scene.from_json(scene, volume=vol).render()))
        self.assertFalse(np.array_equal(got, before))

    def test_version_matches_package(self):
        here = os.path.dirname(os.path.abspath(__file__))
        with open(os.path.join(here, "..", "pyproject.toml")) as f:
            declared = [l.split('"')[1] for l in f if l.startswith("version = ")][0]
        self.assertEqual(volux.version(), declared)

    def test_settings_and_techniques(self):
        s = volux.Scene.from_json(lit_scene(), volume=volux.Volume.procedural("sphere", (16, 16, 16)))
        self.assertEqual(s.settings["technique"], "shaded")
        s.set("render.width", 20)
        self.assertEqual(s.render().shape, (30, 20, 3))
        table = volux.techniques()
        for name in ("ea", "shaded", "pathtrace", "single", "ambient", "lightvol"):
            self.assertIn(name, table)
        self.assertTrue(table["pathtrace"]["progressive"])
        for name, t in table.items():
            for p, info in t["params"].items():
                self.assertIn(info["kind"], ("number", "int", "bool", "string", "file"), (name, p))


class Errors(unittest.TestCase):
    def test_bad_inputs_raise_with_message(self):
        vol = volux.Volume.from_numpy(sphere(16, 6.0))
        bad = lit_scene()
        bad["transfer_function"]["opacity"] = [[1, 0.1], [0, 0.2]]
        with self.assertRaises(volux.Error) as e:
            volux.Scene.from_json(bad, volume=vol)
        self.assertIn("transfer_function.opacity", str(e.exception))
        self.assertEqual(e.exception.status, "invalid")

        s = volux.Scene.from_json(lit_scene(), volume=vol)
        before = s.render()
        with self.assertRaises(volux.Error) as e:
            s.set("lights.0.cone_angle", 270)
        self.assertIn("lights", str(e.exception))
        with self.assertRaises(volux.Error) as e:
            s.set("render.spp", 0)
        self.assertIn("render.spp", str(e.exception))
        with self.assertRaises(volux.Error) as e:
            s.set("volume.dims", [8, 8, 8])
        self.assertIn("volume=", str(e.exception))
        self.assertTrue(np.array_equal(s.render(), before))  # failed sets changed nothing
        with self.assertRaises(volux.Error) as e:
            s.render(technique="nope")
        self.assertIn("nope", str(e.exception))

        with self.assertRaises(volux.Error) as e:
            volux.Volume.from_numpy(np.zeros((4, 4, 4), np.int16), copy=False)
        self.assertEqual(e.exception.status, "unsupported")
        self.assertIn("cannot borrow int16", str(e.exception))
        with self.assertRaises(volux.Error):
            volux.Volume.from_numpy(np.zeros((4, 4), np.float32))
        with self.assertRaises(volux.Error) as e:
            volux.Volume.load("/nonexistent/engine.nhdr")
        self.assertIn("/nonexistent/engine.nhdr", str(e.exception))
        with self.assertRaises(volux.Error) as e:
            volux.Scene.from_json("/nonexistent/scene.json")
        self.assertEqual(e.exception.status, "io")
        with self.assertRaises(volux.Error):
            volux.compare(np.zeros((4, 4, 3)), np.zeros((4, 5, 3)))
        self.assertEqual(volux.compare(before, before)["max_abs"], 0.0)

    def test_load_options_reach_the_reader(self):
        import tempfile
        data = np.arange(27, dtype=np.float32).reshape(3, 3, 3)
        data[1, 2, 0] = np.nan
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "nan.nrrd")
            with open(path, "wb") as f:
                f.write(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 3 3 3\nendian: little\nencoding: raw\n\n")
                f.write(data.astype("<f4").tobytes())
            with self.assertRaises(volux.Error) as e:
                volux.Volume.load(path)
            self.assertEqual(e.exception.status, "format")
            self.assertIn("nan.nrrd", str(e.exception))
            lo, hi = volux.Volume.load(path, allow_nonfinite=True).range
            self.assertEqual((lo, hi), (0.0, 26.0))  # the NaN became the lowest value

    def test_numpy_nonfinite_refused_like_files(self):
        data = np.arange(27, dtype=np.float32).reshape(3, 3, 3)
        data[1, 2, 0] = np.nan
        data[2, 0, 1] = np.inf
        for copy in (True, False):
            with self.assertRaises(volux.Error) as e:
                volux.Volume.from_numpy(data, copy=copy)
            self.assertIn("2 non-finite values", str(e.exception))
            self.assertIn("voxel (0, 2, 1)", str(e.exception))  # (x, y, z) of [1, 2, 0]
        import warnings
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            lo, hi = volux.Volume.from_numpy(data, allow_nonfinite=True).range
        self.assertEqual((lo, hi), (0.0, 26.0))
        self.assertTrue(any("non-finite" in str(x.message) for x in w))

    def test_messages_read_well(self):
        vol = volux.Volume.from_numpy(sphere(16, 6.0))
        bad = lit_scene()
        bad["render"]["spp"] = 0
        with self.assertRaises(volux.Error) as e:
            volux.Scene.from_json(bad, volume=vol)
        msg = str(e.exception)
        self.assertNotIn("<dict>", msg)
        self.assertTrue(msg.startswith("scene dict: render.spp: 0 is outside [1, 16777216]"), msg)
        bad = lit_scene()
        bad["render"]["widht"] = 8
        with self.assertRaises(volux.Error) as e:
            volux.Scene.from_json(bad, volume=vol)
        self.assertIn("did you mean 'width'?", str(e.exception))


PYDICOM_FILES = "/usr/lib/python3/dist-packages/pydicom/data/test_files"


@unittest.skipUnless(os.path.isdir(PYDICOM_FILES), "python3-pydicom's test files are not installed")
class RealDicom(unittest.TestCase):
    """Real files from Debian's python3-pydicom, read by GDCM through volux
    and by pydicom (an independent reader): the same HU, exactly."""

    def expected(self, name):
        try:
            import pydicom
        except ImportError:
            self.skipTest("pydicom is not importable")
        d = pydicom.dcmread(os.path.join(PYDICOM_FILES, name))
        a = d.pixel_array.astype(np.float64) * float(d.get("RescaleSlope", 1)) + float(d.get("RescaleIntercept", 0))
        return d, a

    @staticmethod
    def voxels(v):
        """Every voxel of slice 0 through volux_volume_value_at, [y, x]."""
        import ctypes
        f = volux._lib.volux_volume_value_at
        f.restype, f.argtypes = ctypes.c_float, [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int]
        nx, ny, _ = v.dims
        return np.array([[f(v._handle, i, j, 0) for i in range(nx)] for j in range(ny)], np.float64)

    def load(self, name):
        try:
            return volux.Volume.load(os.path.join(PYDICOM_FILES, name))
        except volux.Error as e:
            if "without DICOM support" in str(e):
                self.skipTest("volux was built without GDCM")
            raise

    def test_ct_small_in_hounsfield_units(self):
        d, want = self.expected("CT_small.dcm")
        v = self.load("CT_small.dcm")
        self.assertEqual(v.dims, (128, 128, 1))
        self.assertAlmostEqual(v.spacing[0], float(d.PixelSpacing[1]), places=6)
        self.assertAlmostEqual(v.spacing[1], float(d.PixelSpacing[0]), places=6)
        self.assertTrue(np.array_equal(self.voxels(v), want))

    def test_compressed_mr_equals_uncompressed(self):
        _, want = self.expected("MR_small.dcm")
        for name in ("MR_small.dcm", "MR_small_RLE.dcm", "MR_small_jpeg_ls_lossless.dcm",
                     "MR_small_jp2klossless.dcm", "MR_small_bigendian.dcm", "MR_small_implicit.dcm"):
            v = self.load(name)
            self.assertEqual(v.dims, (64, 64, 1), name)
            self.assertTrue(np.array_equal(self.voxels(v), want), name)

    def test_truncated_file_is_refused_with_its_name(self):
        with self.assertRaises(volux.Error) as e:
            self.load("MR_truncated.dcm")
        self.assertIn("MR_truncated.dcm", str(e.exception))


class Resources(unittest.TestCase):
    def test_no_leak_across_1000_renders(self):
        vol = volux.Volume.from_numpy(sphere(16, 6.0))
        scene = dict(lit_scene(), render={"technique": "shaded", "width": 16, "height": 16, "spp": 1})
        s = volux.Scene.from_json(scene, volume=vol)
        for k in range(100):  # warm up allocators and caches
            s.render()
        rss0, held0 = rss_bytes(), s.memory_bytes()
        for k in range(1000):
            if k % 50 == 0:
                s.set("camera.orbit.azimuth", k % 360)
            s.render()
        grown = rss_bytes() - rss0
        self.assertLess(grown, 2 << 20, "RSS grew by %d bytes over 1000 renders" % grown)
        self.assertEqual(s.memory_bytes(), held0)

    def test_progress_and_cancel(self):
        s = volux.Scene.from_json(lit_scene(), volume=volux.Volume.from_numpy(sphere(16, 6.0)))
        seen = []
        s.render(technique="pathtrace", spp=4, progress=lambda task, f: seen.append(f))
        self.assertTrue(seen and seen[-1] == 1.0 and seen == sorted(seen), seen)
        with self.assertRaises(volux.Cancelled):
            s.render(technique="pathtrace", spp=4, progress=lambda task, f: True)

        def boom(task, f):
            raise KeyError("from the callback")
        with self.assertRaises(KeyError):
            s.render(technique="pathtrace", spp=4, progress=boom)

        # cancel() from another thread stops a long render.
        started = threading.Event()
        timer = threading.Thread(target=lambda: (started.wait(10), s.cancel()))
        timer.start()
        with self.assertRaises(volux.Cancelled):
            s.render(technique="pathtrace", spp=1 << 20, progress=lambda task, f: started.set())
        timer.join()
        self.assertEqual(s.render(technique="pathtrace", spp=1).shape, (30, 40, 3))  # usable afterwards

    def test_two_threads_equal_serial(self):
        vol = volux.Volume.from_numpy(sphere(20, 8.0))
        jobs = [("pathtrace", 70), ("shaded", 200)]

        def run(job, out, k):
            s = volux.Scene.from_json(lit_scene(), volume=vol, threads=2)
            s.set("camera.orbit.azimuth", job[1])
            out[k] = s.render(technique=job[0], spp=2)

        serial = [None, None]
        for k, job in enumerate(jobs):
            run(job, serial, k)
        parallel = [None, None]
        threads = [threading.Thread(target=run, args=(job, parallel, k)) for k, job in enumerate(jobs)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for k in range(2):
            self.assertTrue(np.array_equal(serial[k], parallel[k]))
        self.assertFalse(np.array_equal(serial[0], serial[1]))


if __name__ == "__main__":
    unittest.main()
