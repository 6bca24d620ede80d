"""volux from Python: numpy volumes in, numpy images out.

A thin layer over the installed C library (libvolux.so, through ctypes; no
compiled extension). Everything the C API reports as an error is raised as
volux.Error carrying the library's message.

    import numpy as np, volux
    z, y, x = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
    vol = volux.Volume.from_numpy((x*x + y*y + z*z < 0.8).astype(np.float32), spacing=(1, 1, 1))
    scene = volux.Scene.from_json({"transfer_function": {"opacity": [[0, 0], [1, 0.5]]},
                                   "render": {"width": 128, "height": 128}}, volume=vol)
    img = scene.render(technique="shaded", spp=1)      # float32, H x W x 3, linear
    scene.set("camera.orbit.azimuth", 60)              # an edit: the next render updates incrementally
    img2 = scene.render(technique="shaded")
    print(volux.compare(img, img2))                    # {'rmse': ..., 'rel_mse': ..., 'psnr': ..., 'max_abs': ...}

Threading: each Scene (and Volume) owns its own volux context, so
different scenes may render in different threads at the same time (the
GIL is released during rendering) and give the same images as serially.
One Scene is used by one thread at a time; its methods take the scene's
lock, so concurrent calls on one Scene wait for each other. cancel() may
be called from any thread.
"""
import ctypes
import itertools
import json
import math
import os
import stat
import threading
import warnings

import numpy as np

from . import _capi

_lib = _capi.load()
__version__ = _lib.volux_version().decode()

__all__ = ["Error", "Cancelled", "Volume", "Scene", "compare", "techniques", "save_image", "version"]


class Error(Exception):
    """A volux failure. `status` is the library's status name ("invalid",
    "io", "format", "unsupported", "limit", "nomem", "write", "cancelled",
    "internal"); str(e) is the library's message."""

    def __init__(self, message, status="invalid"):
        super().__init__(message)
        self.status = status


class Cancelled(Error):
    """The render was cancelled (Scene.cancel() or the progress callback)."""


def version():
    """The version of the loaded libvolux ("0.2.0")."""
    return __version__


class _Context:
    """One volux_context: allocator, threads, first error, progress callback."""

    def __init__(self, threads=0):
        desc = _capi.ContextDesc(threads=int(threads))
        handle = ctypes.c_void_p()
        status = _lib.volux_context_create(ctypes.byref(desc), ctypes.byref(handle))
        if status:
            raise Error("volux: cannot create a context: %s" % _lib.volux_status_name(status).decode(),
                        _lib.volux_status_name(status).decode())
        self.handle = handle

    def check(self, status):
        if status == 0:
            return
        message = _lib.volux_context_error(self.handle).decode("utf-8", "replace")
        name = _lib.volux_status_name(status).decode()
        _lib.volux_context_clear_error(self.handle)  # the next call reports its own error
        raise (Cancelled if name == "cancelled" else Error)(message or name, name)

    def close(self):
        # Only the owner calls this, after destroying everything made from
        # the context (no __del__ here: the garbage collector finalises a
        # cycle in any order, and a context must outlive its objects).
        if getattr(self, "handle", None) and _lib is not None:
            _lib.volux_context_destroy(self.handle)
        self.handle = None


# Volumes are shared: a scene of another context retains the ones it uses,
# and the last release may come from any scene in any order, so they all
# come from one context that lives as long as the process. Its error
# message is read under the lock.
_volume_ctx = None
_volume_lock = threading.Lock()


# Arrays lent to volux (copy=False), by key, until the library calls
# _release_borrowed for the volume's last reference (which a scene may hold
# after the Python Volume object is gone).
_borrowed = {}
_borrowed_keys = itertools.count(1)


@_capi.RELEASE_FN
def _release_borrowed(key):
    _borrowed.pop(key, None)


def _new_volume(create):
    global _volume_ctx
    with _volume_lock:
        if _volume_ctx is None:
            _volume_ctx = _Context()
        handle = ctypes.c_void_p()
        _volume_ctx.check(create(_volume_ctx.handle, ctypes.byref(handle)))
    return Volume(handle)


_TYPES = {np.dtype(np.uint8): 0, np.dtype(np.int8): 1, np.dtype(np.uint16): 2, np.dtype(np.int16): 3,
          np.dtype(np.float32): 4, np.dtype(np.float64): 5, np.dtype(np.int32): 6, np.dtype(np.uint32): 7,
          np.dtype(np.int64): 8, np.dtype(np.uint64): 9}


