/*
 * techniques/dvr/dvr_corners.c — corner words: the SIMD kernel's
 * per-cell copy of an 8-bit volume in which one 64-bit word holds all
 * 8 trilinear corners of a cell (issue 19, item 3: fewer gathered
 * elements per sample).
 *
 * Why: in the bricked copy a u8 sample takes four 32-bit gathered
 * elements (one per (y, z) corner row) from two cache lines (the z and
 * z+1 rows are 81 nodes apart); from the corner words it takes one
 * 64-bit element from one line. bench/gather_cost_avx512.c on the Zen 4:
 * 4 × 0.39 ns against 0.45 ns per lane (docs/BENCHMARKS.md). On CPUs
 * whose gathers cost more per element (Zen 2/3, Intel with the GDS
 * microcode) the ratio only grows.
 *
 * Layout: the bricks of the volume's bricked copy (8³ cells), 512 words
 * per brick, cell (i, j, k) of a brick at (i&7) + 8·(j&7) + 64·(k&7);
 * byte n of a word is corner n in the order c000 c100 c010 c110 c001 c101
 * c011 c111 (x fastest), so the low 32 bits are the z row and the high 32
 * the z+1 row. Every byte is copied from the bricked copy's node that
 * the bricked gathers read, so the samples — and the images — are the
 * same bits (tests/invariants/test_ea_fastpath.c,
 * test_corner_words_are_bit_identical).
 *
 * Memory: 8 bytes per cell, 8× the data (128 MiB at 256³, against the
 * bricked copy's 1.42×); built only under `volume_layout: "corner_words"`
 * for 8-bit volumes rendered by the SIMD kernel, when it takes at most
 * DVR_CORNER_WORDS_MAX_BYTES and the context grants the allocation;
 * otherwise the kernel gathers from the bricked copy (same image).
 * Rebuilt on VOLUME only.
 *
 * NOT the default, because it measured SLOWER on the one CPU at hand (Zen
 * 4, bonsai 256³, 1 thread: step 0.5 +33 %, step 1 +27 %, step 2 +7 %,
 * step 4 +9 % with AVX-512, ±0–3 % with AVX2 at step 4): the copy is 8× the
 * cache footprint (128 MiB does not fit the 32 MiB L3 that the 23 MiB
 * bricked copy fits), and at fine steps neighbouring samples share far
 * fewer lines (8 cells per line against 64 nodes). Kept as an option to
 * measure on CPUs whose gathers cost several times more per element.
 */
#include <string.h>

#include "core/context_internal.h"
#include "dvr.h"

/* The cells of the volume's bricked copy, as corner words. */
static size_t corner_words_count(const volux_volume *v) {
    return (size_t)v->brick_counts[0] * (size_t)v->brick_counts[1] * (size_t)v->brick_counts[2] *
           (size_t)(VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS);
}

void volux_dvr_corner_words_free(dvr_state *st) {
    if (st->corners) volux_free_aligned(st->rc.ctx, st->corners, st->corner_bytes);
    st->corners = NULL;
    st->corner_bytes = 0;
}

static void fill_corner_words(uint64_t *out, const volux_volume *v) {
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    const size_t bricks = (size_t)v->brick_counts[0] * (size_t)v->brick_counts[1] * (size_t)v->brick_counts[2];
    const unsigned char *src = v->bricks;
    for (size_t b = 0; b < bricks; b++) {
        const unsigned char *brick = src + b * VOLUX_BRICK_VOXELS;
        uint64_t *w = out + b * (VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS);
        for (int k = 0; k < VOLUX_BRICK_CELLS; k++)
            for (int j = 0; j < VOLUX_BRICK_CELLS; j++)
                for (int i = 0; i < VOLUX_BRICK_CELLS; i++) {
                    const unsigned char *p = brick + i + SY * j + SZ * k;
                    const unsigned char c[8] = {p[0],  p[1],      p[SY],      p[SY + 1],
                                                p[SZ], p[SZ + 1], p[SZ + SY], p[SZ + SY + 1]};
                    uint64_t word = 0;
                    for (int n = 7; n >= 0; n--) word = word << 8 | c[n];
                    *w++ = word;
                }
    }
}

volux_status volux_dvr_corner_words_update(dvr_state *st, int volume_changed) {
    const volux_volume *v = st->rc.volume;
    const size_t bytes = corner_words_count(v) * sizeof(uint64_t);
    const int wanted = st->corner_words && st->use_simd && v->storage == VOLUX_STORE_U8 && v->bricks &&
                       bytes <= DVR_CORNER_WORDS_MAX_BYTES;
    if (!wanted) {
        volux_dvr_corner_words_free(st);
        return VOLUX_OK;
    }
    if (st->corners && !volume_changed && st->corner_bytes == bytes) return VOLUX_OK;
    volux_dvr_corner_words_free(st);
    uint64_t *w = volux_alloc_aligned(st->rc.ctx, bytes);
    if (!w) return VOLUX_OK; /* over the context's memory cap: the kernel reads the bricks (same image) */
    fill_corner_words(w, v);
    st->corners = w;
    st->corner_bytes = bytes;
    return VOLUX_OK;
}
