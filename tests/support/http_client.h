/*
 * tests/support/http_client.h — a minimal HTTP/1.1 client over loopback
 * sockets for the tests of `volux serve`, and a helper that starts the
 * server as a child process. Raw requests on purpose: the tests send
 * malformed, oversized and slow requests a real client library would not.
 */
#ifndef VOLUX_TEST_HTTP_CLIENT_H
#define VOLUX_TEST_HTTP_CLIENT_H

#include <stddef.h>
#include <sys/types.h>

typedef struct tu_server {
    pid_t pid;
    int port;
} tu_server;

/* Starts `volux serve ARGS --port 0` (ARGS shell-quoted) and waits for the
 * URL line on its stdout. Returns 1 on success. */
int tu_server_start(tu_server *s, const char *args);
/* Writes `scene_json` to FOLDER/scene.json in the test's temp folder
 * (path in scene_path, cap bytes) and starts the server on it with the
 * options the HTTP tests share: --quiet --timeout 2 --idle-ms 0
 * --preview 32. Returns 1 on success. */
int tu_server_start_scene(tu_server *s, const char *folder, const char *scene_json, char *scene_path, size_t cap);
/* SIGTERM, then waits; returns the exit status (or -1). */
int tu_server_stop(tu_server *s);
/* 1 while the process runs. */
int tu_server_alive(const tu_server *s);

typedef struct tu_reply {
    int status;      /* 0: no valid response (connection closed early) */
    char *head;      /* status line + headers, NUL-terminated          */
    char *body;      /* NUL-terminated (binary bodies: use body_len)   */
    size_t body_len;
} tu_reply;

/* Connects to 127.0.0.1:port, sends `n` raw bytes, reads until the server
 * closes (requests should say "Connection: close") or `timeout_ms`
 * passes. */
int tu_http_raw(int port, const void *req, size_t n, int timeout_ms, tu_reply *out);
/* METHOD PATH with optional extra header lines ("K: V\r\n"...) and body
 * (sent as application/json unless the headers give a type). */
int tu_http(int port, const char *method, const char *path, const char *headers, const char *body, tu_reply *out);
void tu_reply_free(tu_reply *r);
/* Value of a response header (static buffer), NULL if absent. */
const char *tu_reply_header(const tu_reply *r, const char *name);
/* Connected socket to 127.0.0.1:port or -1. */
int tu_connect(int port);

#endif
