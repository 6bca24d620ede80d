/*
 * tests/robustness/test_viewer_soak.c — a bounded soak of `volux serve` on
 * loopback: N clients send M edits each (light, TF, camera and technique
 * parameter edits, with a bad edit every tenth), one client reads the
 * event stream throughout, another polls /api/stats. Every request must be
 * answered (good edits 200, bad ones 400), the open descriptors must come
 * back to where they were, and the resident set must stay flat after the
 * warm-up (growth under 20 %: a leak per edit would show; not under ASan,
 * whose quarantine grows RSS — LeakSanitizer checks the server's exit
 * instead). Prints the edit latencies (p50/p99) and the RSS/fd figures.
 *
 * Default: 4 clients × 25 edits; with --slow (ctest label `slow`, skipped
 * under ASan): 4 × 250 = 1000 edits, the soak.
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <dirent.h>

#include "http_client.h"
#include "test_util.h"

static int slow_mode;
static tu_server server;

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static long rss_kb(pid_t pid) {
    char p[64], line[256];
    snprintf(p, sizeof p, "/proc/%d/status", (int)pid);
    FILE *f = fopen(p, "r");
    long kb = -1;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "VmRSS:", 6)) kb = atol(line + 6);
    if (f) fclose(f);
    return kb;
}

static int open_fds(pid_t pid) {
    char p[64];
    snprintf(p, sizeof p, "/proc/%d/fd", (int)pid);
    DIR *d = opendir(p);
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        if (e->d_name[0] != '.') n++;
    closedir(d);
    return n;
}

typedef struct client {
    int id, edits, ok, bad_ok, failed;
    double *lat;
} client;

static void *edit_client(void *arg) {
    client *c = arg;
    for (int i = 0; i < c->edits; i++) {
        char body[256];
        int bad = i % 10 == 9;
        switch (bad ? 4 : i % 4) {
        case 0: snprintf(body, sizeof body, "[{\"path\":\"lights.0.irradiance\",\"value\":%.3f}]", 0.5 + (i % 7) * 0.2); break;
        case 1:
            snprintf(body, sizeof body, "[{\"path\":\"transfer_function.opacity\",\"value\":[[0,0],[60,%.3f],[255,0.8]]}]",
                     0.02 + (i % 5) * 0.01);
            break;
        case 2: snprintf(body, sizeof body, "[{\"path\":\"camera.orbit.azimuth\",\"value\":%d}]", (c->id * 37 + i * 5) % 360); break;
        case 3: snprintf(body, sizeof body, "[{\"path\":\"transfer_function.anisotropy\",\"value\":%.2f}]", (i % 9) * 0.1 - 0.4); break;
        default: snprintf(body, sizeof body, "[{\"path\":\"lights.0.irradiance\",\"value\":-%d}]", i); break;
        }
        double t0 = now_ms();
        tu_reply r;
        int got = tu_http(server.port, "POST", "/api/edit", NULL, body, &r);
        c->lat[i] = now_ms() - t0;
        if (got && r.status == (bad ? 400 : 200)) bad ? c->bad_ok++ : c->ok++;
        else c->failed++;
        tu_reply_free(&r);
    }
    return NULL;
}

static volatile int stop_readers;

static void *stream_reader(void *arg) {
    long *bytes = arg;
    int fd = tu_connect(server.port);
    if (fd < 0) return NULL;
    const char *req = "GET /api/events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
    send(fd, req, strlen(req), MSG_NOSIGNAL);
    struct timeval tv = {1, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    char buf[65536];
    while (!stop_readers) {
        ssize_t n = recv(fd, buf, sizeof buf, 0);
        if (n == 0) break;
        if (n > 0) *bytes += n;
    }
    close(fd);
    return NULL;
}

static void *stats_poller(void *arg) {
    int *failed = arg;
    while (!stop_readers) {
        tu_reply r;
        if (!tu_http(server.port, "GET", "/api/stats", NULL, NULL, &r) || r.status != 200) ++*failed;
        tu_reply_free(&r);
        usleep(100000);
    }
    return NULL;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

typedef struct soak_result {
    int total, ok, bad_ok, failed;
    double wall_ms, p50, p99, max;
} soak_result;

/* n_clients editors in parallel, `edits` each; latencies sorted. */
static soak_result run_clients(int n_clients, int edits) {
    pthread_t t[16];
    client c[16];
    soak_result res = {n_clients * edits, 0, 0, 0, 0, 0, 0, 0};
    double t0 = now_ms();
    for (int i = 0; i < n_clients; i++) {
        c[i] = (client){i, edits, 0, 0, 0, calloc((size_t)edits, sizeof(double))};
        pthread_create(&t[i], NULL, edit_client, &c[i]);
    }
    for (int i = 0; i < n_clients; i++) pthread_join(t[i], NULL);
    res.wall_ms = now_ms() - t0;
    double *all = calloc((size_t)res.total, sizeof(double));
    for (int i = 0; i < n_clients; i++) {
        res.ok += c[i].ok;
        res.bad_ok += c[i].bad_ok;
        res.failed += c[i].failed;
        memcpy(all + (size_t)i * (size_t)edits, c[i].lat, sizeof(double) * (size_t)edits);
        free(c[i].lat);
    }
    qsort(all, (size_t)res.total, sizeof(double), cmp_double);
    res.p50 = all[res.total / 2];
    res.p99 = all[(int)(res.total * 0.99)];
    res.max = all[res.total - 1];
    free(all);
    return res;
}

