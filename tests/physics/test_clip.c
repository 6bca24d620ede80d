/*
 * tests/physics/test_clip.c — crop box and clipping planes (issue 30):
 * clipped material is empty space for every technique and every ray.
 *
 * THE VOLUME (20³, spacing 1, centred: node i at x = i − 9.5). A block of
 * medium in the lower half (values 0.3 … 1.0, the 1.0 keeps the value range
 * of every variant the same) and a dense slab above it (0.9), light from
 * above: the slab shadows the block. TF: σt = 2·max(0, s − 0.15)/0.85,
 * value 0 transparent.
 *
 * WHAT IS CHECKED, for every technique:
 *   - cut: the scene with a plane that removes the slab (and a crop box that
 *     removes a corner of the block) renders the same image as the volume
 *     physically cut (those voxels written as 0): camera rays, shadow rays
 *     and every cache see the clipped medium, nothing else;
 *   - no shadow: with the slab clipped, the lit techniques' block is
 *     clearly brighter than with the slab (it shadowed the block, and
 *     clipped material no longer does);
 *   - edit: a clip applied as a document edit (`--set clip...` through
 *     volux_scene_doc_edit) to a live instance equals a fresh render.
 * And through the CLI: malformed clips exit 2 naming the key; --dump-scene
 * round-trips the section.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"
#include "volux/io.h"
#include "volux/technique.h"

#define N 20
/* Nodes x = i − 9.5. The slab: y ∈ [4.5, 7.5]; the block: y ∈ [−7.5, 1.5]. */
#define PLANE "{\"origin\": [0, 3, 0], \"normal\": [0, 1, 0]}"
/* Keeps x ≤ 5 (removes the block's +x corner), everything else inside. */
#define BOX "{\"min\": [-20, -20, -20], \"max\": [5, 20, 20]}"

static int in_slab(int i, int j, int k) {
    (void)i, (void)k;
    return j >= 14 && j <= 17;
}
static int in_block(int i, int j, int k) { return i >= 2 && i <= 17 && k >= 2 && k <= 17 && j >= 2 && j <= 11; }

/* variant 0: all; 1: slab removed; 2: slab removed and x > 5 removed */
static void write_volume(const char *name, int variant) {
    float *v = calloc((size_t)N * N * N, sizeof *v);
    assert_non_null(v);
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) {
                float s = 0.0f;
                if (in_block(i, j, k)) s = (i == 9 && j == 5 && k == 9) ? 1.0f : 0.3f + 0.05f * (float)((i + j + k) % 8);
                if (in_slab(i, j, k)) s = 0.9f;
                double x = i - 9.5, y = j - 9.5;
                if (variant >= 1 && y > 3.0) s = 0.0f;
                if (variant >= 2 && x > 5.0) s = 0.0f;
                v[((size_t)k * N + (size_t)j) * N + (size_t)i] = s;
            }
    tu_write_file(name, v, sizeof *v * (size_t)N * N * N);
    free(v);
}

static const char *scene_json(const char *file, const char *clip, const char *technique) {
    static char buf[2048];
    snprintf(buf, sizeof buf,
             "{\"volume\": {\"file\": \"%s\", \"dims\": [%d, %d, %d], \"type\": \"float32\", \"endian\": \"little\"},"
             " \"transfer_function\": {\"color\": [[0, 1, 0.9, 0.8], [1, 0.8, 0.9, 1]],"
             " \"extinction\": [[0, 0], [0.15, 0], [1, 2]], \"albedo\": 0.8},"
             " %s%s%s"
             " \"camera\": {\"type\": \"orthographic\", \"eye\": [6, 4, 40], \"look_at\": [0, 0, 0], \"height\": 24},"
             " \"lights\": [{\"type\": \"directional\", \"direction\": [0.1, -1, 0.05], \"irradiance\": 8}],"
             " \"render\": {\"technique\": \"%s\", \"width\": 16, \"height\": 16, \"spp\": %d, \"step\": 0.5,"
             " \"max_depth\": 4}}",
             file, N, N, N, clip ? "\"clip\": " : "", clip ? clip : "", clip ? "," : "", technique,
             strcmp(technique, "pathtrace") && strcmp(technique, "guided") && strcmp(technique, "manylights") ? 1 : 4);
    return buf;
}

static volux_image render(volux_context *ctx, const char *file, const char *clip, const char *technique) {
    volux_scene *s = tu_scene(ctx, scene_json(file, clip, technique));
    volux_image img = tu_render(ctx, s, technique);
    volux_scene_destroy(s);
    return img;
}

static double max_value(const volux_image *a) {
    double m = 0;
    for (size_t i = 0; i < (size_t)a->width * (size_t)a->height * 3; i++) m = fmax(m, a->rgb[i]);
    return m;
}