class Volume:
    """An immutable scalar grid (volux_volume). Build one with from_numpy(),
    load() or procedural(); pass it to Scene.from_json(..., volume=)."""

    def __init__(self, _handle):
        self._handle = _handle

    @classmethod
    def from_numpy(cls, array, spacing=(1.0, 1.0, 1.0), origin=None, copy=True, allow_nonfinite=False):
        """A volume from a 3-D array indexed [z, y, x] (C order: x fastest).

        dtype: uint8, int8, uint16, int16, float32, float64 or a 32/64-bit
        integer (values are file units; the transfer function maps them;
        float64 and the wide integers are kept as float32, exact for
        integers up to 2^24). spacing and origin are
        (x, y, z) in world units; origin None centres the volume at 0.
        copy=True copies (any strides); copy=False lends the array to volux
        without a copy (uint8/uint16/float32, C-contiguous): the Volume keeps
        a reference, and the array must not be written while any scene uses
        the volume. NaN/Inf values are refused as in files (Error naming
        their count and first voxel) unless allow_nonfinite=True, which maps
        them to the lowest finite value with a warning (in a copy).
        """
        a = np.asarray(array)
        if a.ndim != 3:
            raise Error("Volume.from_numpy: expected a 3-D array [z, y, x], got shape %s" % (a.shape,))
        if a.dtype.byteorder not in ("=", "|") and copy:
            a = a.astype(a.dtype.newbyteorder("="))
        if a.dtype not in _TYPES:
            raise Error("Volume.from_numpy: dtype %s is not one of uint8, int8, uint16, int16, float32, float64, "
                        "int32, uint32, int64, uint64" % a.dtype, "unsupported")
        if a.dtype.kind == "f":
            finite = np.isfinite(a)
            if not finite.all():
                bad = int(a.size - np.count_nonzero(finite))
                z, y, x = (int(i) for i in np.argwhere(~finite)[0])
                if not allow_nonfinite:
                    raise Error("Volume.from_numpy: %d non-finite values (NaN/Inf), the first at voxel (%d, %d, %d) "
                                "(x, y, z); allow_nonfinite=True maps them to the lowest value" % (bad, x, y, z))
                lowest = a[finite].min() if finite.any() else 0
                warnings.warn("Volume.from_numpy: %d non-finite values (NaN/Inf) mapped to the lowest value %g"
                              % (bad, lowest))
                a = np.where(finite, a, lowest).astype(a.dtype)
        if any(s == 0 and n > 1 for s, n in zip(a.strides, a.shape)):
            if not copy:
                raise Error("Volume.from_numpy: cannot borrow a broadcast array (zero strides); copy it",
                            "unsupported")
            a = np.ascontiguousarray(a)
        desc = _capi.VolumeMemoryDesc()
        desc.dims[:] = [a.shape[2], a.shape[1], a.shape[0]]
        desc.type = _TYPES[a.dtype]
        desc.spacing[:] = [float(s) for s in spacing]
        if origin is not None:
            desc.origin[:] = [float(o) for o in origin]
            desc.use_origin = 1
        desc.data = a.ctypes.data
        desc.strides[:] = [a.strides[2], a.strides[1], a.strides[0]]
        desc.mode = 0 if copy else 1
        key = None
        if not copy:
            key = next(_borrowed_keys)
            _borrowed[key] = a
            desc.release, desc.release_user = _release_borrowed, key
        try:
            return _new_volume(lambda ctx, out: _lib.volux_volume_from_memory(ctx, ctypes.byref(desc), out))
        except Error:
            _borrowed.pop(key, None)  # a failed create never calls release
            raise

    @classmethod
    def load(cls, path, *, use_file_origin=False, allow_outside_dir=False, data_root=None, allow_nonfinite=False):
        """Reads a volume file (.nrrd .nhdr .mhd .mha .nii .nii.gz .hdr .vti), or
        DICOM: a folder (its largest series) or one file of a series (that
        series), in HU when the files rescale (needs a build with GDCM).

        use_file_origin: place it at the header's origin (else centred);
        allow_outside_dir: a detached header's data file may lie outside the
        header's folder; data_root: detached data must also lie in this
        folder; allow_nonfinite: NaN/Inf values become the lowest value with
        a warning (else the load fails naming the count and first voxel)."""
        opt = _capi.LoadOptions(None, int(bool(use_file_origin)), int(bool(allow_outside_dir)),
                                os.fsencode(data_root) if data_root is not None else None,
                                int(bool(allow_nonfinite)), None)
        return _new_volume(lambda ctx, out: _lib.volux_volume_load(ctx, os.fsencode(path), ctypes.byref(opt), out))

    @classmethod
    def procedural(cls, name, dims, seed=1):
        """A procedural volume: "sphere", "marschner_lobb", "cloud", "phantom", "constant"."""
        d = (ctypes.c_int * 3)(*[int(n) for n in dims])
        return _new_volume(lambda ctx, out: _lib.volux_volume_procedural(ctx, name.encode(), ctypes.byref(d),
                                                                         int(seed), out))

    @property
    def dims(self):
        """(nx, ny, nz)."""
        d = (ctypes.c_int * 3)()
        _lib.volux_volume_dims(self._handle, ctypes.byref(d))
        return tuple(d)

    @property
    def spacing(self):
        s = (ctypes.c_double * 3)()
        _lib.volux_volume_spacing(self._handle, ctypes.byref(s))
        return tuple(s)

    @property
    def range(self):
        """(min, max) value in file units."""
        lo, hi = ctypes.c_double(), ctypes.c_double()
        _lib.volux_volume_range(self._handle, ctypes.byref(lo), ctypes.byref(hi))
        return lo.value, hi.value

    def __del__(self):
        if getattr(self, "_handle", None) and _lib is not None:
            _lib.volux_volume_release(self._handle)  # a scene may still hold its own reference
        self._handle = None


