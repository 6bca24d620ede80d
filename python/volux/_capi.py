"""ctypes declarations of the volux C API (include/volux/*.h) used by the package.

Only the functions and structs the Python layer needs are declared; their
layouts mirror the C headers of the same library version (checked at load:
volux_version() must equal the version this file was written for, up to the
patch number, the ABI promise of docs/API.md).
"""
import ctypes
import ctypes.util
import os

ABI_VERSION = (0, 2)  # MAJOR, MINOR of the headers mirrored below

c_int, c_uint32, c_uint64, c_int64 = ctypes.c_int, ctypes.c_uint32, ctypes.c_uint64, ctypes.c_int64
c_double, c_float, c_char_p, c_void_p, c_size_t = (ctypes.c_double, ctypes.c_float, ctypes.c_char_p,
                                                   ctypes.c_void_p, ctypes.c_size_t)
P = ctypes.POINTER

PROGRESS_FN = ctypes.CFUNCTYPE(c_int, c_void_p, c_char_p, c_double)
ALLOC_FN = ctypes.CFUNCTYPE(c_void_p, c_void_p, c_void_p, c_size_t, c_size_t)
RELEASE_FN = ctypes.CFUNCTYPE(None, c_void_p)


class ContextDesc(ctypes.Structure):
    _fields_ = [("threads", c_int), ("max_bytes", c_uint64), ("alloc", ALLOC_FN), ("alloc_user", c_void_p),
                ("progress", PROGRESS_FN), ("progress_user", c_void_p), ("cache_dir", c_char_p),
                ("message", c_void_p), ("message_user", c_void_p)]  # no message callback: NULL


class VolumeMemoryDesc(ctypes.Structure):
    _fields_ = [("dims", c_int * 3), ("type", c_int), ("spacing", c_double * 3), ("origin", c_double * 3),
                ("use_origin", c_int), ("data", c_void_p), ("strides", c_int64 * 3), ("mode", c_int),
                ("release", RELEASE_FN), ("release_user", c_void_p)]


class LoadOptions(ctypes.Structure):  # volux_volume_load_options (raw and region: not exposed, NULL)
    _fields_ = [("raw", c_void_p), ("use_file_origin", c_int), ("allow_outside_dir", c_int), ("data_root", c_char_p),
                ("allow_nonfinite", c_int), ("region", c_void_p)]


class RenderSettings(ctypes.Structure):
    _fields_ = [("width", c_int), ("height", c_int), ("spp", c_int), ("step", c_float), ("seed", c_uint64),
                ("max_depth", c_int), ("exposure", c_float), ("threads", c_int), ("time_ms", c_double),
                ("target_error", c_double), ("technique", ctypes.c_char * 32)]


class RenderLimits(ctypes.Structure):
    _fields_ = [("spp", c_uint32), ("time_ms", c_double), ("target_error", c_double)]


class RenderReport(ctypes.Structure):
    _fields_ = [("spp", c_uint32), ("ms", c_double), ("cpu_ms", c_double), ("rel_error", c_double),
                ("samples", c_uint64), ("vertices", c_uint64), ("truncated", c_int)]


class Image(ctypes.Structure):
    _fields_ = [("width", c_int), ("height", c_int), ("rgb", P(c_float))]


class ImageError(ctypes.Structure):
    _fields_ = [("rmse", c_double), ("rel_mse", c_double), ("psnr", c_double), ("max_abs", c_double)]


class ParamInfo(ctypes.Structure):
    _fields_ = [("name", c_char_p), ("kind", c_int), ("default", c_double), ("min", c_double), ("max", c_double),
                ("def_string", c_char_p), ("doc", c_char_p)]


class TechniqueInfo(ctypes.Structure):
    _fields_ = [("name", c_char_p), ("summary", c_char_p), ("params", P(ParamInfo)), ("progressive", c_int)]


