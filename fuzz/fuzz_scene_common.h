/*
 * fuzz/fuzz_scene_common.h — shared by the scene, override and preset harnesses.
 *
 * One context per process, with a small memory cap so no input can ask for
 * a large volume (procedural dims are capped by max_bytes: 64 KiB is 40³
 * uint8 voxels) and each run stays fast. After every input nothing may be
 * left allocated through the context: a leak on an error path aborts.
 */
#ifndef VOLUX_FUZZ_SCENE_COMMON_H
#define VOLUX_FUZZ_SCENE_COMMON_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/scene_formats.h"
#include "volux/technique.h"

#define FUZZ_MAX_BYTES (64u << 10)

static inline volux_context *fuzz_context(void) {
    static volux_context *ctx;
    if (!ctx) {
        volux_context_desc d = {0};
        d.threads = 1;
        d.max_bytes = FUZZ_MAX_BYTES;
        if (volux_context_create(&d, &ctx) != VOLUX_OK) abort();
    }
    volux_context_clear_error(ctx);
    return ctx;
}

static inline void fuzz_check_no_leak(volux_context *ctx) {
    if (volux_context_bytes_in_use(ctx) != 0) {
        fprintf(stderr, "fuzz: %llu bytes left allocated through the context (last error: %s)\n",
                (unsigned long long)volux_context_bytes_in_use(ctx), volux_context_error(ctx));
        abort();
    }
}

/* DESIGN §4: every error names the file. A failure must leave a message
 * that starts with the name the input was given. */
static inline void fuzz_check_failure(volux_context *ctx, volux_status st, const char *name) {
    const char *msg = volux_context_error(ctx);
    size_t n = strlen(name);
    if (st == VOLUX_ERR_INTERNAL || strncmp(msg, name, n) != 0 || msg[n] != ':') {
        fprintf(stderr, "fuzz: status %s with message \"%s\" (must start with \"%s:\")\n", volux_status_name(st),
                msg, name);
        abort();
    }
}

/* What a renderer does first with a loaded scene: bake the TF over the
 * volume's range, resolve the camera, check technique parameters. Errors
 * are fine; crashes, UB and non-finite LUT entries are not. */
static inline void fuzz_use_scene(volux_context *ctx, volux_scene *s) {
    const volux_transfer_lut *lut = volux_scene_transfer_lut(s);
    if (lut && !(lut->sigma_t_max >= 0.0f)) {
        fprintf(stderr, "fuzz: LUT sigma_t_max is %g\n", lut->sigma_t_max);
        abort();
    }
    /* The loader promises a finite view for the loaded volume. */
    volux_camera cam;
    if (volux_scene_camera(s, &cam) != VOLUX_OK) {
        fprintf(stderr, "fuzz: loaded scene has no valid camera: %s\n", volux_context_error(ctx));
        abort();
    }
    float sum = cam.eye.x + cam.eye.y + cam.eye.z + cam.forward.x + cam.forward.y + cam.forward.z + cam.right.x +
                cam.right.y + cam.right.z + cam.up.x + cam.up.y + cam.up.z + cam.tan_half_fov + cam.half_height;
    if (!isfinite(sum)) {
        fprintf(stderr, "fuzz: loaded scene has a non-finite camera\n");
        abort();
    }
    (void)volux_scene_step_world(s);
    (void)volux_technique_validate_params(ctx, s);
}

#endif