# The library's cap on a scene file (io/json_reader.c), applied before
# reading so that '/dev/zero' or a FIFO cannot hold the interpreter.
_SCENE_FILE_MAX_BYTES = 16 << 20
# render.spp's range (core/scene.c) and what the limits struct can hold.
_SPP_MAX = 1 << 24


def _read_scene_file(path):
    """The text of a scene file: a regular file of at most 16 MiB, opened
    without blocking (a FIFO is refused, not waited on)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise Error("%s: cannot read the scene file: %s" % (path, e.strerror), "io") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise Error("%s: cannot read the scene file: not a regular file" % path, "io")
        if st.st_size > _SCENE_FILE_MAX_BYTES:
            raise Error("%s: the scene file is larger than 16 MiB" % path, "limit")
        os.set_blocking(fd, True)
        with os.fdopen(fd, "rb") as f:
            fd = -1
            data = f.read(_SCENE_FILE_MAX_BYTES + 1)
    except OSError as e:
        raise Error("%s: cannot read the scene file: %s" % (path, e.strerror), "io") from None
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > _SCENE_FILE_MAX_BYTES:
        raise Error("%s: the scene file is larger than 16 MiB" % path, "limit")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise Error("%s: not UTF-8 text (byte %d)" % (path, e.start), "format") from None


def _check_count(what, value, lo, hi):
    """An int (not a bool, not a float) in [lo, hi], checked before any
    ctypes conversion (which would wrap -1 to 2^32 - 1 or truncate 2^40)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError("%s: expected an integer, got %r" % (what, value))
    if not lo <= int(value) <= hi:
        raise Error("%s: must be in [%d, %d], got %d" % (what, lo, hi, int(value)), "invalid")
    return int(value)


