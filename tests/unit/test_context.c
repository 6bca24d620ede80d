/*
 * tests/unit/test_context.c — the context's cache folder option: the
 * default from the environment (XDG Base Directory spec), explicit
 * folders, "" for none, copies, and that its storage is not counted as
 * object memory.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

static volux_context *create(const char *cache_dir) {
    volux_context_desc d = {0};
    d.threads = 1;
    d.cache_dir = cache_dir;
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    return ctx;
}

static void test_default_cache_dir_follows_xdg_then_home(void **state) {
    (void)state;
    setenv("XDG_CACHE_HOME", "/xdg/cache", 1);
    setenv("HOME", "/home/someone", 1);
    volux_context *a = create(NULL);
    assert_string_equal(volux_context_cache_dir(a), "/xdg/cache/volux");
    setenv("XDG_CACHE_HOME", "", 1); /* empty counts as unset */
    volux_context *b = create(NULL);
    assert_string_equal(volux_context_cache_dir(b), "/home/someone/.cache/volux");
    /* resolved at creation: a later environment does not move a context */
    assert_string_equal(volux_context_cache_dir(a), "/xdg/cache/volux");
    unsetenv("XDG_CACHE_HOME");
    unsetenv("HOME");
    volux_context *c = create(NULL);
    assert_string_equal(volux_context_cache_dir(c), ""); /* nowhere to go: no disk cache */
    /* set(NULL) reads the environment again */
    setenv("HOME", "/h2", 1);
    assert_int_equal(volux_context_set_cache_dir(c, NULL), VOLUX_OK);
    assert_string_equal(volux_context_cache_dir(c), "/h2/.cache/volux");
    volux_context_destroy(a);
    volux_context_destroy(b);
    volux_context_destroy(c);
    /* volux_context_create(NULL, ...) takes the default as well */
    volux_context *e;
    assert_int_equal(volux_context_create(NULL, &e), VOLUX_OK);
    assert_string_equal(volux_context_cache_dir(e), "/h2/.cache/volux");
    volux_context_destroy(e);
}

static void test_explicit_cache_dir_is_copied(void **state) {
    (void)state;
    char dir[64];
    snprintf(dir, sizeof dir, "/some/where");
    volux_context *ctx = create(dir);
    dir[1] = 'X';
    assert_string_equal(volux_context_cache_dir(ctx), "/some/where");
    assert_int_equal(volux_context_set_cache_dir(ctx, dir), VOLUX_OK);
    dir[1] = 'Y';
    assert_string_equal(volux_context_cache_dir(ctx), "/Xome/where");
    assert_int_equal(volux_context_set_cache_dir(ctx, ""), VOLUX_OK);
    assert_string_equal(volux_context_cache_dir(ctx), "");
    volux_context_destroy(ctx);
    ctx = create("");
    assert_string_equal(volux_context_cache_dir(ctx), "");
    volux_context_destroy(ctx);
}

/* The context's own storage is not object memory: a fresh context reports
 * zero bytes in use (leak checks rely on it), whatever its folder. */
static void test_cache_dir_is_not_counted_as_object_memory(void **state) {
    (void)state;
    volux_context *ctx = create("/a/rather/long/cache/folder/name");
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    assert_int_equal(volux_context_set_cache_dir(ctx, "/b"), VOLUX_OK);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

typedef struct counting {
    long allocs, frees, fail_at; /* fail the fail_at-th allocation (0 = never) */
} counting;

static void *counting_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    counting *c = user;
    (void)old_size;
    if (new_size == 0) {
        if (ptr) c->frees++;
        free(ptr);
        return NULL;
    }
    if (!ptr && ++c->allocs == c->fail_at) return NULL;
    return realloc(ptr, new_size);
}

/* The folder name goes through the context's allocator, is freed with the
 * context, and running out of memory for it is a clean NOMEM. */
static void test_cache_dir_uses_the_context_allocator(void **state) {
    (void)state;
    counting c = {0, 0, 0};
    volux_context_desc d = {0};
    d.alloc = counting_alloc;
    d.alloc_user = &c;
    d.cache_dir = "/x";
    volux_context *ctx;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    assert_int_equal(c.allocs, 2); /* the context and its folder name */
    assert_int_equal(volux_context_set_cache_dir(ctx, "/y"), VOLUX_OK);
    c.fail_at = c.allocs + 1;
    assert_int_equal(volux_context_set_cache_dir(ctx, "/z"), VOLUX_ERR_NOMEM);
    assert_string_equal(volux_context_cache_dir(ctx), "/y"); /* kept */
    volux_context_destroy(ctx);
    assert_int_equal(c.allocs - 1, c.frees); /* everything but the failed one freed */
    c = (counting){0, 0, 2};
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_ERR_NOMEM);
    assert_int_equal(c.frees, 1); /* the context itself, released */
}

/* A failure that follows from an earlier one must not hide it: the first
 * error is kept until the caller clears it; the library never clears. */
static void test_the_first_error_wins_until_cleared(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
    l.intensity = -1;
    assert_int_equal(volux_scene_set_light(s, 3, &l), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "lights[3].intensity"));
    /* a second, different failure: status returned, first message kept */
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "no-such-technique", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "lights[3].intensity"));
    assert_int_equal(volux_context_error_status(ctx), VOLUX_ERR_INVALID);
    /* successful calls leave it alone too */
    volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
    assert_int_equal(volux_scene_set_light(s, 3, &l), VOLUX_OK);
    assert_non_null(strstr(volux_context_error(ctx), "lights[3].intensity"));
    volux_context_clear_error(ctx);
    assert_string_equal(volux_context_error(ctx), "");
    assert_int_equal(volux_context_error_status(ctx), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "no-such-technique", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "no-such-technique"));
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_the_first_error_wins_until_cleared),
        cmocka_unit_test(test_default_cache_dir_follows_xdg_then_home),
        cmocka_unit_test(test_explicit_cache_dir_is_copied),
        cmocka_unit_test(test_cache_dir_is_not_counted_as_object_memory),
        cmocka_unit_test(test_cache_dir_uses_the_context_allocator),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
