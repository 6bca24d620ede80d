/*
 * tools/viewer/state.c — the JSON documents of the API: the snapshot
 * clients read without waiting for a frame (/api/scene, /api/state), the
 * technique list (/api/techniques) and the statistics (/api/stats).
 */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "viewer.h"

void viewer_change_names(uint32_t bits, char *out, size_t n) {
    static const char *const names[] = {"volume", "extinction", "color",  "density", "phase",
                                        "lights", "camera",     "params", "render"};
    size_t used = 0;
    out[0] = 0;
    for (int i = 0; i < 9; i++)
        if (bits & (1u << i)) {
            int w = snprintf(out + used, n - used, "%s%s", used ? "," : "", names[i]);
            if (w < 0 || (size_t)w >= n - used) break;
            used += (size_t)w;
        }
}

char *viewer_base64(const unsigned char *data, size_t n, size_t *out_len) {
    static const char a[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t len = 4 * ((n + 2) / 3);
    char *out = malloc(len + 1);
    if (!out) return NULL;
    size_t o = 0, i = 0;
    for (; i + 2 < n; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16 | (uint32_t)data[i + 1] << 8 | data[i + 2];
        out[o++] = a[v >> 18];
        out[o++] = a[(v >> 12) & 63];
        out[o++] = a[(v >> 6) & 63];
        out[o++] = a[v & 63];
    }
    if (i < n) {
        uint32_t v = (uint32_t)data[i] << 16 | (i + 1 < n ? (uint32_t)data[i + 1] << 8 : 0);
        out[o++] = a[v >> 18];
        out[o++] = a[(v >> 12) & 63];
        out[o++] = i + 1 < n ? a[(v >> 6) & 63] : '=';
        out[o++] = '=';
    }
    out[o] = 0;
    if (out_len) *out_len = o;
    return out;
}

static cJSON *vec3(volux_vec3 v) {
    double d[3] = {v.x, v.y, v.z};
    return cJSON_CreateDoubleArray(d, 3);
}

/* The transfer function as the scene holds it after reading (a preset
 * file's colours included), so the page can draw and edit it. */
static cJSON *resolved_tf(const volux_scene *s) {
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    cJSON *o = cJSON_CreateObject(), *color = cJSON_AddArrayToObject(o, "color"),
          *op = cJSON_AddArrayToObject(o, tf->extinction ? "extinction" : "opacity");
    for (int i = 0; i < tf->n_color; i++) {
        double row[4] = {tf->color[i].s, tf->color[i].r, tf->color[i].g, tf->color[i].b};
        cJSON_AddItemToArray(color, cJSON_CreateDoubleArray(row, 4));
    }
    for (int i = 0; i < tf->n_opacity; i++) {
        double row[2] = {tf->opacity[i].s, tf->opacity[i].v};
        cJSON_AddItemToArray(op, cJSON_CreateDoubleArray(row, 2));
    }
    cJSON_AddNumberToObject(o, "albedo", tf->albedo);
    cJSON_AddNumberToObject(o, "anisotropy", tf->anisotropy);
    cJSON_AddNumberToObject(o, "density_scale", tf->density_scale);
    cJSON_AddNumberToObject(o, "opacity_unit_distance", tf->opacity_unit_distance);
    return o;
}

static cJSON *volume_info(const volux_scene *s) {
    const volux_volume *vol = volux_scene_volume(s);
    cJSON *o = cJSON_CreateObject();
    int dims[3];
    double sp[3], lo, hi;
    volux_volume_dims(vol, dims);
    volux_volume_spacing(vol, sp);
    volux_volume_range(vol, &lo, &hi);
    cJSON_AddItemToObject(o, "dims", cJSON_CreateIntArray(dims, 3));
    cJSON_AddItemToObject(o, "spacing", cJSON_CreateDoubleArray(sp, 3));
    cJSON_AddItemToObject(o, "type", cJSON_CreateString(volux_scalar_type_name(volux_volume_type(vol))));
    double range[2] = {lo, hi};
    cJSON_AddItemToObject(o, "range", cJSON_CreateDoubleArray(range, 2));
    volux_vec3 c;
    float r;
    volux_scene_bounds_sphere(s, &c, &r);
    cJSON_AddItemToObject(o, "center", vec3(c));
    cJSON_AddNumberToObject(o, "radius", r);
    volux_vec3 sup;
    if (volux_volume_superior(vol, &sup)) cJSON_AddItemToObject(o, "superior", vec3(sup)); /* patient axes known */
    volux_vec3 box_lo, box_hi; /* the crop box sliders' range (world) */
    volux_volume_bounds(vol, &box_lo, &box_hi);
    cJSON_AddItemToObject(o, "box_min", vec3(box_lo));
    cJSON_AddItemToObject(o, "box_max", vec3(box_hi));
    uint64_t counts[VIEWER_HISTOGRAM_BINS];
    volux_volume_histogram(vol, VIEWER_HISTOGRAM_BINS, counts);
    double d[VIEWER_HISTOGRAM_BINS];
    for (int i = 0; i < VIEWER_HISTOGRAM_BINS; i++) d[i] = (double)counts[i];
    cJSON_AddItemToObject(o, "histogram", cJSON_CreateDoubleArray(d, VIEWER_HISTOGRAM_BINS));
    return o;
}

int viewer_snapshot(viewer *v) {
    volux_scene *s = volux_scene_doc_scene(v->doc);
    char *rel = NULL, *abs = NULL, *state = NULL;
    size_t nr = 0, na = 0;
    volux_context_clear_error(v->ctx);
    if (volux_scene_doc_json(v->doc, 0, &rel, &nr) ||
        volux_scene_doc_json(v->doc, VOLUX_DOC_JSON_PRETTY | VOLUX_DOC_JSON_ABSOLUTE_PATHS, &abs, &na)) {
        volux_scene_doc_json_free(v->doc, rel, nr);
        return 0;
    }
    if (!v->vol_info || (volux_scene_changes_since(s, &v->vol_seen).what & VOLUX_CHANGE_VOLUME)) {
        cJSON_Delete(v->vol_info);
        v->vol_info = volume_info(s); /* one pass over the voxels, only for a new volume */
        v->vol_seen = volux_scene_stamp_now(s);
    }
    cJSON *vol_info = v->vol_info;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "version", (double)volux_scene_doc_version(v->doc));
    const char *name = v->opt.scene_name ? v->opt.scene_name : v->opt.scene_path;
    cJSON_AddItemToObject(o, "scene_path", cJSON_CreateString(name));
    cJSON_AddItemToObject(o, "data_root", cJSON_CreateString(v->opt.data_root_shown ? v->opt.data_root_shown
                                                                                    : volux_scene_doc_data_root(v->doc)));
    cJSON_AddItemToObject(o, "scene", cJSON_Parse(rel));
    cJSON *res = cJSON_AddObjectToObject(o, "resolved");
    cJSON_AddItemToObject(res, "transfer_function", resolved_tf(s));
    const volux_render_settings *rs = volux_scene_render(s);
    cJSON *r = cJSON_AddObjectToObject(res, "render");
    cJSON_AddStringToObject(r, "technique", rs->technique);
    cJSON_AddNumberToObject(r, "width", rs->width);
    cJSON_AddNumberToObject(r, "height", rs->height);
    cJSON_AddNumberToObject(r, "spp", rs->spp);
    cJSON_AddNumberToObject(r, "exposure", rs->exposure);
    cJSON_AddNumberToObject(r, "step", rs->step);
    cJSON_AddNumberToObject(r, "target_error", rs->target_error);
    cJSON_AddNumberToObject(r, "time_ms", rs->time_ms);
    const volux_camera_desc *cam = volux_scene_camera_desc(s);
    cJSON *c = cJSON_AddObjectToObject(res, "camera");
    cJSON_AddBoolToObject(c, "orbit", cam->use_orbit);
    cJSON_AddNumberToObject(c, "azimuth", cam->azimuth_deg);
    cJSON_AddNumberToObject(c, "elevation", cam->elevation_deg);
    cJSON_AddNumberToObject(c, "distance", cam->distance);
    cJSON_AddNumberToObject(c, "fov_y", cam->fov_y_deg);
    cJSON_AddItemToObject(c, "eye", vec3(cam->eye));
    cJSON_AddItemToObject(c, "look_at", vec3(cam->look_at));
    cJSON_AddItemToObject(c, "up", vec3(cam->up));
    cJSON_AddItemToObject(c, "type", cJSON_CreateString(cam->projection == VOLUX_ORTHOGRAPHIC ? "orthographic"
                                                                                             : "perspective"));
    cJSON_AddItemToObject(o, "volume", cJSON_Duplicate(vol_info, 1));
    if (volux_scene_sequence(s)) { /* a time-varying volume: the page shows its step slider */
        cJSON *q = cJSON_AddObjectToObject(o, "sequence");
        cJSON_AddNumberToObject(q, "steps", volux_scene_time_steps(s));
        cJSON_AddNumberToObject(q, "step", volux_scene_time_step(s));
    }
    cJSON *lim = cJSON_AddObjectToObject(o, "limits");
    cJSON_AddNumberToObject(lim, "max_image", v->opt.max_image);
    cJSON_AddNumberToObject(lim, "preview_max", v->opt.preview_max);
    cJSON_AddNumberToObject(lim, "max_lights", VOLUX_MAX_LIGHTS);
    cJSON_AddNumberToObject(lim, "slice_max_pixels", VIEWER_SLICE_MAX_PIXELS);
    cJSON *vw = cJSON_AddObjectToObject(o, "viewer"); /* the switches at start (POST /api/view changes them) */
    cJSON_AddBoolToObject(vw, "auto_exposure", v->opt.auto_exposure);
    cJSON_AddBoolToObject(vw, "denoise", !v->opt.no_denoise);
    state = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    if (!state) {
        volux_scene_doc_json_free(v->doc, rel, nr);
        volux_scene_doc_json_free(v->doc, abs, na);
        return 0;
    }
    char *rel_copy = strdup(rel), *abs_copy = strdup(abs), *state_copy = strdup(state);
    volux_scene_doc_json_free(v->doc, rel, nr);
    volux_scene_doc_json_free(v->doc, abs, na);
    cJSON_free(state);
    if (!rel_copy || !abs_copy || !state_copy) {
        free(rel_copy);
        free(abs_copy);
        free(state_copy);
        return 0;
    }
    pthread_mutex_lock(&v->snap_lock);
    free(v->scene_json);
    free(v->scene_json_abs);
    free(v->state_json);
    v->scene_json = rel_copy;
    v->scene_json_abs = abs_copy;
    v->state_json = state_copy;
    v->snap_version = volux_scene_doc_version(v->doc);
    pthread_mutex_unlock(&v->snap_lock);
    return 1;
}

