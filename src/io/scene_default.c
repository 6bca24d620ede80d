/*
 * io/scene_default.c — the quick-look scene: what `volux render VOLUME`
 * shows, and the transfer function a scene without one gets.
 *
 * Everything a viewer in the field does when it opens a bare volume
 * (ParaView, 3D Slicer's volume rendering module, Inviwo): a transfer
 * function from the histogram (core/transfer_auto.c), a camera that frames
 * the volume, one light, gradient shading. Values are rounded so the JSON
 * a user gets from --dump-scene is readable; the scene that renders is the
 * one read back from that JSON, so the dump is exact.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/context_internal.h"
#include "scene_formats.h"

/* x to `digits` significant digits (for readable JSON). */
static double round_sig(double x, int digits) {
    char buf[64];
    snprintf(buf, sizeof buf, "%.*g", digits, x);
    return strtod(buf, NULL);
}

static double round_dec(double x, double scale) { return round(x * scale) / scale; }

static cJSON *row(const double *v, int n) {
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++) {
        cJSON *num = cJSON_CreateNumber(v[i]);
        if (!num || !cJSON_AddItemToArray(a, num)) {
            cJSON_Delete(num);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

static int add(cJSON *obj, const char *key, cJSON *item) {
    if (!item) return 0;
    if (!cJSON_AddItemToObject(obj, key, item)) {
        cJSON_Delete(item);
        return 0;
    }
    return 1;
}

static int push(cJSON *arr, cJSON *item) {
    if (!item) return 0;
    if (!cJSON_AddItemToArray(arr, item)) {
        cJSON_Delete(item);
        return 0;
    }
    return 1;
}

cJSON *volux_auto_tf_json(volux_context *ctx, const volux_volume *vol, volux_status *status) {
    *status = VOLUX_OK;
    volux_transfer_auto a;
    if ((*status = volux_transfer_auto_from_volume(ctx, vol, &a))) return NULL;
    char comment[256];
    snprintf(comment, sizeof comment,
             "volux default: opacity 0 up to %.6g (%s), ramp to %g at %.6g (99.5th percentile); "
             "ParaView's Cool to Warm colours over the ramp",
             round_sig(a.ramp_start, 6), a.has_background ? "the end of the histogram's background peak" : "the minimum",
             (double)a.opacity[1].v, round_sig(a.ramp_end, 6));
    /* Each container is attached before it is filled, so one delete of tf
     * frees everything on any failure. */
    cJSON *tf = cJSON_CreateObject(), *color = NULL, *opacity = NULL;
    int ok = tf && add(tf, "comment", cJSON_CreateString(comment)) && add(tf, "color", color = cJSON_CreateArray()) &&
             add(tf, "opacity", opacity = cJSON_CreateArray());
    for (int i = 0; ok && i < a.n_color; i++) {
        double v[4] = {round_sig(a.color[i].s, 6), round_dec(a.color[i].r, 1e4), round_dec(a.color[i].g, 1e4),
                       round_dec(a.color[i].b, 1e4)};
        ok = push(color, row(v, 4));
    }
    for (int i = 0; ok && i < a.n_opacity; i++) {
        double v[2] = {round_sig(a.opacity[i].s, 6), a.opacity[i].v};
        ok = push(opacity, row(v, 2));
    }
    if (!ok) {
        cJSON_Delete(tf);
        *status = volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the default transfer function");
        return NULL;
    }
    return tf;
}

volux_status volux_scene_default_json(volux_context *ctx, const char *volume_json, const volux_volume *vol,
                                      char **json) {
    *json = NULL;
    cJSON *volume = cJSON_Parse(volume_json);
    if (!cJSON_IsObject(volume)) {
        cJSON_Delete(volume);
        return volux_error(ctx, VOLUX_ERR_INVALID, "default scene: the volume must be a JSON object, got '%.200s'",
                           volume_json);
    }
    volux_status st = VOLUX_OK;
    cJSON *root = cJSON_CreateObject();
    if (!root || !add(root, "comment",
                      cJSON_CreateString("volux quick look: the default transfer function from the histogram, an "
                                         "orbit camera framing the volume, one key light. Edit and render with "
                                         "`volux render THIS.json -o OUT.png`.")) ||
        !add(root, "volume", volume)) {
        if (!cJSON_GetObjectItemCaseSensitive(root, "volume")) cJSON_Delete(volume);
        goto nomem;
    }
    cJSON *tf = volux_auto_tf_json(ctx, vol, &st);
    if (!tf) goto fail;
    if (!add(root, "transfer_function", tf)) goto nomem;

    /* Camera: DESIGN §3's default orbit (az 30, el 20, fov 30, framing the
     * bounding sphere) around the file's superior direction when it has
     * one; an axis within 5° counts as that axis. */
    double up[3] = {0, 1, 0};
    volux_vec3 sup;
    if (volux_volume_superior(vol, &sup)) {
        double s[3] = {sup.x, sup.y, sup.z};
        int axis = -1;
        for (int k = 0; k < 3; k++)
            if (fabs(s[k]) > 0.996) axis = k;
        for (int k = 0; k < 3; k++) up[k] = axis < 0 ? round_dec(s[k], 1e3) : (k == axis ? (s[k] > 0 ? 1 : -1) : 0);
    }
    cJSON *camera = cJSON_CreateObject(), *orbit = cJSON_CreateObject();
    if (!add(root, "camera", camera)) {
        cJSON_Delete(orbit);
        goto nomem;
    }
    if (!add(camera, "orbit", orbit) || !add(orbit, "azimuth", cJSON_CreateNumber(30)) ||
        !add(orbit, "elevation", cJSON_CreateNumber(20)) || !add(camera, "fov_y", cJSON_CreateNumber(30)))
        goto nomem;
    if (up[0] == 0 && up[1] == 0 && up[2] == 1) {
        if (!add(camera, "z_up", cJSON_CreateTrue())) goto nomem;
    } else if (!(up[0] == 0 && up[1] == 1 && up[2] == 0)) {
        if (!add(camera, "up", row(up, 3))) goto nomem;
    }

    /* Key light: from 45° to the viewer's left and 45° above the orbit's
     * equator (the camera sits at az 30, el 20), travelling towards the
     * volume; irradiance 1 keeps `shaded` colours near the TF's. */
    volux_vec3 basis[3];
    volux_camera_orbit_basis((volux_vec3){(float)up[0], (float)up[1], (float)up[2]}, basis);
    const double az = (30.0 - 45.0) * 3.14159265358979 / 180.0, el = 45.0 * 3.14159265358979 / 180.0;
    double from[3], dir[3];
    for (int k = 0; k < 3; k++) {
        const float *b0 = &basis[0].x, *b1 = &basis[1].x, *b2 = &basis[2].x;
        from[k] = cos(el) * sin(az) * b0[k] + sin(el) * b1[k] + cos(el) * cos(az) * b2[k];
        dir[k] = round_dec(-from[k], 1e3);
        if (dir[k] == 0.0) dir[k] = 0.0; /* no "-0" in the JSON */
    }
    cJSON *lights = cJSON_CreateArray(), *key = cJSON_CreateObject();
    if (!add(root, "lights", lights)) {
        cJSON_Delete(key);
        goto nomem;
    }
    if (!push(lights, key) || !add(key, "type", cJSON_CreateString("directional")) ||
        !add(key, "direction", row(dir, 3)) || !add(key, "irradiance", cJSON_CreateNumber(1)))
        goto nomem;
    /* ParaView's background (0.32, 0.34, 0.43) as displayed, in linear
     * units (the PNG writer applies the sRGB curve). */
    const double bg[3] = {0.085, 0.095, 0.155};
    cJSON *render = cJSON_CreateObject();
    if (!add(root, "background", row(bg, 3)) || !add(root, "render", render) ||
        !add(render, "technique", cJSON_CreateString("shaded")) || !add(render, "width", cJSON_CreateNumber(512)) ||
        !add(render, "height", cJSON_CreateNumber(512)))
        goto nomem;
    st = volux_json_print(ctx, root, json);
    cJSON_Delete(root);
    return st;
nomem:
    st = volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the default scene");
fail:
    cJSON_Delete(root);
    return st;
}