# name: (restype, argtypes)
_SIGNATURES = {
    "volux_version": (c_char_p, []),
    "volux_status_name": (c_char_p, [c_int]),
    "volux_context_create": (c_int, [P(ContextDesc), P(c_void_p)]),
    "volux_context_destroy": (None, [c_void_p]),
    "volux_context_error": (c_char_p, [c_void_p]),
    "volux_context_clear_error": (None, [c_void_p]),
    "volux_context_set_progress": (None, [c_void_p, PROGRESS_FN, c_void_p]),
    "volux_context_bytes_in_use": (c_uint64, [c_void_p]),
    "volux_volume_from_memory": (c_int, [c_void_p, P(VolumeMemoryDesc), P(c_void_p)]),
    "volux_volume_load": (c_int, [c_void_p, c_char_p, P(LoadOptions), P(c_void_p)]),
    "volux_volume_procedural": (c_int, [c_void_p, c_char_p, P(c_int * 3), c_uint64, P(c_void_p)]),
    "volux_volume_release": (None, [c_void_p]),
    "volux_volume_dims": (None, [c_void_p, P(c_int * 3)]),
    "volux_volume_spacing": (None, [c_void_p, P(c_double * 3)]),
    "volux_volume_range": (None, [c_void_p, P(c_double), P(c_double)]),
    "volux_scene_load_string": (c_int, [c_void_p, c_char_p, c_char_p, c_char_p, P(c_char_p), c_int, P(c_void_p)]),
    "volux_scene_load_string_with_volume": (c_int, [c_void_p, c_char_p, c_char_p, c_char_p, P(c_char_p), c_int,
                                                    c_void_p, P(c_void_p)]),
    "volux_scene_assign": (c_int, [c_void_p, c_void_p, c_int]),
    "volux_scene_destroy": (None, [c_void_p]),
    "volux_scene_volume": (c_void_p, [c_void_p]),
    "volux_scene_render": (P(RenderSettings), [c_void_p]),
    "volux_technique_count": (c_int, []),
    "volux_technique_info_at": (P(TechniqueInfo), [c_int]),
    "volux_technique_validate_params": (c_int, [c_void_p, c_void_p]),
    "volux_technique_create": (c_int, [c_void_p, c_char_p, c_void_p, P(c_void_p)]),
    "volux_technique_destroy": (None, [c_void_p]),
    "volux_framebuffer_create": (c_int, [c_void_p, c_int, c_int, P(c_void_p)]),
    "volux_framebuffer_destroy": (None, [c_void_p]),
    "volux_framebuffer_resolve": (c_int, [c_void_p, P(Image)]),
    "volux_render": (c_int, [c_void_p, c_void_p, c_void_p, P(RenderLimits), P(RenderReport)]),
    "volux_image_free": (None, [c_void_p, P(Image)]),
    "volux_image_compare": (c_int, [c_void_p, P(Image), P(Image), P(ImageError)]),
    "volux_image_save": (c_int, [c_void_p, c_char_p, P(Image), c_float]),
}


def _candidates():
    env = os.environ.get("VOLUX_LIBRARY")
    if env:
        return [env]
    found = []
    try:  # written by `make install` / `cmake --install` next to this file
        from . import _install
        found.append(os.path.join(_install.LIBDIR, "libvolux.so.%d.%d" % ABI_VERSION))
    except ImportError:
        pass
    found.append("libvolux.so.%d.%d" % ABI_VERSION)  # the dynamic loader's search path
    name = ctypes.util.find_library("volux")
    if name:
        found.append(name)
    return found


def load():
    """Loads libvolux.so: $VOLUX_LIBRARY, else the installed one, else the loader's path."""
    errors = []
    for path in _candidates():
        try:
            lib = ctypes.CDLL(path)
            break
        except OSError as e:
            errors.append(str(e))
    else:
        raise OSError("volux: cannot load libvolux.so (set VOLUX_LIBRARY to its path): " + "; ".join(errors))
    for name, (res, args) in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    version = lib.volux_version().decode()
    if tuple(int(x) for x in version.split(".")[:2]) != ABI_VERSION:
        raise OSError("volux: the package mirrors the %d.%d API but libvolux is %s" % (ABI_VERSION + (version,)))
    return lib