static const char *const TECHNIQUES[] = {"ea",  "shaded", "single",     "ao",     "ambient",
                                         "lightvol", "sh", "manylights", "guided", "pathtrace"};
#define N_TECH (int)(sizeof TECHNIQUES / sizeof TECHNIQUES[0])

static int setup(void **state) {
    (void)state;
    write_volume("clip_all.raw", 0);
    write_volume("clip_noslab.raw", 1);
    write_volume("clip_cut.raw", 2);
    return 0;
}

/* The clipped scene equals the physically cut volume, for every technique. */
static void clip_equals_cut_volume(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    for (int t = 0; t < N_TECH; t++) {
        const char *tech = TECHNIQUES[t];
        volux_image plane = render(ctx, "clip_all.raw", "{\"planes\": [" PLANE "]}", tech);
        volux_image noslab = render(ctx, "clip_noslab.raw", NULL, tech);
        volux_image both = render(ctx, "clip_all.raw", "{\"box\": " BOX ", \"planes\": [" PLANE "]}", tech);
        volux_image cut = render(ctx, "clip_cut.raw", NULL, tech);
        double d1 = tu_max_abs_diff(&plane, &noslab), d2 = tu_max_abs_diff(&both, &cut);
        double scale = fmax(max_value(&noslab), 1e-6);
        printf("%-10s plane vs slab removed: %.3g   box+plane vs cut: %.3g   (image max %.3g)\n", tech, d1, d2,
               scale);
        if (d1 > 1e-5 * scale || d2 > 1e-5 * scale) fail_msg("%s: the clip differs from the cut volume", tech);
        /* the box really removed something */
        if (!(tu_max_abs_diff(&both, &plane) > 1e-3 * scale)) fail_msg("%s: the crop box changed nothing", tech);
        volux_image_free(ctx, &plane);
        volux_image_free(ctx, &noslab);
        volux_image_free(ctx, &both);
        volux_image_free(ctx, &cut);
    }
    volux_context_destroy(ctx);
}

/* Clipped material no longer shadows: the block (image rows 10–13, below
 * the slab) is clearly brighter with the slab clipped than with it, for
 * every technique that lights the medium. A plane that removes nothing
 * renders exactly the unclipped scene. */
static double block_luminance(const volux_image *img) {
    double sum = 0;
    int n = 0;
    for (int y = 10; y <= 13; y++)
        for (int x = 0; x < img->width; x++, n++)
            sum += 0.2126 * tu_pixel(img, x, y, 0) + 0.7152 * tu_pixel(img, x, y, 1) + 0.0722 * tu_pixel(img, x, y, 2);
    return sum / n;
}

static void clipped_slab_casts_no_shadow(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    for (int t = 0; t < N_TECH; t++) {
        const char *tech = TECHNIQUES[t];
        volux_image lit = render(ctx, "clip_all.raw", "{\"planes\": [" PLANE "]}", tech);
        volux_image kept = render(ctx, "clip_all.raw", "{\"planes\": [{\"origin\": [0, 10, 0], \"normal\": [0, 1, 0]}]}", tech);
        volux_image none = render(ctx, "clip_all.raw", NULL, tech);
        double l1 = block_luminance(&lit), l0 = block_luminance(&kept), d = tu_max_abs_diff(&kept, &none);
        printf("%-10s block luminance: slab clipped %.4g, slab kept %.4g (x%.2f); empty clip vs none %.3g\n", tech,
               l1, l0, l1 / l0, d);
        if (d != 0.0) fail_msg("%s: a clip that removes nothing changed the image by %g", tech, d);
        /* ea and shaded cast no shadows: the block looks the same */
        if (strcmp(tech, "ea") && strcmp(tech, "shaded") && !(l1 > 1.2 * l0)) fail_msg("%s: the clipped slab still shadows the block", tech);
        volux_image_free(ctx, &lit);
        volux_image_free(ctx, &kept);
        volux_image_free(ctx, &none);
    }
    volux_context_destroy(ctx);
}