static void run_soak(int n_clients, int edits) {
    /* warm-up: the first frames, caches, thread stacks */
    for (int i = 0; i < 20; i++) {
        tu_reply r;
        char body[128];
        snprintf(body, sizeof body, "[{\"path\":\"lights.0.irradiance\",\"value\":%d}]", 1 + i % 3);
        assert_true(tu_http(server.port, "POST", "/api/edit", NULL, body, &r));
        assert_int_equal(r.status, 200);
        tu_reply_free(&r);
    }
    usleep(500000);
    int fds0 = open_fds(server.pid);
    long rss0 = rss_kb(server.pid);
    long stream_bytes = 0;
    int stats_failed = 0;
    pthread_t reader, poller;
    stop_readers = 0;
    pthread_create(&reader, NULL, stream_reader, &stream_bytes);
    pthread_create(&poller, NULL, stats_poller, &stats_failed);
    /* A concurrent warm-up (a tenth of the run): the connection threads'
     * stacks and malloc arenas settle at what concurrency needs; growth
     * after this point is what a leak per edit would look like. */
    soak_result warm = run_clients(n_clients, edits / 10 > 5 ? edits / 10 : 5);
    long rss_warm = rss_kb(server.pid);
    soak_result run = run_clients(n_clients, edits);
    stop_readers = 1;
    pthread_join(reader, NULL);
    pthread_join(poller, NULL);
    /* The connections close and the last frames finish; a stream notices
     * its closed socket at its next keep-alive write (every 4 s). */
    int fds1 = -1;
    for (int k = 0; k < 100 && (fds1 = open_fds(server.pid)) != fds0; k++) usleep(100000);
    long rss1 = rss_kb(server.pid);
    printf("soak: %d clients x %d edits = %d in %.1f s (%d applied, %d bad ones refused, %d failed); "
           "edit request latency p50 %.1f ms, p99 %.1f ms, max %.1f ms; event stream %ld bytes; "
           "stats polls failed %d; RSS %ld kB at start, %ld kB after the concurrent warm-up (%d edits), "
           "%ld kB at the end (%+.1f %% over the run, %+.1f %% from the start); fds %d -> %d\n",
           n_clients, edits, run.total, run.wall_ms / 1e3, run.ok, run.bad_ok, run.failed, run.p50, run.p99, run.max,
           stream_bytes, stats_failed, rss0, rss_warm, warm.total, rss1,
           100.0 * (double)(rss1 - rss_warm) / (double)rss_warm, 100.0 * (double)(rss1 - rss0) / (double)rss0, fds0,
           fds1);
    assert_int_equal(warm.failed, 0);
    assert_int_equal(run.failed, 0);
    assert_int_equal(run.ok + run.bad_ok, run.total);
    assert_int_equal(stats_failed, 0);
    assert_true(stream_bytes > 0);
    assert_int_equal(fds1, fds0);
#ifndef __SANITIZE_ADDRESS__
    assert_true((double)rss1 < 1.20 * (double)rss_warm);
#else
    /* ASan keeps freed blocks in its quarantine (up to 256 MiB), so RSS
     * grows without a leak; its LeakSanitizer checks the server at exit
     * instead (tu_server_stop must see status 0). */
#endif
    assert_true(tu_server_alive(&server));
}

static void test_soak(void **state) {
    (void)state;
    char dir[600], path[700], args[800];
    snprintf(dir, sizeof dir, "%s", tu_temp_path("soak"));
    mkdir(dir, 0755);
    snprintf(path, sizeof path, "%s/scene.json", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("{\"volume\": {\"procedural\": \"phantom\", \"dims\": [48, 48, 48]},"
          " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [255, 0.8]]},"
          " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -1, -1]}],"
          " \"render\": {\"technique\": \"shaded\", \"width\": 96, \"height\": 96, \"spp\": 2}}",
          f);
    fclose(f);
    snprintf(args, sizeof args, "'%s' --quiet --idle-ms 20 --preview 64", path);
    assert_true(tu_server_start(&server, args));
    run_soak(4, slow_mode ? 250 : 25);
    assert_int_equal(tu_server_stop(&server), 0);
}

/* Runs after a failed assertion too: no server outlives the test. */
static int stop_server(void **state) {
    (void)state;
    if (server.pid > 0) tu_server_stop(&server);
    return 0;
}

int main(int argc, char **argv) {
    slow_mode = argc > 1 && !strcmp(argv[1], "--slow");
    const struct CMUnitTest tests[] = {cmocka_unit_test_teardown(test_soak, stop_server)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
