/* tests/support/pt_util.c — see pt_util.h. */
#include "pt_util.h"
#include "render/technique_class.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


void pt_accumulate(volux_technique *t, volux_scene *scene, int spp, pt_stats *out) {
    const volux_render_settings *rs = volux_scene_render(scene);
    int w = rs->width, h = rs->height;
    size_t n = (size_t)w * (size_t)h;
    double *sum = calloc(3 * n, sizeof *sum), *sq = calloc(3 * n, sizeof *sq);
    assert_non_null(sum);
    assert_non_null(sq);
    const volux_technique_class *cls = volux_technique_class_of(t);
    const void *state = volux_technique_state(t);
    float rgb[VOLUX_TILE_SIZE * VOLUX_TILE_SIZE * 3];
    for (int s = 0; s < spp; s++)
        for (int y0 = 0; y0 < h; y0 += VOLUX_TILE_SIZE)
            for (int x0 = 0; x0 < w; x0 += VOLUX_TILE_SIZE) {
                volux_tile tile = {x0, y0, w - x0 < VOLUX_TILE_SIZE ? w - x0 : VOLUX_TILE_SIZE,
                                   h - y0 < VOLUX_TILE_SIZE ? h - y0 : VOLUX_TILE_SIZE, (uint32_t)s, NULL, NULL, NULL};
                volux_tile_stats ts = {0, 0, 0};
                memset(rgb, 0, sizeof rgb);
                cls->render_tile(state, scene, &tile, rgb, &ts);
                for (int y = 0; y < tile.h; y++)
                    for (int x = 0; x < tile.w; x++) {
                        size_t p = (size_t)(y0 + y) * (size_t)w + (size_t)(x0 + x);
                        for (int c = 0; c < 3; c++) {
                            double v = rgb[3 * (y * tile.w + x) + c];
                            assert_true(isfinite(v));
                            sum[3 * p + c] += v;
                            sq[3 * p + c] += v * v;
                        }
                    }
            }
    out->width = w;
    out->height = h;
    out->spp = spp;
    out->mean = sum;
    out->var = sq;
    for (size_t i = 0; i < 3 * n; i++) {
        double m = sum[i] / spp;
        double var = spp > 1 ? (sq[i] - spp * m * m) / (spp - 1) : 0.0;
        out->mean[i] = m;
        out->var[i] = var > 0.0 ? var : 0.0;
    }
}

void pt_stats_free(pt_stats *s) {
    free(s->mean);
    free(s->var);
    memset(s, 0, sizeof *s);
}

double pt_stats_se(const pt_stats *s, int p, int c) { return sqrt(s->var[3 * p + c] / s->spp); }

volux_volume *pt_volume_fn(volux_context *ctx, int nx, int ny, int nz, float (*f)(int, int, int, void *),
                           void *user) {
    float *data = malloc(sizeof(float) * (size_t)nx * (size_t)ny * (size_t)nz);
    assert_non_null(data);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) data[((size_t)k * ny + j) * nx + i] = f(i, j, k, user);
    volux_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = nx, d.dims[1] = ny, d.dims[2] = nz;
    d.spacing[0] = d.spacing[1] = d.spacing[2] = 1.0;
    d.type = VOLUX_FLOAT32;
    d.data = data;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    free(data);
    return v;
}

static float constant_fn(int i, int j, int k, void *u) {
    (void)i, (void)j, (void)k;
    return *(const float *)u;
}

volux_volume *pt_volume_constant(volux_context *ctx, int nx, int ny, int nz, float value) {
    return pt_volume_fn(ctx, nx, ny, nz, constant_fn, &value);
}

volux_scene *pt_scene(volux_context *ctx, volux_volume *v, const volux_tf_scalar_point *ext, int n_ext,
                      const volux_tf_color_point *color, int n_color, float albedo, float g, float height, int w,
                      int h, int max_depth) {
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_transfer_desc tf;
    volux_transfer_desc_defaults(&tf);
    tf.opacity = ext;
    tf.n_opacity = n_ext;
    tf.extinction = 1;
    tf.color = color;
    tf.n_color = n_color;
    tf.albedo = albedo;
    tf.anisotropy = g;
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    volux_camera_desc cam;
    volux_camera_desc_defaults(&cam);
    cam.use_orbit = 0;
    cam.projection = VOLUX_ORTHOGRAPHIC;
    cam.eye = (volux_vec3){0, 0, 50};
    cam.look_at = (volux_vec3){0, 0, 0};
    cam.up = (volux_vec3){0, 1, 0};
    cam.height = height;
    assert_int_equal(volux_scene_set_camera(s, &cam), VOLUX_OK);
    volux_render_settings rs;
    volux_render_settings_defaults(&rs);
    rs.width = w;
    rs.height = h;
    rs.max_depth = max_depth;
    rs.threads = 1;
    strcpy(rs.technique, "pathtrace");
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    return s;
}

void pt_add_constant_env(volux_scene *s, volux_vec3 rgb, int visible) {
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.color = rgb;
    l.radiance = 1.0f;
    l.visible = visible;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
}
