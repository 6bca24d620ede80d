/* tests/support/http_client.c — see http_client.h. */
#include "http_client.h"
#include "test_util.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef VOLUX_CLI
#define VOLUX_CLI "volux"
#endif

int tu_server_start_scene(tu_server *s, const char *folder, const char *scene_json, char *scene_path, size_t cap) {
    const char *dir = tu_temp_path(folder);
    mkdir(dir, 0755);
    if ((size_t)snprintf(scene_path, cap, "%s/scene.json", dir) >= cap) return 0;
    FILE *f = fopen(scene_path, "w");
    if (!f) return 0;
    fputs(scene_json, f);
    fclose(f);
    char args[1400];
    snprintf(args, sizeof args, "'%s' --quiet --timeout 2 --idle-ms 0 --preview 32", scene_path);
    return tu_server_start(s, args);
}

int tu_server_start(tu_server *s, const char *args) {
    int fd[2];
    if (pipe(fd)) return 0;
    pid_t parent = getpid();
    pid_t pid = fork();
    if (pid < 0) return 0;
    if (pid == 0) {
        /* A test that fails an assertion never reaches tu_server_stop: the
         * server must not outlive it (it would hold ctest's output pipe
         * open and the test would hang until its timeout). */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() != parent) _exit(127);
        dup2(fd[1], 1);
        close(fd[0]);
        close(fd[1]);
        char cmd[4096];
        snprintf(cmd, sizeof cmd, "exec '%s' serve %s --port 0", VOLUX_CLI, args);
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    close(fd[1]);
    /* The server prints "volux serve: http://127.0.0.1:PORT/..." */
    char line[512];
    size_t n = 0;
    s->pid = pid;
    s->port = 0;
    for (;;) {
        struct pollfd p = {fd[0], POLLIN, 0};
        if (poll(&p, 1, 60000) <= 0) break;
        ssize_t got = read(fd[0], line + n, sizeof line - 1 - n);
        if (got <= 0) break;
        n += (size_t)got;
        line[n] = 0;
        const char *at = strstr(line, "127.0.0.1:");
        if (at && strchr(at, '\n')) {
            s->port = atoi(at + 10);
            break;
        }
        if (n >= sizeof line - 1) break;
    }
    close(fd[0]);
    if (!s->port) {
        kill(pid, SIGKILL);
        waitpid(pid, NULL, 0);
        return 0;
    }
    return 1;
}

int tu_server_alive(const tu_server *s) { return s->pid > 0 && kill(s->pid, 0) == 0 && waitpid(s->pid, NULL, WNOHANG) == 0; }

int tu_server_stop(tu_server *s) {
    if (s->pid <= 0) return -1;
    kill(s->pid, SIGTERM);
    int status = 0;
    for (int i = 0; i < 600; i++) { /* up to 60 s: ASan builds stop slowly */
        pid_t r = waitpid(s->pid, &status, WNOHANG);
        if (r == s->pid) break;
        if (r < 0) return -1;
        struct timespec ts = {0, 100000000};
        nanosleep(&ts, NULL);
        if (i == 599) {
            kill(s->pid, SIGKILL);
            waitpid(s->pid, &status, 0);
            s->pid = 0;
            return -1;
        }
    }
    s->pid = 0;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int tu_connect(int port) {
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return -1;
    struct sockaddr_in a = {0};
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, (struct sockaddr *)&a, sizeof a)) {
        close(fd);
        return -1;
    }
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

int tu_http_raw(int port, const void *req, size_t n, int timeout_ms, tu_reply *out) {
    memset(out, 0, sizeof *out);
    int fd = tu_connect(port);
    if (fd < 0) return 0;
    const char *p = req;
    size_t sent = 0;
    while (sent < n) {
        ssize_t w = send(fd, p + sent, n - sent, MSG_NOSIGNAL);
        if (w <= 0) break; /* the server may answer (and close) before reading it all */
        sent += (size_t)w;
    }
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap + 1);
    double end = now_ms() + timeout_ms;
    for (;;) {
        double left = end - now_ms();
        if (left <= 0) break;
        struct pollfd pf = {fd, POLLIN, 0};
        if (poll(&pf, 1, (int)left) <= 0) break;
        if (len == cap) {
            cap *= 2;
            buf = realloc(buf, cap + 1);
        }
        ssize_t got = recv(fd, buf + len, cap - len, 0);
        if (got <= 0) break;
        len += (size_t)got;
    }
    close(fd);
    buf[len] = 0;
    char *sep = strstr(buf, "\r\n\r\n");
    if (!sep || strncmp(buf, "HTTP/1.", 7)) {
        out->head = buf;
        out->body = strdup("");
        return 1;
    }
    out->status = atoi(buf + 9);
    size_t hl = (size_t)(sep - buf);
    out->head = malloc(hl + 1);
    memcpy(out->head, buf, hl);
    out->head[hl] = 0;
    out->body_len = len - hl - 4;
    out->body = malloc(out->body_len + 1);
    memcpy(out->body, sep + 4, out->body_len);
    out->body[out->body_len] = 0;
    free(buf);
    return 1;
}

int tu_http(int port, const char *method, const char *path, const char *headers, const char *body, tu_reply *out) {
    size_t bl = body ? strlen(body) : 0;
    size_t n = 512 + strlen(path) + (headers ? strlen(headers) : 0) + bl;
    char *req = malloc(n);
    int has_type = headers && (strstr(headers, "Content-Type:") || strstr(headers, "content-type:"));
    int w = snprintf(req, n, "%s %s HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n%s%s", method, path, port,
                     headers ? headers : "", body && !has_type ? "Content-Type: application/json\r\n" : "");
    if (body) w += snprintf(req + w, n - (size_t)w, "Content-Length: %zu\r\n", bl);
    w += snprintf(req + w, n - (size_t)w, "\r\n");
    if (body) {
        memcpy(req + w, body, bl);
        w += (int)bl;
    }
    int ok = tu_http_raw(port, req, (size_t)w, 120000, out);
    free(req);
    return ok;
}

void tu_reply_free(tu_reply *r) {
    free(r->head);
    free(r->body);
    memset(r, 0, sizeof *r);
}

const char *tu_reply_header(const tu_reply *r, const char *name) {
    static char value[512];
    if (!r->head) return NULL;
    size_t nl = strlen(name);
    for (const char *line = strstr(r->head, "\r\n"); line; line = strstr(line + 2, "\r\n")) {
        const char *l = line + 2;
        if (!strncasecmp(l, name, nl) && l[nl] == ':') {
            l += nl + 1;
            while (*l == ' ') l++;
            size_t k = strcspn(l, "\r\n");
            if (k >= sizeof value) k = sizeof value - 1;
            memcpy(value, l, k);
            value[k] = 0;
            return value;
        }
    }
    return NULL;
}