def _check_ms(what, value):
    """A finite number of milliseconds ≥ 0 (0 = no limit)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError("%s: expected a number, got %r" % (what, value))
    v = float(value)
    if not math.isfinite(v) or v < 0.0:
        raise Error("%s: must be a finite number ≥ 0, got %r" % (what, value), "invalid")
    return v


def _jsonable(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError("%r is not JSON serialisable" % (o,))


class Scene:
    """A scene (DESIGN §3 JSON) with cached technique instances, so renders
    after set() edits do only the work the edit invalidates."""

    @classmethod
    def from_json(cls, obj, volume=None, threads=0):
        """obj: a dict, a JSON string or a path to a scene file. volume: a
        Volume used instead of the scene's "volume" key (which may then be
        absent). threads: worker threads (0 = all cores)."""
        if isinstance(obj, dict):
            text, base, name = json.dumps(obj, default=_jsonable), ".", "scene dict"
        elif isinstance(obj, (str, bytes, os.PathLike)):
            s = os.fsdecode(obj)
            if s.lstrip().startswith("{"):
                text, base, name = s, ".", "scene string"
            else:
                text = _read_scene_file(s)
                base, name = os.path.dirname(os.path.abspath(s)), s
        else:
            raise TypeError("Scene.from_json: expected a dict, a JSON string or a path, got %s" % type(obj).__name__)
        if volume is not None and not isinstance(volume, Volume):
            raise TypeError("Scene.from_json: volume= must be a volux.Volume")
        self = cls.__new__(cls)
        self._ctx = None
        self._lock = threading.RLock()
        self._cancel = threading.Event()
        self._techniques = {}
        self._handle = None
        self._ctx = _Context(threads)
        self._volume = None
        self._text, self._base, self._name, self._sets, self._volume = text, base, name, [], volume
        self._handle = self._load(self._sets, None)
        self.last_report = None
        return self

    def _load(self, sets, keep_volume_of):
        """A new C scene from the JSON text and `sets`; the volume is the
        supplied one, else `keep_volume_of`'s, else read from the JSON."""
        arr = (ctypes.c_char_p * max(len(sets), 1))(*[s.encode() for s in sets])
        out = ctypes.c_void_p()
        vol = self._volume._handle if self._volume is not None else keep_volume_of
        args = (self._ctx.handle, self._text.encode(), os.fsencode(self._base), self._name.encode(), arr, len(sets))
        if vol:
            self._ctx.check(_lib.volux_scene_load_string_with_volume(*args, vol, ctypes.byref(out)))
        else:
            self._ctx.check(_lib.volux_scene_load_string(*args, ctypes.byref(out)))
        status = _lib.volux_technique_validate_params(self._ctx.handle, out)
        if status:
            _lib.volux_scene_destroy(out)
            self._ctx.check(status)
        return out

    def set(self, path, value):
        """Sets one value by its --set path (DESIGN §4), e.g.
        set("lights.0.irradiance", 2.5), set("transfer_function.opacity",
        [[0, 0], [1, 0.4]]), set("render.technique", "pathtrace"). The
        scene is re-read with every set so far and only what changed is
        updated (a camera edit does not rebuild lighting caches). A bad path
        or value raises Error and leaves the scene unchanged."""
        item = "%s=%s" % (path, json.dumps(value, default=_jsonable))
        touches_volume = path == "volume" or path.startswith("volume.")
        with self._lock:
            self._check_open("set")
            if touches_volume and self._volume is not None:
                raise Error("%s: %s: this scene's volume was given as volume=; make a new Volume instead"
                            % (self._name, path))
            sets = self._sets + [item]
            tmp = self._load(sets, None if touches_volume else _lib.volux_scene_volume(self._handle))
            try:
                self._ctx.check(_lib.volux_scene_assign(self._handle, tmp, 0 if touches_volume else 1))
            finally:
                _lib.volux_scene_destroy(tmp)
            self._sets = sets

    @property
    def settings(self):
        """The render settings as a dict (width, height, spp, technique, ...)."""
        self._check_open("settings")
        r = _lib.volux_scene_render(self._handle).contents
        return {"width": r.width, "height": r.height, "spp": r.spp, "step": r.step, "seed": r.seed,
                "max_depth": r.max_depth, "exposure": r.exposure, "threads": r.threads,
                "time_ms": r.time_ms, "target_error": r.target_error, "technique": r.technique.decode()}

    def render(self, technique=None, spp=None, progress=None, time_ms=None):
        """Renders and returns the mean radiance as float32 [height, width, 3]
        (linear). technique/spp default to the scene's render settings.
        progress(task, fraction) is called as the render advances (from a
        worker thread, never concurrently); a true return value cancels.
        Raises Cancelled when cancelled, Error on failure."""
        if spp is not None:
            spp = _check_count("render: spp", spp, 1, _SPP_MAX)
        if time_ms is not None:
            time_ms = _check_ms("render: time_ms", time_ms)
        with self._lock:
            self._check_open("render")
            r = _lib.volux_scene_render(self._handle).contents
            name = technique or r.technique.decode()
            t = self._techniques.get(name)
            if t is None:
                t = ctypes.c_void_p()
                self._ctx.check(_lib.volux_technique_create(self._ctx.handle, name.encode(), self._handle,
                                                            ctypes.byref(t)))
                self._techniques[name] = t
            limits = _capi.RenderLimits(spp=int(spp if spp is not None else r.spp),
                                        time_ms=float(time_ms if time_ms is not None else r.time_ms),
                                        target_error=r.target_error)
            failure = []

            def on_progress(user, task, fraction):
                if self._cancel.is_set():
                    return 1
                if progress is None:
                    return 0
                try:
                    return 1 if progress(task.decode(), fraction) else 0
                except BaseException as e:  # re-raised below, after the render stops
                    failure.append(e)
                    return 1

            callback = _capi.PROGRESS_FN(on_progress)
            fb = ctypes.c_void_p()
            report = _capi.RenderReport()
            image = _capi.Image()
            self._ctx.check(_lib.volux_framebuffer_create(self._ctx.handle, r.width, r.height, ctypes.byref(fb)))
            _lib.volux_context_set_progress(self._ctx.handle, callback, None)
            try:
                status = _lib.volux_render(t, self._handle, fb, ctypes.byref(limits), ctypes.byref(report))
                self._cancel.clear()
                if failure:
                    _lib.volux_context_clear_error(self._ctx.handle)
                    raise failure[0]
                self._ctx.check(status)
                self._ctx.check(_lib.volux_framebuffer_resolve(fb, ctypes.byref(image)))
                out = np.ctypeslib.as_array(image.rgb, shape=(image.height, image.width, 3)).copy()
            finally:
                _lib.volux_context_set_progress(self._ctx.handle, ctypes.cast(None, _capi.PROGRESS_FN), None)
                _lib.volux_image_free(self._ctx.handle, ctypes.byref(image))
                _lib.volux_framebuffer_destroy(fb)
            self.last_report = {"spp": report.spp, "ms": report.ms, "cpu_ms": report.cpu_ms,
                                "rel_error": report.rel_error}
            return out

    def _check_open(self, what):
        """A closed scene never reaches the library (its handles are freed)."""
        if not getattr(self, "_handle", None):
            raise Error("%s: the scene is closed" % what, "invalid")

    def cancel(self):
        """Stops the render running in another thread (it raises Cancelled);
        if none runs, the next render is cancelled."""
        self._cancel.set()

    def memory_bytes(self):
        """Bytes the scene's context holds (scene, caches of its techniques)."""
        self._check_open("memory_bytes")
        return int(_lib.volux_context_bytes_in_use(self._ctx.handle))

    def close(self):
        """Frees the scene and its technique caches (also done on deletion)."""
        lock = getattr(self, "_lock", None)
        if lock is None or _lib is None:
            return
        with lock:
            for t in self._techniques.values():
                _lib.volux_technique_destroy(t)
            self._techniques = {}
            if self._handle:
                _lib.volux_scene_destroy(self._handle)
            self._handle = None
            if self._ctx:
                self._ctx.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


