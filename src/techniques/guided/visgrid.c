/* techniques/guided/visgrid.c — the 5-D visibility grid's storage and its
 * directions (§5): one position per `cell`³ voxels, N×N directions of an
 * equal-area octahedral map per position. */
#include <string.h>

#include "core/context_internal.h"
#include "guided.h"
#include "sample/octahedral.h"

volux_status guided_grid_alloc(volux_context *ctx, guided_grid *g, const volux_volume *v, const guided_vis_params *p) {
    int dims[3], cells[3];
    volux_volume_dims(v, dims);
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        cells[a] = (dims[a] - 1 + p->cell - 1) / p->cell;
        if (cells[a] < 1) cells[a] = 1;
        n *= (size_t)cells[a];
    }
    int dirs = p->dir_res * p->dir_res;
    size_t bytes, src_bytes = sizeof(int) * (size_t)dirs;
    if (!volux_mul_size(n, (size_t)dirs * sizeof(uint16_t), &bytes) || bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT,
                           "techniques.guided: a visibility grid of %dx%dx%d positions x %d directions exceeds the "
                           "memory cap (raise techniques.guided.cell or lower directions)",
                           cells[0], cells[1], cells[2], dirs);
    if (g->v && g->bytes == bytes && g->dirs == dirs && !memcmp(g->cells, cells, sizeof cells)) {
        for (int a = 0; a < 3; a++) g->cell_size[a] = (float)(dims[a] - 1) / (float)cells[a];
        for (int d = 0; d < dirs; d++) g->src[d] = -1;
        return VOLUX_OK;
    }
    guided_grid_free(ctx, g);
    if ((g->v = volux_alloc_aligned(ctx, bytes))) g->bytes = bytes;
    if ((g->src = volux_malloc(ctx, src_bytes))) g->src_bytes = src_bytes;
    if (!g->v || !g->src) {
        guided_grid_free(ctx, g);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for the visibility grid", bytes);
    }
    g->dirs = dirs;
    for (int a = 0; a < 3; a++) {
        g->cells[a] = cells[a];
        g->cell_size[a] = (float)(dims[a] - 1) / (float)cells[a];
    }
    for (int d = 0; d < dirs; d++) g->src[d] = -1;
    return VOLUX_OK;
}

void guided_grid_free(volux_context *ctx, guided_grid *g) {
    if (g->v) volux_free_aligned(ctx, g->v, g->bytes);
    volux_free(ctx, g->src, g->src_bytes);
    memset(g, 0, sizeof *g);
}

volux_vec3 guided_direction(int n, int d, int s, int su, int sv) {
    uint32_t x, y;
    volux_morton2_decode((uint32_t)d, &x, &y);
    float u = ((float)x + ((float)su + 0.5f) / (float)s) / (float)n;
    float v = ((float)y + ((float)sv + 0.5f) / (float)s) / (float)n;
    return volux_octa_to_dir(u, v);
}
