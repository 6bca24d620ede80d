/*
 * io/tf_preset.c — ParaView colour-map presets (the JSON that ParaView's
 * "Save as preset" / "Export" writes): a list of objects, or one object,
 * with "Name", "RGBPoints": [x, r, g, b, ...] and optionally "Points":
 * [x, opacity, midpoint, sharpness, ...]. ParaView applies a preset over the
 * data range, so we map the preset's [x_first, x_last] onto [s_min, s_max].
 * Opacity segments honour ParaView's midpoint, the fraction of the segment
 * at which the opacity reaches the mean of its two ends (an extra point
 * there; exact for sharpness 0, ParaView's default). Sharpness > 0 bends
 * the segment into a curve that is not modelled: such segments are counted
 * (n_sharp) so the scene loader can say so.
 * Other keys (ColorSpace, NanColor, ...) are ParaView's business and are
 * ignored, but the ones we read must not repeat.
 */
#include <math.h>
#include <string.h>

#include "json_reader.h"
#include "scene_formats.h"

void volux_tf_preset_free(volux_context *ctx, volux_tf_preset *p) {
    if (!p) return;
    volux_free(ctx, p->color, sizeof *p->color * (size_t)p->n_color);
    volux_free(ctx, p->opacity, sizeof *p->opacity * (size_t)p->n_opacity);
    memset(p, 0, sizeof *p);
}

/* Reads a flat array of `stride`-tuples with non-decreasing x. */
static volux_status read_tuples(volux_json_reader *r, const cJSON *arr, const char *what, int stride, double **out,
                                int *count) {
    if (!cJSON_IsArray(arr)) return volux_json_error(r, VOLUX_ERR_FORMAT, what, "expected an array of numbers");
    int n = cJSON_GetArraySize(arr);
    if (n < stride || n % stride != 0 || n / stride > VOLUX_TF_MAX_POINTS)
        return volux_json_error(r, VOLUX_ERR_FORMAT, what, "needs a multiple of %d numbers (1..%d points), got %d",
                                stride, VOLUX_TF_MAX_POINTS, n);
    double *v = volux_malloc(r->ctx, sizeof(double) * (size_t)n);
    if (!v) return volux_json_error(r, VOLUX_ERR_NOMEM, what, "out of memory");
    int i = 0;
    for (const cJSON *c = arr->child; c; c = c->next, i++) {
        if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) || fabs(c->valuedouble) > 1e30) {
            volux_free(r->ctx, v, sizeof(double) * (size_t)n);
            return volux_json_error(r, VOLUX_ERR_FORMAT, what, "element %d is not a finite number", i);
        }
        v[i] = c->valuedouble;
        if (i % stride == 0 && i >= stride && v[i] < v[i - stride]) {
            volux_free(r->ctx, v, sizeof(double) * (size_t)n);
            return volux_json_error(r, VOLUX_ERR_FORMAT, what, "point %d: x must not decrease", i / stride);
        }
        if (i % stride != 0 && (v[i] < 0.0 || v[i] > 1.0)) { /* colours, opacity, midpoint, sharpness */
            double bad = v[i]; /* read before the free below */
            volux_free(r->ctx, v, sizeof(double) * (size_t)n);
            return volux_json_error(r, VOLUX_ERR_FORMAT, what, "element %d = %g is outside [0, 1]", i, bad);
        }
    }
    *out = v;
    *count = n / stride;
    return VOLUX_OK;
}

/* cJSON keeps repeated keys and returns the first; a file that says
 * "RGBPoints" twice is ambiguous, so it is an error. */
static int repeated(const cJSON *obj, const char *key) {
    int n = 0;
    for (const cJSON *c = obj->child; c; c = c->next) n += c->string && !strcmp(c->string, key);
    return n > 1;
}