/* A clip set by a document edit on a live instance equals a fresh render. */
static void clip_edit_equals_fresh(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    for (int t = 0; t < N_TECH; t++) {
        const char *tech = TECHNIQUES[t];
        const char *path = tu_write_file("clip_scene.json", scene_json("clip_all.raw", NULL, tech),
                                         strlen(scene_json("clip_all.raw", NULL, tech)));
        volux_scene_doc *doc;
        assert_int_equal(volux_scene_doc_load(ctx, path, NULL, 0, NULL, &doc), VOLUX_OK);
        volux_technique *inst;
        assert_int_equal(volux_technique_create(ctx, tech, volux_scene_doc_scene(doc), &inst), VOLUX_OK);
        volux_image before = tu_render_with(ctx, volux_scene_doc_scene(doc), inst);
        const char *set[] = {"clip.box.min=[-20,-20,-20]", "clip.box.max=[5,20,20]", "clip.planes=[" PLANE "]"};
        uint32_t changed = 0;
        if (volux_scene_doc_edit(doc, set, 3, &changed)) fail_msg("edit: %s", volux_context_error(ctx));
        assert_true(changed & VOLUX_DOC_VOLUME);
        volux_image edited = tu_render_with(ctx, volux_scene_doc_scene(doc), inst);
        volux_image fresh = render(ctx, "clip_all.raw", "{\"box\": " BOX ", \"planes\": [" PLANE "]}", tech);
        double d = tu_max_abs_diff(&edited, &fresh), scale = fmax(max_value(&fresh), 1e-6);
        printf("%-10s edited vs fresh: %.3g (before the edit: %.3g)\n", tech, d, tu_max_abs_diff(&before, &fresh));
        if (d > 1e-4 * scale) fail_msg("%s: clip edit differs from a fresh render by %g", tech, d);
        volux_image_free(ctx, &before);
        volux_image_free(ctx, &edited);
        volux_image_free(ctx, &fresh);
        volux_technique_destroy(inst);
        volux_scene_doc_destroy(doc);
    }
    volux_context_destroy(ctx);
}

static void malformed_clip_exits_2(void **state) {
    (void)state;
    const char *json = scene_json("clip_all.raw", NULL, "ea");
    char path[512], out[512]; /* tu_temp_path's buffer is reused */
    snprintf(path, sizeof path, "%s", tu_write_file("clip_bad.json", json, strlen(json)));
    snprintf(out, sizeof out, "%s", tu_temp_path("bad.png"));
    static const struct {
        const char *set, *named;
    } cases[] = {
        {"clip.planes=[{\"origin\":[0,0,0],\"normal\":[0,0,0]}]", "clip.planes[0].normal"},
        {"clip.box={\"min\":[1,0,0],\"max\":[0,1,1]}", "clip.box"},
        {"clip.box.max=[0,1,\"a\"]", "clip.box.max"},
        {"clip.planes=[{\"normal\":[0,1,0]}]", "clip.planes[0]"},
        {"clip.planes=[" PLANE "," PLANE "," PLANE "," PLANE "," PLANE "," PLANE "," PLANE "]", "clip.planes"},
        {"clip.planes=[{\"origin\":[0,0],\"normal\":[0,1,0]}]", "clip.planes[0].origin"},
        {"clip.planes=[{\"origin\":[0,0,0],\"normal\":[0,1,0],\"side\":1}]", "clip.planes[0]"},
        {"clip.box.min=[nan,0,0]", "clip.box.min"},
        {"clip.boxx={}", "clip"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char args[2048];
        snprintf(args, sizeof args, "render '%s' --set '%s' -o '%s'", path, cases[i].set, out);
        const char *err;
        int rc = tu_run_cli(args, &err);
        printf("--set %s\n  -> %d: %s", cases[i].set, rc, err);
        assert_int_equal(rc, 2);
        if (!strstr(err, cases[i].named)) fail_msg("the message does not name %s: %s", cases[i].named, err);
        FILE *f = fopen(out, "rb");
        assert_null(f);
    }
}

static void dump_scene_round_trip(void **state) {
    (void)state;
    const char *json = scene_json("clip_all.raw", "{\"box\": " BOX ", \"planes\": [" PLANE "]}", "ea");
    char path[512], dump[512], args[1536]; /* tu_temp_path's buffer is reused */
    snprintf(path, sizeof path, "%s", tu_write_file("clip_rt.json", json, strlen(json)));
    snprintf(dump, sizeof dump, "%s", tu_temp_path("clip_dump.json"));
    snprintf(args, sizeof args, "render '%s' --set clip.box.min=[-19,-20,-20] --dump-scene '%s'", path, dump);
    const char *err;
    assert_int_equal(tu_run_cli(args, &err), 0);
    volux_context *ctx = tu_context(1);
    volux_scene *s;
    if (volux_scene_load(ctx, dump, NULL, 0, &s))
        fail_msg("dumped scene: %s", volux_context_error(ctx));
    const volux_clip_desc *c = volux_scene_clip(s);
    assert_int_equal(c->has_box, 1);
    assert_true(c->box_min[0] == -19 && c->box_max[0] == 5 && c->box_max[1] == 20);
    assert_int_equal(c->n_planes, 1);
    assert_true(c->planes[0].origin[1] == 3 && c->planes[0].normal[1] == 1);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(clip_equals_cut_volume),   cmocka_unit_test(clipped_slab_casts_no_shadow),
        cmocka_unit_test(clip_edit_equals_fresh),   cmocka_unit_test(malformed_clip_exits_2),
        cmocka_unit_test(dump_scene_round_trip),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
