/*
 * bench/gather_cost_avx512.c — CPU time per gathered element on this CPU
 * (issue 19, item 3: is a layout with fewer gathered elements worth it?).
 * Independent 32-bit gathers of random indices into a 64 KiB table (L1/L2
 * resident, as the corner rows of neighbouring samples mostly are), 8 lanes
 * (AVX2) and 16 (AVX-512F, where present), against plain scalar loads.
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
    if (!table || !idx) return 1;
    for (int i = 0; i < TABLE; i++) table[i] = i;
    srand(1);
    for (int i = 0; i < INDICES; i++) idx[i] = rand() % TABLE;
    const double ns = 1e9 / ((double)REPEAT * INDICES);
    __builtin_cpu_init();
    for (int round = 0; round < 3; round++) {
        double a = __builtin_cpu_supports("avx2") ? gather8(table, idx) : 0.0;
        double b = __builtin_cpu_supports("avx512f") ? gather16(table, idx) : 0.0;
        double c = scalar_loads(table, idx);
        printf("CPU ns per element: 8-lane gather %.3f, 16-lane gather %.3f, scalar load %.3f\n", a * ns, b * ns,
               c * ns);
    }
    free(table);
    free(idx);
    return 0;
}