char *viewer_techniques_json(void) {
    static const char *const kinds[] = {"number", "int", "bool", "string", "file"};
    cJSON *list = cJSON_CreateArray();
    for (int i = 0; i < volux_technique_count(); i++) {
        const volux_technique_info *t = volux_technique_info_at(i);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", t->name);
        cJSON_AddStringToObject(o, "summary", t->summary);
        cJSON_AddBoolToObject(o, "progressive", t->progressive);
        cJSON *ps = cJSON_AddArrayToObject(o, "params");
        for (const volux_param_info *p = t->params; p && p->name; p++) {
            cJSON *q = cJSON_CreateObject();
            cJSON_AddStringToObject(q, "name", p->name);
            cJSON_AddStringToObject(q, "kind", kinds[p->kind]);
            if (p->kind == VOLUX_PARAM_STRING || p->kind == VOLUX_PARAM_FILE) {
                cJSON_AddStringToObject(q, "default", p->def_string ? p->def_string : "");
            } else if (p->kind == VOLUX_PARAM_BOOL) {
                cJSON_AddBoolToObject(q, "default", p->def != 0);
            } else {
                cJSON_AddNumberToObject(q, "default", p->def);
                cJSON_AddNumberToObject(q, "min", p->min);
                cJSON_AddNumberToObject(q, "max", p->max);
            }
            cJSON_AddStringToObject(q, "doc", p->doc ? p->doc : "");
            cJSON_AddItemToArray(ps, q);
        }
        cJSON_AddItemToArray(list, o);
    }
    char *text = cJSON_PrintUnformatted(list);
    cJSON_Delete(list);
    char *copy = text ? strdup(text) : NULL;
    cJSON_free(text);
    return copy;
}