def _as_image(a, what):
    a = np.ascontiguousarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise Error("%s: expected an image of shape (height, width, 3), got %s" % (what, a.shape))
    img = _capi.Image(a.shape[1], a.shape[0], a.ctypes.data_as(ctypes.POINTER(ctypes.c_float)))
    return a, img


def compare(a, b):
    """Error metrics of image a against the reference b (DESIGN §4, `volux
    compare`): dict with rmse, rel_mse, psnr, max_abs."""
    a, ia = _as_image(a, "compare: a")
    b, ib = _as_image(b, "compare: b")
    ctx = _Context(1)
    err = _capi.ImageError()
    try:
        ctx.check(_lib.volux_image_compare(ctx.handle, ctypes.byref(ia), ctypes.byref(ib), ctypes.byref(err)))
    finally:
        ctx.close()
    return {"rmse": err.rmse, "rel_mse": err.rel_mse, "psnr": err.psnr, "max_abs": err.max_abs}


def save_image(path, image, exposure=0.0):
    """Writes an [H, W, 3] linear image: .png (tone mapped: 2^exposure, sRGB,
    8 bit), .pfm or .exr (linear float). Atomic: a failure leaves no file."""
    a, img = _as_image(image, "save_image")
    ctx = _Context(1)
    try:
        ctx.check(_lib.volux_image_save(ctx.handle, os.fsencode(path), ctypes.byref(img), float(exposure)))
    finally:
        ctx.close()


_KINDS = {0: "number", 1: "int", 2: "bool", 3: "string", 4: "file"}


def techniques():
    """The registered techniques and their parameter tables:
    {name: {"summary": str, "progressive": bool, "params": {param: {"kind",
    "default", "min", "max", "doc"}}}} (what `volux techniques` lists)."""
    out = {}
    for i in range(_lib.volux_technique_count()):
        info = _lib.volux_technique_info_at(i).contents
        params = {}
        k = 0
        while info.params and info.params[k].name:
            p = info.params[k]
            kind = _KINDS.get(p.kind, "number")
            entry = {"kind": kind, "doc": (p.doc or b"").decode()}
            if kind in ("string", "file"):
                entry["default"] = (p.def_string or b"").decode()
            else:
                conv = bool if kind == "bool" else int if kind == "int" else float
                entry.update(default=conv(p.default), min=p.min, max=p.max)
            params[p.name.decode()] = entry
            k += 1
        out[info.name.decode()] = {"summary": (info.summary or b"").decode(), "progressive": bool(info.progressive),
                                   "params": params}
    return out
