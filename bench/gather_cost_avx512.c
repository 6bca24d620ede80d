/*
 * bench/gather_cost_avx512.c — CPU time per gathered element on this CPU
 * (issue 19, item 3: is a layout with fewer gathered elements worth it?).
 * Independent 32-bit gathers of random indices into a 64 KiB table (L1/L2
 * resident, as the corner rows of neighbouring samples mostly are), 8 lanes
 * (AVX2) and 16 (AVX-512F, where present), against plain scalar loads;
 * and 64-bit gathers (4 lanes AVX2, 8 lanes AVX-512), the element of a
 * corner-packed layout (one 64-bit word = a u8 cell's 8 corners). Printed
 * per element and per lane of a sample (a u8 sample needs four 32-bit
 * elements in the bricked layout, one 64-bit element in the packed one).
 * Stand-alone, not part of the build:
 *
 *   cc -O2 -o /tmp/gather_cost bench/gather_cost_avx512.c && /tmp/gather_cost
 */
#include <immintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

enum { TABLE = 1 << 14, INDICES = 4096, REPEAT = 20000 };

static double cpu_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* four independent chains, so the gathers' latency overlaps */
__attribute__((target("avx2"))) static double gather8(const int *table, const int *idx) {
    __m256i acc[4] = {_mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256()};
    double t0 = cpu_s();
    for (int r = 0; r < REPEAT; r++)
        for (int i = 0; i < INDICES; i += 32)
            for (int c = 0; c < 4; c++)
                acc[c] = _mm256_add_epi32(
                    acc[c], _mm256_i32gather_epi32(table, _mm256_loadu_si256((const void *)(idx + i + 8 * c)), 4));
    double t = cpu_s() - t0;
    volatile int sink = _mm256_extract_epi32(_mm256_add_epi32(_mm256_add_epi32(acc[0], acc[1]), acc[2]), 0);
    (void)sink;
    return t;
}

__attribute__((target("avx512f"))) static double gather16(const int *table, const int *idx) {
    __m512i acc[2] = {_mm512_setzero_si512(), _mm512_setzero_si512()};
    double t0 = cpu_s();
    for (int r = 0; r < REPEAT; r++)
        for (int i = 0; i < INDICES; i += 32)
            for (int c = 0; c < 2; c++)
                acc[c] = _mm512_add_epi32(acc[c], _mm512_i32gather_epi32(_mm512_loadu_si512(idx + i + 16 * c), table, 4));
    double t = cpu_s() - t0;
    volatile int sink = _mm512_reduce_add_epi32(_mm512_add_epi32(acc[0], acc[1]));
    (void)sink;
    return t;
}

/* 64-bit elements at 32-bit indices: 4 per AVX2 gather, 8 per AVX-512 one */
__attribute__((target("avx2"))) static double gather4q(const long long *table, const int *idx) {
    __m256i acc[4] = {_mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256(), _mm256_setzero_si256()};
    double t0 = cpu_s();
    for (int r = 0; r < REPEAT; r++)
        for (int i = 0; i < INDICES; i += 16)
            for (int c = 0; c < 4; c++)
                acc[c] = _mm256_add_epi64(
                    acc[c], _mm256_i32gather_epi64(table, _mm_loadu_si128((const void *)(idx + i + 4 * c)), 8));
    double t = cpu_s() - t0;
    volatile long long sink = _mm256_extract_epi64(_mm256_add_epi64(_mm256_add_epi64(acc[0], acc[1]), acc[2]), 0);
    (void)sink;
    return t;
}

__attribute__((target("avx512f"))) static double gather8q(const long long *table, const int *idx) {
    __m512i acc[4] = {_mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512(), _mm512_setzero_si512()};
    double t0 = cpu_s();
    for (int r = 0; r < REPEAT; r++)
        for (int i = 0; i < INDICES; i += 32)
            for (int c = 0; c < 4; c++)
                acc[c] = _mm512_add_epi64(
                    acc[c], _mm512_i32gather_epi64(_mm256_loadu_si256((const void *)(idx + i + 8 * c)), table, 8));
    double t = cpu_s() - t0;
    volatile long long sink = _mm512_reduce_add_epi64(_mm512_add_epi64(acc[0], acc[3]));
    (void)sink;
    return t;
}

static double scalar_loads(const int *table, const int *idx) {
    unsigned sum = 0;
    double t0 = cpu_s();
    for (int r = 0; r < REPEAT; r++)
        for (int i = 0; i < INDICES; i++) sum += (unsigned)table[idx[i]];
    double t = cpu_s() - t0;
    volatile unsigned sink = sum;
    (void)sink;
    return t;
}

int main(void) {
    int *table = aligned_alloc(64, TABLE * sizeof(int)), *idx = aligned_alloc(64, INDICES * sizeof(int));
    long long *qtable = aligned_alloc(64, TABLE / 2 * sizeof(long long));
    if (!table || !idx || !qtable) return 1;
    for (int i = 0; i < TABLE; i++) table[i] = i;
    for (int i = 0; i < TABLE / 2; i++) qtable[i] = i;
    srand(1);
    for (int i = 0; i < INDICES; i++) idx[i] = rand() % TABLE;
    const double ns = 1e9 / ((double)REPEAT * INDICES);
    __builtin_cpu_init();
    for (int round = 0; round < 3; round++) {
        double a = __builtin_cpu_supports("avx2") ? gather8(table, idx) : 0.0;
        double b = __builtin_cpu_supports("avx512f") ? gather16(table, idx) : 0.0;
        double c = scalar_loads(table, idx);
        /* the 64-bit runs index a table of half as many (same 64 KiB) */
        for (int i = 0; i < INDICES; i++) idx[i] >>= 1;
        double d = __builtin_cpu_supports("avx2") ? gather4q(qtable, idx) : 0.0;
        double e = __builtin_cpu_supports("avx512f") ? gather8q(qtable, idx) : 0.0;
        for (int i = 0; i < INDICES; i++) idx[i] = rand() % TABLE;
        printf("CPU ns per element: 32-bit x8 %.3f, x16 %.3f, scalar %.3f; 64-bit x4 %.3f, x8 %.3f | "
               "per u8 sample (4 x 32-bit vs 1 x 64-bit): AVX2 %.2f vs %.2f, AVX-512 %.2f vs %.2f\n",
               a * ns, b * ns, c * ns, d * ns, e * ns, 4 * a * ns, d * ns, 4 * b * ns, e * ns);
    }
    free(qtable);
    free(table);
    free(idx);
    return 0;
}
