# %% [markdown]
# # A simulated volume from numpy, two techniques side by side
#
# A Jupyter-style script (cells marked `# %%`; run it as a script, in
# Jupyter through jupytext, or paste the cells into a notebook). It builds a
# smoke-like density field with numpy — a stand-in for a simulation's output
# — hands it to volux without writing a file, renders it with `shaded`
# (gradient Blinn–Phong, no shadows) and `single` (single scattering with
# shadows) under the same light, and puts the two images side by side.
#
#     PYTHONPATH=$PREFIX/lib/python3/dist-packages python3 examples/python/side_by_side.py out.png
#
# (or VOLUX_LIBRARY=build/libvolux.so PYTHONPATH=python for an uninstalled build)

# %%
import sys
import time

import numpy as np

import volux

print("volux", volux.version())

# %% [markdown]
# ## The "simulation": a turbulent plume
# Sum of random Gaussian blobs along a rising, twisting axis, modulated by
# smooth "turbulence" (a few sine octaves), on a 96³ grid. Indexed [z, y, x] like any C-order
# numpy array; volux takes the spacing in (x, y, z).

# %%
n = 96
rng = np.random.default_rng(7)
z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32) / (n - 1) * 2 - 1
density = np.zeros((n, n, n), np.float32)
for k in range(40):
    t = rng.uniform(-0.65, 0.55)                    # height along the plume (y)
    cx, cz = 0.3 * np.sin(3 * t), 0.3 * np.cos(2 * t)
    r = 0.12 + 0.1 * (t + 0.65)                     # widens as it rises
    density += rng.uniform(0.5, 1.0) * np.exp(-((x - cx) ** 2 + (y - t) ** 2 + (z - cz) ** 2) / (2 * r * r))
for f in (5, 11, 23):
    phase = rng.uniform(0, 2 * np.pi, 3)
    density *= 1 + (3.0 / f) * np.sin(f * x + phase[0]) * np.sin(f * y + phase[1]) * np.sin(f * z + phase[2])
density = np.clip(density / density.max(), 0, 1).astype(np.float32)
print("density: shape", density.shape, "mean %.3f" % density.mean())

# %% [markdown]
# ## Hand it to volux (borrowed: no copy) and describe the scene
# The scene is the same JSON a `volux render` scene file holds (DESIGN §3),
# as a dict; `volume=` replaces its "volume" key.

# %%
volume = volux.Volume.from_numpy(density, spacing=(1, 1, 1), copy=False)
scene = volux.Scene.from_json({
    "transfer_function": {
        "color": [[0.0, 0.9, 0.9, 1.0], [0.5, 1.0, 0.8, 0.6], [1.0, 1.0, 0.5, 0.3]],
        "opacity": [[0.0, 0.0], [0.2, 0.0], [1.0, 0.3]],
        "albedo": 0.9,
    },
    "lights": [{"type": "directional", "direction": [-1, -1, -0.5], "irradiance": 4.0}],
    "background": [0.02, 0.02, 0.03],
    "camera": {"orbit": {"azimuth": 30, "elevation": 15, "distance": 2.4}, "fov_y": 30},
    "render": {"width": 320, "height": 320, "spp": 1},
}, volume=volume)

# %% [markdown]
# ## Render with two techniques
# The scene keeps one instance per technique, so editing the scene and
# rendering again only recomputes what the edit invalidated.

# %%
images = {}
for technique, spp in (("shaded", 1), ("single", 2)):
    t0 = time.perf_counter()
    images[technique] = scene.render(technique=technique, spp=spp)
    print("%-7s %dx%d, %d spp: %.0f ms" % (technique, *images[technique].shape[1::-1], spp,
                                          1e3 * (time.perf_counter() - t0)))
print("difference:", {k: round(v, 4) for k, v in volux.compare(images["shaded"], images["single"]).items()})

# %% [markdown]
# ## Side by side
# In a notebook: `plt.imshow(np.clip(side ** (1 / 2.2), 0, 1))`. Here the
# combined image is written as PNG (tone mapped: sRGB, 8 bit).

# %%
gap = np.zeros((images["shaded"].shape[0], 8, 3), np.float32)
side = np.concatenate([images["shaded"], gap, images["single"]], axis=1)
out = sys.argv[1] if len(sys.argv) > 1 else "side_by_side.png"
volux.save_image(out, side, exposure=-0.5)
print("wrote", out, side.shape)