volux_status volux_tf_preset_parse(volux_context *ctx, const char *text, size_t n, const char *name,
                                   const char *preset_name, double s_min, double s_max, volux_tf_preset *out) {
    volux_json_reader r = {ctx, name ? name : "preset"};
    cJSON *root = NULL;
    volux_status st = volux_json_parse(&r, text, n, &root);
    if (st) return st;
    const cJSON *preset = NULL;
    if (cJSON_IsObject(root)) preset = root;
    else if (cJSON_IsArray(root)) {
        for (const cJSON *c = root->child; c && !preset; c = c->next) {
            if (!cJSON_IsObject(c)) continue;
            const cJSON *nm = cJSON_GetObjectItemCaseSensitive(c, "Name");
            if (!preset_name || (cJSON_IsString(nm) && !strcmp(nm->valuestring, preset_name))) preset = c;
        }
    }
    /* A single preset object must also carry the asked-for name: picking
     * it anyway would silently show the wrong colours. */
    if (preset && preset == root && preset_name) {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(preset, "Name");
        if (!cJSON_IsString(nm) || strcmp(nm->valuestring, preset_name)) preset = NULL;
    }
    if (!preset) {
        cJSON_Delete(root);
        if (preset_name) return volux_json_error(&r, VOLUX_ERR_INVALID, NULL, "no preset named '%.128s'", preset_name);
        return volux_json_error(&r, VOLUX_ERR_FORMAT, NULL, "expected a preset object or a list of them");
    }
    static const char *const read_keys[] = {"Name", "RGBPoints", "Points"};
    for (int k = 0; k < 3; k++)
        if (repeated(preset, read_keys[k])) {
            cJSON_Delete(root);
            return volux_json_error(&r, VOLUX_ERR_FORMAT, read_keys[k], "duplicate key");
        }
    const cJSON *rgb = cJSON_GetObjectItemCaseSensitive(preset, "RGBPoints");
    if (!rgb) {
        cJSON_Delete(root);
        return volux_json_error(&r, VOLUX_ERR_UNSUPPORTED, "RGBPoints",
                                "missing (indexed-colour presets are not supported)");
    }
    double *cv = NULL, *ov = NULL;
    int nc = 0, no = 0;
    volux_tf_preset p = {0};
    if ((st = read_tuples(&r, rgb, "RGBPoints", 4, &cv, &nc))) goto done;
    const cJSON *pts = cJSON_GetObjectItemCaseSensitive(preset, "Points");
    if (pts && (st = read_tuples(&r, pts, "Points", 4, &ov, &no))) goto done;
    /* Map [x0, x1] of the colours onto the data range when asked. */
    double x0 = cv[0], x1 = cv[4 * (nc - 1)];
    double scale = 1.0, shift = 0.0;
    if (s_min < s_max && x1 > x0) {
        scale = (s_max - s_min) / (x1 - x0);
        shift = s_min - x0 * scale;
    }
    /* A tiny preset span mapped onto a wide range can overflow float; say
     * so here instead of failing later on a non-finite TF point. */
    for (int i = 0; i < nc + no; i++) {
        double x = (i < nc ? cv[4 * i] : ov[4 * (i - nc)]) * scale + shift;
        if (!(fabs(x) <= 1e30)) {
            st = volux_json_error(&r, VOLUX_ERR_FORMAT, i < nc ? "RGBPoints" : "Points",
                                  "point %d does not map to a finite value on [%g, %g] (\"preset_rescale\": false "
                                  "keeps the preset's own values)",
                                  i < nc ? i : i - nc, s_min, s_max);
            goto done;
        }
    }
    p.color = volux_malloc(ctx, sizeof *p.color * (size_t)nc);
    if (!p.color) {
        st = volux_json_error(&r, VOLUX_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    p.n_color = nc;
    for (int i = 0; i < nc; i++)
        p.color[i] = (volux_tf_color_point){(float)(cv[4 * i] * scale + shift), (float)cv[4 * i + 1],
                                            (float)cv[4 * i + 2], (float)cv[4 * i + 3]};
    if (no) {
        /* Point i's midpoint and sharpness shape the segment to point i+1. */
        int extra = 0;
        for (int i = 0; i + 1 < no; i++) extra += ov[4 * i + 2] != 0.5 && ov[4 * (i + 1)] > ov[4 * i];
        if (no + extra > VOLUX_TF_MAX_POINTS) {
            st = volux_json_error(&r, VOLUX_ERR_FORMAT, "Points", "%d points with their midpoints exceed %d", no + extra,
                                  VOLUX_TF_MAX_POINTS);
            goto done;
        }
        p.opacity = volux_malloc(ctx, sizeof *p.opacity * (size_t)(no + extra));
        if (!p.opacity) {
            st = volux_json_error(&r, VOLUX_ERR_NOMEM, NULL, "out of memory");
            goto done;
        }
        int k = 0;
        for (int i = 0; i < no; i++) {
            double x = ov[4 * i], o = ov[4 * i + 1];
            p.opacity[k++] = (volux_tf_scalar_point){(float)(x * scale + shift), (float)o};
            if (i + 1 == no) break;
            double xn = ov[4 * (i + 1)], o1 = ov[4 * (i + 1) + 1], mid = ov[4 * i + 2], sharp = ov[4 * i + 3];
            if (sharp > 0.0 && o1 != o) p.n_sharp++;
            if (mid != 0.5 && xn > x) {
                /* Midpoint 0 or 1 puts the mean at an end: a step there. */
                double xm = x + mid * (xn - x);
                p.opacity[k++] = (volux_tf_scalar_point){(float)(xm * scale + shift), (float)(0.5 * (o + o1))};
            }
        }
        p.n_opacity = k;
    }
done:
    volux_free(ctx, cv, sizeof(double) * 4 * (size_t)nc);
    volux_free(ctx, ov, sizeof(double) * 4 * (size_t)no);
    cJSON_Delete(root);
    if (st) {
        volux_tf_preset_free(ctx, &p);
        return st;
    }
    *out = p;
    return VOLUX_OK;
}

volux_status volux_tf_preset_load(volux_context *ctx, const char *path, const char *name, double s_min, double s_max,
                                  volux_tf_preset *out) {
    char *text;
    size_t n;
    volux_status st = volux_json_read_file(ctx, path, &text, &n);
    if (st) return st;
    st = volux_tf_preset_parse(ctx, text, n, path, name, s_min, s_max, out);
    volux_free(ctx, text, n + 1);
    return st;
}
