/* core/parallel.c — OpenMP behind one function (STYLE §8). */
#include "parallel.h"

#ifdef _OPENMP
#include <omp.h>
#endif

int volux_parallel_max_threads(void) {
#ifdef _OPENMP
    return omp_get_num_procs();
#else
    return 1;
#endif
}

void volux_parallel_for(int threads, int64_t n, volux_parallel_fn fn, void *user) {
    if (threads <= 0) threads = volux_parallel_max_threads();
    if (threads == 1 || n <= 1) {
        for (int64_t i = 0; i < n; i++) fn(user, i, 0);
        return;
    }
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int64_t i = 0; i < n; i++) fn(user, i, omp_get_thread_num());
#else
    for (int64_t i = 0; i < n; i++) fn(user, i, 0);
#endif
}