char *viewer_stats_json(viewer *v) {
    pthread_mutex_lock(&v->frame_lock);
    viewer_stats s = v->stats;
    viewer_frame f = v->frame;
    pthread_mutex_unlock(&v->frame_lock);
    static const char *const kinds[] = {"preview", "refine", "final"};
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "technique", s.technique);
    cJSON_AddNumberToObject(o, "frame", (double)f.id);
    cJSON_AddNumberToObject(o, "version", (double)f.version);
    cJSON_AddStringToObject(o, "kind", f.data ? kinds[f.kind] : "none");
    cJSON_AddNumberToObject(o, "spp", f.spp);
    cJSON_AddNumberToObject(o, "width", f.width);
    cJSON_AddNumberToObject(o, "height", f.height);
    cJSON_AddNumberToObject(o, "edit_to_preview_ms", s.last_latency_ms);
    cJSON_AddNumberToObject(o, "edit_to_preview_cpu_ms", s.last_latency_cpu_ms);
    int first[2] = {s.last_first_w, s.last_first_h};
    cJSON_AddItemToObject(o, "first_preview_size", cJSON_CreateIntArray(first, 2));
    cJSON_AddNumberToObject(o, "first_preview_step_scale", s.last_first_step_scale);
    cJSON_AddNumberToObject(o, "preview_step_max", v->opt.preview_step_max);
    cJSON_AddNumberToObject(o, "edit_to_full_preview_ms", s.last_full_preview_ms);
    cJSON_AddNumberToObject(o, "edit_to_full_preview_cpu_ms", s.last_full_preview_cpu_ms);
    cJSON_AddNumberToObject(o, "preview_budget_ms", v->opt.preview_budget_ms);
    cJSON_AddNumberToObject(o, "edit_to_final_ms", s.last_final_ms);
    cJSON_AddNumberToObject(o, "update_ms", s.last_update_ms);
    cJSON_AddNumberToObject(o, "render_ms", s.last_render_ms);
    cJSON_AddNumberToObject(o, "encode_ms", s.last_encode_ms);
    cJSON_AddNumberToObject(o, "refine_step_ms", s.last_refine_ms);
    char names[128];
    viewer_change_names(s.last_changes, names, sizeof names);
    cJSON *cw = cJSON_AddObjectToObject(o, "cache_work");
    cJSON_AddStringToObject(cw, "changes", names);
    cJSON_AddNumberToObject(cw, "lights_updated", s.last_lights_changed);
    cJSON_AddNumberToObject(cw, "update_ms", s.last_update_ms);
    cJSON_AddNumberToObject(cw, "memory_bytes", (double)s.technique_bytes);
    cJSON_AddNumberToObject(cw, "budget_ms", s.last_update_budget_ms);
    cJSON_AddNumberToObject(cw, "pending", (double)s.pending);
    cJSON_AddNumberToObject(o, "edits", (double)s.edits);
    cJSON_AddNumberToObject(o, "edits_rejected", (double)s.edits_rejected);
    cJSON_AddNumberToObject(o, "frames", (double)s.frames);
    cJSON_AddNumberToObject(o, "cancelled", (double)s.cancelled);
    cJSON_AddNumberToObject(o, "first_frames_cancelled", (double)s.first_frames_cancelled);
    cJSON_AddNumberToObject(o, "downloads_refused", (double)s.downloads_refused);
    cJSON_AddNumberToObject(o, "stand_in_frames", (double)s.stand_in_frames);
    cJSON_AddNumberToObject(o, "edit_to_stand_in_ms", s.last_stand_in_ms);
    cJSON_AddNumberToObject(o, "edit_to_own_frame_ms", s.last_own_frame_ms);
    cJSON_AddStringToObject(o, "last_preparation", s.last_preparation);
    cJSON_AddBoolToObject(o, "auto_exposure_on", atomic_load(&v->auto_exposure));
    cJSON_AddNumberToObject(o, "auto_exposure", s.auto_exposure);
    cJSON_AddNumberToObject(o, "auto_exposures", (double)s.auto_exposures);
    cJSON_AddBoolToObject(o, "denoise", !atomic_load(&v->no_denoise));
    cJSON_AddNumberToObject(o, "requests", (double)s.requests);
    cJSON_AddNumberToObject(o, "requests_rejected", (double)s.requests_rejected);
    uint64_t rss = 0;
    FILE *fs = fopen("/proc/self/status", "r");
    if (fs) {
        char line[256];
        while (fgets(line, sizeof line, fs))
            if (!strncmp(line, "VmRSS:", 6)) rss = strtoull(line + 6, NULL, 10);
        fclose(fs);
    }
    cJSON_AddNumberToObject(o, "rss_kb", (double)rss);
    cJSON_AddNumberToObject(o, "context_bytes", (double)volux_context_bytes_in_use(v->ctx));
    if (s.error[0]) cJSON_AddStringToObject(o, "error", s.error);
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    char *copy = text ? strdup(text) : NULL;
    cJSON_free(text);
    return copy;
}
