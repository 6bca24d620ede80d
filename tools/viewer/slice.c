/*
 * tools/viewer/slice.c — axis-aligned slices of the raw volume for the
 * page's 2-D views (GET /api/slice): one pixel per voxel, coloured by the
 * scene's transfer-function colour map or as window/level grey.
 *
 * Orientation (voxel axes i, j, k = x, y, z of the volume): an axial (z)
 * slice shows i to the right and j upwards, a coronal (y) slice i to the
 * right and k upwards, a sagittal (x) slice j to the right and k upwards.
 * For a volume stored in RAS+ order (NIfTI's patient axes) that is the
 * axial view from above (the patient's right on the right: the
 * "neurological" convention), the coronal view from behind and the
 * sagittal view from the patient's right with anterior to the right.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "viewer.h"

int viewer_slice_image(viewer *v, const viewer_slice_request *rq, volux_context *ctx, volux_image *out, char *err,
                       size_t errn) {
    viewer_lock_read(v);
    const volux_scene *s = volux_scene_doc_scene(v->doc);
    const volux_volume *vol = volux_scene_volume(s);
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    int dims[3];
    volux_volume_dims(vol, dims);
    /* the image's axes: u to the right, w upwards, the slice along `axis` */
    const int axis = rq->axis, u = axis == 0 ? 1 : 0, w = axis == 2 ? 1 : 2;
    int index = rq->index < 0 ? dims[axis] / 2 : rq->index;
    int code = 200;
    if (index >= dims[axis]) {
        snprintf(err, errn, "index: %d is outside [0, %d] for axis %c", rq->index, dims[axis] - 1, "xyz"[axis]);
        code = 400;
    } else if ((double)dims[u] * dims[w] > VIEWER_SLICE_MAX_PIXELS) {
        snprintf(err, errn, "the slice (%dx%d voxels) is larger than the viewer sends (%d pixels)", dims[u], dims[w],
                 VIEWER_SLICE_MAX_PIXELS);
        code = 413;
    } else if (volux_image_create(ctx, dims[u], dims[w], out)) {
        snprintf(err, errn, "out of memory");
        code = 500;
    }
    if (code != 200) {
        viewer_unlock(v, 0);
        return code;
    }
    double lo, hi;
    volux_volume_range(vol, &lo, &hi);
    double window = rq->window > 0 ? rq->window : hi - lo, level = rq->has_level ? rq->level : 0.5 * (lo + hi);
    if (!(window > 0)) window = 1;
    for (int y = 0; y < dims[w]; y++) {
        for (int x = 0; x < dims[u]; x++) {
            int ijk[3];
            ijk[axis] = index;
            ijk[u] = x;
            ijk[w] = dims[w] - 1 - y; /* rows from the top */
            float val = volux_volume_value_at(vol, ijk[0], ijk[1], ijk[2]);
            float *p = out->rgb + 3 * ((size_t)y * dims[u] + x);
            if (rq->grey) {
                double g = (val - (level - 0.5 * window)) / window;
                g = g < 0 ? 0 : g > 1 ? 1 : g;
                /* grey as displayed (the PNG encoding applies the sRGB curve) */
                p[0] = p[1] = p[2] = volux_srgb_decode((float)g);
            } else if (tf->n_color > 0) {
                volux_tf_eval_color(tf->color, tf->n_color, val, p); /* linear, as the renderer uses it */
            } else {
                p[0] = p[1] = p[2] = 1.0f;
            }
        }
    }
    viewer_unlock(v, 0);
    return 200;
}
