/*
 * tests/robustness/test_scene_malformed.c — malformed scene files: each is
 * rejected with the right status and a message naming the file and the key
 * path, nothing allocated through the context leaks (also on every failed
 * allocation), and the CLI exits with status 2 without writing an image.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/scene_formats.h"
#include "test_util.h"
#include "volux/edit.h"

#define assert_contains(hay, needle)                                                                   \
    do {                                                                                               \
        const char *h_ = (hay), *n_ = (needle);                                                        \
        if (!strstr(h_, n_)) fail_msg("expected \"%s\" in \"%s\"", n_, h_);                           \
    } while (0)

/* Pieces of a valid scene the cases below vary. */
#define VOL "\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]}"
#define TF "\"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]}"
#define SCENE(rest) "{" VOL ", " TF rest "}"
#define SCENE_TF(tf) "{" VOL ", \"transfer_function\": " tf "}"
#define SCENE_VOL(vol) "{\"volume\": " vol ", " TF "}"
#define LIGHTS(list) SCENE(", \"lights\": " list)

typedef struct malformed {
    const char *json;
    volux_status status;
    const char *part; /* substring of the message: the key path */
} malformed;

static const malformed CASES[] = {
    /* syntax */
    {"", VOLUX_ERR_FORMAT, "invalid JSON at line 1, column 1"},
    {"{\"volume\": }", VOLUX_ERR_FORMAT, "invalid JSON at line 1, column 12"},
    {"{\n\"volume\": {\n\"dims\": [1,]}}", VOLUX_ERR_FORMAT, "invalid JSON at line 3"},
    {SCENE("") " {}", VOLUX_ERR_FORMAT, "unexpected text after the JSON value"},
    {SCENE("") "]", VOLUX_ERR_FORMAT, "unexpected text after the JSON value"},
    {"[]", VOLUX_ERR_INVALID, "the scene must be a JSON object"},
    {"\"scene\"", VOLUX_ERR_INVALID, "the scene must be a JSON object"},
    {"{\"render\\u0000x\": {}}", VOLUX_ERR_FORMAT, "\\u0000 (NUL) in a string at line 1, column 9"},
    {SCENE_VOL("{\"procedural\": \"sphere\\u0000.png\"}"), VOLUX_ERR_FORMAT, "\\u0000"},
    /* a literal backslash followed by u0000 is fine text; the key is unknown */
    {"{\"a\\\\u0000\": 1}", VOLUX_ERR_INVALID, "a\\u0000: unknown key"},
    /* what RFC 8259 forbids and cJSON accepts (issue 16) */
    {SCENE(", \"render\": {\"width\": 064}"), VOLUX_ERR_FORMAT, "invalid number at line 1"},
    {SCENE(", \"render\": {\"width\": +64}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"render\": {\"step\": .5}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"render\": {\"step\": 1.}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"render\": {\"step\": 1e}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"render\": {\"width\": 0x40}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"render\": {\"width\": -064}"), VOLUX_ERR_FORMAT, "invalid number"},
    {SCENE(", \"comment\": \"\\uZZ12\""), VOLUX_ERR_FORMAT, "\\u needs four hex digits"},
    {SCENE(", \"comment\": \"\\u12\""), VOLUX_ERR_FORMAT, "\\u needs four hex digits"},
    {SCENE(", \"comment\": \"\\q\""), VOLUX_ERR_FORMAT, "invalid escape"},
    {SCENE(", \"comment\": \"\\ud800\""), VOLUX_ERR_FORMAT, "lone UTF-16 high surrogate"},
    {SCENE(", \"comment\": \"\\ud800\\u0041\""), VOLUX_ERR_FORMAT, "lone UTF-16 high surrogate"},
    {SCENE(", \"comment\": \"\\udc00\""), VOLUX_ERR_FORMAT, "lone UTF-16 low surrogate"},
    {SCENE(", \"comment\": \"\xff\""), VOLUX_ERR_FORMAT, "invalid UTF-8 at line 1"},
    {SCENE(", \"comment\": \"\xc0\xaf\""), VOLUX_ERR_FORMAT, "invalid UTF-8"},       /* overlong '/' */
    {SCENE(", \"comment\": \"\xed\xa0\x80\""), VOLUX_ERR_FORMAT, "invalid UTF-8"},   /* a surrogate */
    {SCENE(", \"comment\": \"\xf4\x90\x80\x80\""), VOLUX_ERR_FORMAT, "invalid UTF-8"}, /* > U+10FFFF */
    {SCENE(", \"comment\": \"a\tb\""), VOLUX_ERR_FORMAT, "control character in a string"},
    /* valid: a surrogate pair, UTF-8, 0, -0.5e-3, 1E+2 (the comment is free text) */
    {SCENE(", \"comment\": \"\\ud83d\\ude00 \xc3\xa9 \\u00e9\", \"render\": {\"step\": 0, \"width\": 1E+2}"),
     VOLUX_ERR_INVALID, "render.step"},
    /* unknown and duplicate keys, with their full path */
    {SCENE(", \"lihgts\": []"), VOLUX_ERR_INVALID, "lihgts: unknown key; did you mean 'lights'? (expected one of: volume,"},
    {SCENE(", \"render\": {\"widht\": 64}"), VOLUX_ERR_INVALID, "render.widht: unknown key; did you mean 'width'?"},
    {SCENE(", \"render\": {\"width\": 64, \"width\": 32}"), VOLUX_ERR_INVALID, "render.width: duplicate key"},
    {SCENE(", \"render\": {}, \"render\": {}"), VOLUX_ERR_INVALID, "render: duplicate key"},
    {SCENE(", \"camera\": {\"orbit\": {\"azimut\": 3}}"), VOLUX_ERR_INVALID, "camera.orbit.azimut: unknown key; did you mean 'azimuth'?"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"colour\": []}"), VOLUX_ERR_INVALID, "transfer_function.colour: unknown key"},
    {SCENE(", \"techniques\": {\"ea\": {}, \"ea\": {}}"), VOLUX_ERR_INVALID, "techniques.ea: duplicate key"},
    {SCENE(", \"techniques\": {\"ea\": {\"a\": 1, \"a\": 2}}"), VOLUX_ERR_INVALID, "techniques.ea.a: duplicate key"},
    /* volume */
    {"{" TF "}", VOLUX_ERR_INVALID, "volume: missing"},
    {SCENE_VOL("[]"), VOLUX_ERR_INVALID, "volume: expected an object"},
    {SCENE_VOL("{}"), VOLUX_ERR_INVALID, "volume: give exactly one of file, files, pattern, procedural"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"file\": \"a.nrrd\"}"), VOLUX_ERR_INVALID, "give exactly one"},
    {SCENE_VOL("{\"procedural\": 3}"), VOLUX_ERR_INVALID, "volume.procedural: expected a string"},
    {SCENE_VOL("{\"procedural\": \"torus\"}"), VOLUX_ERR_INVALID, "volume.procedural: procedural: unknown volume"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"type\": \"uint16\"}"), VOLUX_ERR_INVALID, "volume.type: unknown key"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"spacing\": [1, 1, 1]}"), VOLUX_ERR_INVALID,
     "volume.spacing: unknown key"},
    {SCENE_VOL("{\"file\": \"a.nhdr\", \"seed\": 3}"), VOLUX_ERR_INVALID, "volume.seed: unknown key"},
    {SCENE_VOL("{\"file\": \"a.nhdr\", \"endian\": \"big\"}"), VOLUX_ERR_INVALID,
     "volume.endian: only for a raw file"},
    {SCENE_VOL("{\"file\": \"a.nhdr\", \"spacing\": [1, 1, 1]}"), VOLUX_ERR_INVALID, "volume.spacing: only for a raw"},
    {SCENE_VOL("{\"file\": \"a.raw\", \"dims\": [4, 4, 4]}"), VOLUX_ERR_INVALID, "volume: a raw file needs both"},
    {SCENE_VOL("{\"file\": \"a.raw\", \"dims\": [4, 4, 4], \"type\": \"int128\"}"), VOLUX_ERR_INVALID,
     "volume.type: unknown type 'int128'"},
    {SCENE_VOL("{\"file\": \"a.raw\", \"dims\": [4, 4, 4], \"type\": \"uint8\", \"endian\": \"middle\"}"),
     VOLUX_ERR_INVALID, "volume.endian"},
    {SCENE_VOL("{\"file\": \"\"}"), VOLUX_ERR_INVALID, "volume.file: empty file name"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": [8, 8]}"), VOLUX_ERR_INVALID, "volume.dims: expected 3"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": \"8\"}"), VOLUX_ERR_INVALID, "volume.dims: expected 3"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": [8, 0, 8]}"), VOLUX_ERR_INVALID, "volume.dims[1]"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": [8, 8, 2.5]}"), VOLUX_ERR_INVALID, "volume.dims[2]"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": [1e300, 8, 8]}"), VOLUX_ERR_INVALID, "volume.dims[0]"},
    {SCENE_VOL("{\"procedural\": \"sphere\", \"dims\": [16384, 16384, 16384]}"), VOLUX_ERR_LIMIT,
     "volume.procedural: procedural:sphere:"},
    {SCENE_VOL("{\"procedural\": \"cloud\", \"seed\": 1.5}"), VOLUX_ERR_INVALID, "volume.seed: expected an integer"},
    {SCENE_VOL("{\"procedural\": \"cloud\", \"seed\": -1}"), VOLUX_ERR_INVALID, "volume.seed: -1 is outside"},
    /* transfer function */
    {SCENE_TF("3"), VOLUX_ERR_INVALID, "transfer_function: expected an object"},
    {SCENE_TF("{}"), VOLUX_ERR_INVALID, "transfer_function: needs opacity or extinction points"},
    {SCENE_TF("{\"opacity\": []}"), VOLUX_ERR_INVALID, "transfer_function.opacity: needs 1..65536 rows, got 0"},
    {SCENE_TF("{\"opacity\": {}}"), VOLUX_ERR_INVALID, "transfer_function.opacity: expected an array"},
    {SCENE_TF("{\"opacity\": [[0, 0], [1, 0.5], [2, 7]]}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity[2]: 7 is outside [0, 1]"},
    {SCENE_TF("{\"opacity\": [[0, 0], [1, 0.5], [2]]}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity[2]: expected a row of 2 numbers"},
    {SCENE_TF("{\"opacity\": [[0, 0], [1, 0.5], [2, \"x\"]]}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity[2][1]: expected a number"},
    {SCENE_TF("{\"opacity\": [[0, 0], [2, 0.5], [1, 0.5]]}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity[2]: s = 1 must not decrease"},
    {SCENE_TF("{\"opacity\": [[0, 0]], \"extinction\": [[0, 1]]}"), VOLUX_ERR_INVALID,
     "transfer_function: give opacity or extinction, not both"},
    {SCENE_TF("{\"extinction\": [[0, -1]]}"), VOLUX_ERR_INVALID, "transfer_function.extinction[0]"},
    {SCENE_TF("{\"extinction\": [[0, 1]], \"opacity_unit_distance\": 2}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity_unit_distance: only applies to opacity"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"color\": [[0, 1, 1]]}"), VOLUX_ERR_INVALID,
     "transfer_function.color[0]: expected a row of 4 numbers"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"color\": [[0, 1, 1, 2]]}"), VOLUX_ERR_INVALID,
     "transfer_function.color[0]: r,g,b must be in [0, 1]"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"color\": [[0, 1, 1, 1], [1, 1, 1e31, 1]]}"), VOLUX_ERR_INVALID,
     "transfer_function.color[1][2]"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"albedo\": 1.5}"), VOLUX_ERR_INVALID, "transfer_function.albedo: 1.5 is"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"anisotropy\": 1}"), VOLUX_ERR_INVALID, "transfer_function.anisotropy"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"density_scale\": -1}"), VOLUX_ERR_INVALID, "transfer_function.density_scale"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"opacity_unit_distance\": 0}"), VOLUX_ERR_INVALID,
     "transfer_function.opacity_unit_distance"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"preset_name\": \"Cool\"}"), VOLUX_ERR_INVALID,
     "preset_name and preset_rescale need a preset"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"preset\": \"p.json\", \"color\": [[0, 1, 1, 1]]}"), VOLUX_ERR_INVALID,
     "color points or a preset, not both"},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"preset\": \"no_such_preset.json\"}"), VOLUX_ERR_IO,
     "transfer_function.preset: "},
    {SCENE_TF("{\"opacity\": [[0, 1]], \"preset\": \"bad_preset.json\"}"), VOLUX_ERR_FORMAT,
     "bad_preset.json: RGBPoints: element 2 = 2 is outside [0, 1]"},
    {SCENE_TF("\"bad_tf.json\""), VOLUX_ERR_INVALID, "bad_tf.json: transfer_function.albedo"},
    {SCENE_TF("\"nul_tf.json\""), VOLUX_ERR_FORMAT, "NUL byte at line 1"},
    {SCENE_TF("\"no_such_tf.json\""), VOLUX_ERR_IO, "transfer_function: "},
    {SCENE_TF("\".\""), VOLUX_ERR_IO, "transfer_function: "},
    {SCENE_TF("\".\""), VOLUX_ERR_IO, ": not a regular file"},
    /* camera */
    {SCENE(", \"camera\": {\"type\": \"fisheye\"}"), VOLUX_ERR_INVALID, "camera.type: expected"},
    {SCENE(", \"camera\": {\"height\": 2}"), VOLUX_ERR_INVALID, "camera.height: only for"},
    {SCENE(", \"camera\": {\"eye\": [0, 0, 5], \"orbit\": {}}"), VOLUX_ERR_INVALID, "camera: give eye/look_at or orbit"},
    {SCENE(", \"camera\": {\"look_at\": [0, 0, 5]}"), VOLUX_ERR_INVALID, "camera.look_at: needs an eye"},
    {SCENE(", \"camera\": {\"up\": [0, 0, 0]}"), VOLUX_ERR_INVALID, "camera.up: must not be the zero vector"},
    {SCENE(", \"camera\": {\"up\": [0, 0, 1], \"z_up\": true}"), VOLUX_ERR_INVALID, "camera: give up or z_up, not both"},
    {SCENE(", \"camera\": {\"z_up\": 1}"), VOLUX_ERR_INVALID, "camera.z_up: expected true or false"},
    {SCENE(", \"camera\": {\"eye\": [0, 0, 0]}"), VOLUX_ERR_INVALID, "camera: eye and look_at coincide"},
    {SCENE(", \"camera\": {\"eye\": [0, 5, 0], \"up\": [0, 2, 0]}"), VOLUX_ERR_INVALID, "camera: up is parallel"},
    {SCENE(", \"camera\": {\"eye\": [0, 5]}"), VOLUX_ERR_INVALID, "camera.eye: expected an array of 3 numbers"},
    {SCENE(", \"camera\": {\"fov_y\": 180}"), VOLUX_ERR_INVALID, "camera.fov_y: 180 is outside"},
    {SCENE(", \"camera\": {\"orbit\": {\"elevation\": 95}}"), VOLUX_ERR_INVALID, "camera.orbit.elevation"},
    {SCENE(", \"camera\": {\"orbit\": {\"distance\": 0}}"), VOLUX_ERR_INVALID, "camera.orbit.distance"},
    {SCENE(", \"camera\": {\"orbit\": 3}"), VOLUX_ERR_INVALID, "camera.orbit: expected an object"},
    /* huge but finite coordinates would overflow squared float lengths */
    {SCENE(", \"camera\": {\"eye\": [1e20, 0, 0]}"), VOLUX_ERR_INVALID, "camera.eye[0]: must be a number in"},
    {SCENE(", \"camera\": {\"orbit\": {\"distance\": 1e30}}"), VOLUX_ERR_INVALID, "camera.orbit.distance: 1e+30 is"},
    {LIGHTS("[{\"type\": \"point\", \"position\": [0, 1e20, 0]}]"), VOLUX_ERR_INVALID, "lights[0].position[1]"},
    {SCENE(", \"camera\": {\"type\": \"orthographic\", \"height\": -1}"), VOLUX_ERR_INVALID, "camera.height"},
    /* lights */
    {LIGHTS("{}"), VOLUX_ERR_INVALID, "lights: expected an array"},
    {LIGHTS("[3]"), VOLUX_ERR_INVALID, "lights[0]: expected an object"},
    {LIGHTS("[{\"type\": \"point\"}, {}]"), VOLUX_ERR_INVALID, "lights[1]: missing type"},
    {LIGHTS("[{\"type\": \"laser\"}]"), VOLUX_ERR_INVALID, "lights[0].type: unknown light type 'laser'"},
    {LIGHTS("[{\"type\": \"directional\", \"position\": [0, 0, 0]}]"), VOLUX_ERR_INVALID,
     "lights[0].position: unknown key"},
    {LIGHTS("[{\"type\": \"directional\", \"direction\": [0, 0, 0]}]"), VOLUX_ERR_INVALID, "lights[0].direction"},
    {LIGHTS("[{\"type\": \"point\"}, {\"type\": \"spot\", \"cone_angle\": 170}]"), VOLUX_ERR_INVALID,
     "lights[1].cone_angle: 170 is outside"},
    {LIGHTS("[{\"type\": \"point\"}, {\"type\": \"spot\", \"cone_angle\": 20, \"falloff_angle\": 30}]"),
     VOLUX_ERR_INVALID, "lights[1].falloff_angle: must be in [0, cone_angle]"},
    {LIGHTS("[{\"type\": \"sphere\", \"radius\": 0}]"), VOLUX_ERR_INVALID, "lights[0].radius"},
    {LIGHTS("[{\"type\": \"point\", \"color\": [1, 1]}]"), VOLUX_ERR_INVALID, "lights[0].color: expected an array"},
    {LIGHTS("[{\"type\": \"point\", \"color\": [1, -1, 1]}]"), VOLUX_ERR_INVALID, "lights[0].color[1]: must be"},
    {LIGHTS("[{\"type\": \"point\", \"intensity\": \"bright\"}]"), VOLUX_ERR_INVALID,
     "lights[0].intensity: expected a number"},
    {LIGHTS("[{\"type\": \"point\", \"enabled\": 1}]"), VOLUX_ERR_INVALID, "lights[0].enabled: expected true or false"},
    {LIGHTS("[{\"type\": \"environment\", \"file\": \"env.pfm\", \"radiance\": 2}]"), VOLUX_ERR_INVALID,
     "lights[0]: give radiance (constant) or file (map), not both"},
    {LIGHTS("[{\"type\": \"environment\", \"file\": \"no_such_env.hdr\"}]"), VOLUX_ERR_IO, "lights[0].file: "},
    /* background, render, techniques */
    {SCENE(", \"background\": [1, 2]"), VOLUX_ERR_INVALID, "background: expected an array of 3"},
    {SCENE(", \"background\": [0, -1, 0]"), VOLUX_ERR_INVALID, "background[1]: must be"},
    {SCENE(", \"render\": 3"), VOLUX_ERR_INVALID, "render: expected an object"},
    {SCENE(", \"render\": {\"width\": 0}"), VOLUX_ERR_INVALID, "render.width: 0 is outside [1, 32768]"},
    {SCENE(", \"render\": {\"height\": 40000}"), VOLUX_ERR_INVALID, "render.height"},
    {SCENE(", \"render\": {\"width\": 1.5}"), VOLUX_ERR_INVALID, "render.width: expected an integer"},
    {SCENE(", \"render\": {\"width\": \"64\"}"), VOLUX_ERR_INVALID, "render.width: expected a number"},
    {SCENE(", \"render\": {\"spp\": 0}"), VOLUX_ERR_INVALID, "render.spp"},
    {SCENE(", \"render\": {\"step\": 0}"), VOLUX_ERR_INVALID, "render.step"},
    {SCENE(", \"render\": {\"seed\": 0.5}"), VOLUX_ERR_INVALID, "render.seed: expected an integer"},
    {SCENE(", \"render\": {\"threads\": -1}"), VOLUX_ERR_INVALID, "render.threads"},
    {SCENE(", \"render\": {\"max_depth\": -1}"), VOLUX_ERR_INVALID, "render.max_depth"},
    {SCENE(", \"render\": {\"exposure\": 100}"), VOLUX_ERR_INVALID, "render.exposure"},
    {SCENE(", \"render\": {\"technique\": \"a-technique-name-longer-than-31-chars\"}"), VOLUX_ERR_INVALID,
     "render.technique: name too long"},
    {SCENE(", \"techniques\": []"), VOLUX_ERR_INVALID, "techniques: expected an object"},
    {SCENE(", \"techniques\": {\"ea\": 1}"), VOLUX_ERR_INVALID, "techniques.ea: expected an object of parameters"},
    {SCENE(", \"techniques\": {\"ea\": {\"foo\": null}}"), VOLUX_ERR_INVALID,
     "techniques.ea.foo: expected a number, boolean or string"},
    {SCENE(", \"techniques\": {\"ea\": {\"a-parameter-name-that-is-far-too-long-for-the-table\": 1}}"),
     VOLUX_ERR_INVALID, "name too long"},
};

/* Files the cases refer to, in the temp folder (the loader's base dir). */
static void write_support_files(void) {
    const char *bad_tf = "{\"opacity\": [[0, 1]], \"albedo\": 3}";
    tu_write_file("bad_tf.json", bad_tf, strlen(bad_tf));
    tu_write_file("nul_tf.json", "{\"opacity\"\0: [[0, 1]]}", 22);
    const char *bad_preset = "[{\"Name\": \"x\", \"RGBPoints\": [0, 0, 2, 0]}]";
    tu_write_file("bad_preset.json", bad_preset, strlen(bad_preset));
}

static void test_malformed_scenes_name_the_key(void **state) {
    (void)state;
    write_support_files();
    volux_context *ctx = tu_context(1);
    for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; i++) {
        const malformed *c = &CASES[i];
        volux_scene *s = NULL;
        volux_context_clear_error(ctx);
        volux_status st = volux_scene_load_string(ctx, c->json, tu_temp_path(""), "bad.json", NULL, 0, &s);
        const char *msg = volux_context_error(ctx);
        if (st == VOLUX_OK) {
            volux_scene_destroy(s);
            fail_msg("case %zu loaded: %s", i, c->json);
        }
        if (st != c->status || !strstr(msg, c->part) || strncmp(msg, "bad.json: ", 10) != 0)
            fail_msg("case %zu: %s: got %s \"%s\", expected %s \"%s\"", i, c->json, volux_status_name(st), msg,
                     volux_status_name(c->status), c->part);
        assert_null(s);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    }
    volux_context_destroy(ctx);
}

/* Inputs sized to make a careless reader slow or hungry: each must fail
 * fast, before anything proportional to the input is allocated by us. */
static char *repeat(const char *head, const char *item, size_t count, const char *sep, const char *tail) {
    size_t n = strlen(head) + count * (strlen(item) + strlen(sep)) + strlen(tail) + 1;
    char *s = malloc(n), *p = s;
    assert_non_null(s);
    p += sprintf(p, "%s", head);
    for (size_t i = 0; i < count; i++) p += sprintf(p, "%s%s", i ? sep : "", item);
    sprintf(p, "%s", tail);
    return s;
}

static void test_huge_arrays_deep_nesting_and_many_keys(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    struct {
        char *json;
        volux_status status;
        const char *part;
    } cases[] = {
        /* one light past the cap: refused before any light is read */
        {repeat("{" VOL ", " TF ", \"lights\": [", "{}", VOLUX_MAX_LIGHTS + 1, ",", "]}"), VOLUX_ERR_LIMIT,
         "lights: at most 1048576 lights, got 1048577"},
        {repeat("{" VOL ", \"transfer_function\": {\"opacity\": [", "[0, 0]", 65537, ",", "]}}"), VOLUX_ERR_INVALID,
         "transfer_function.opacity: needs 1..65536 rows, got 65537"},
        {repeat("{" VOL ", \"transfer_function\": {\"opacity\": [[", "0", 200000, ",", "]]}}"), VOLUX_ERR_INVALID,
         "transfer_function.opacity[0]: expected a row of 2 numbers"},
        {repeat("{\"volume\": {\"procedural\": \"sphere\", \"dims\": [", "1", 200000, ",", "]}}"), VOLUX_ERR_INVALID,
         "volume.dims: expected 3 integers"},
        {repeat("{", "\"comment\": 0", 100000, ",", "}"), VOLUX_ERR_INVALID, "comment: duplicate key"},
        {repeat("{" VOL ", " TF ", \"techniques\": {", "\"t\": {}", 1000, ",", "}}"), VOLUX_ERR_LIMIT,
         "techniques: more than 64 techniques"},
        {repeat("{\"comment\": ", "[", 65, "", "]}"), VOLUX_ERR_LIMIT, "nesting deeper than 64 levels"},
        {repeat("{\"comment\": ", "[", 1000000, "", "}"), VOLUX_ERR_LIMIT, "nesting deeper than 64 levels"},
        {repeat("", "{\"a\":", 100000, "", "}"), VOLUX_ERR_LIMIT, "nesting deeper than 64 levels"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        volux_scene *s = NULL;
        volux_context_clear_error(ctx);
        volux_status st = volux_scene_load_string(ctx, cases[i].json, NULL, "big.json", NULL, 0, &s);
        if (st != cases[i].status || !strstr(volux_context_error(ctx), cases[i].part))
            fail_msg("case %zu: got %s \"%s\", expected \"%s\"", i, volux_status_name(st), volux_context_error(ctx),
                     cases[i].part);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        free(cases[i].json);
    }
    /* The cap itself is fine (issue 16: 50 000-point TFs exist): 65 536
     * opacity and colour points load, and a TF edit copies them. */
    {
        char *big = malloc(65536 * 40 + 256), *p = big;
        p += sprintf(p, "{" VOL ", \"transfer_function\": {\"opacity\": [");
        for (int i = 0; i < 65536; i++) p += sprintf(p, "%s[%d, %g]", i ? "," : "", i, (i % 7) / 7.0);
        p += sprintf(p, "], \"color\": [");
        for (int i = 0; i < 65536; i++) p += sprintf(p, "%s[%d, 1, 0.5, 0]", i ? "," : "", i);
        sprintf(p, "]}}");
        volux_scene *s = NULL;
        volux_context_clear_error(ctx);
        if (volux_scene_load_string(ctx, big, NULL, "big.json", NULL, 0, &s) != VOLUX_OK)
            fail_msg("65536 TF points: %s", volux_context_error(ctx));
        assert_int_equal(volux_scene_transfer(s)->n_opacity, 65536);
        assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
        volux_scene_destroy(s);
        free(big);
    }
    /* 64 levels are fine as far as nesting goes (the key is then unknown). */
    char *ok = repeat("{\"comment\": ", "[", 63, "", "");
    char *closed = repeat(ok, "]", 63, "", "}");
    volux_scene *s = NULL;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_scene_load_string(ctx, closed, NULL, "deep.json", NULL, 0, &s), VOLUX_ERR_INVALID);
    assert_contains(volux_context_error(ctx), "volume: missing");
    free(ok);
    free(closed);
    volux_context_destroy(ctx);
}

static void test_nul_bytes_are_rejected_with_their_position(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const char text[] = "{\"volume\": {\"procedural\": \"sphere\"},\n \"comment\": \"a\0b\"}";
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_parse(ctx, text, sizeof text - 1, NULL, "nul.json", NULL, 0, 0, &s),
                     VOLUX_ERR_FORMAT);
    assert_contains(volux_context_error(ctx), "nul.json: NUL byte at line 2, column 15");
    /* The same through a file. */
    const char *path = tu_write_file("nul.json", text, sizeof text - 1);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_scene_load(ctx, path, NULL, 0, &s), VOLUX_ERR_FORMAT);
    assert_contains(volux_context_error(ctx), "nul.json: NUL byte at line 2");
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ allocation failures */

typedef struct failing_alloc {
    long calls, fail_at; /* fail the fail_at-th allocation (1-based); 0 = never */
    long long live;      /* bytes allocated and not yet freed */
} failing_alloc;

static void *failing(void *user, void *ptr, size_t old_size, size_t new_size) {
    failing_alloc *f = user;
    if (new_size == 0) {
        if (ptr) __atomic_sub_fetch(&f->live, (long long)old_size, __ATOMIC_RELAXED);
        free(ptr);
        return NULL;
    }
    long k = __atomic_add_fetch(&f->calls, 1, __ATOMIC_RELAXED);
    if (f->fail_at && k == f->fail_at) return NULL;
    void *p = realloc(ptr, new_size);
    if (p) __atomic_add_fetch(&f->live, (long long)new_size - (long long)(ptr ? old_size : 0), __ATOMIC_RELAXED);
    return p;
}

static void test_every_allocation_failure_is_reported_without_leaks(void **state) {
    (void)state;
    /* A scene that reads files of every kind: raw volume, TF file, preset,
     * environment map. */
    volux_context *setup = tu_context(1);
    unsigned char vox[64];
    for (int i = 0; i < 64; i++) vox[i] = (unsigned char)(4 * i);
    tu_write_file("oom.raw", vox, sizeof vox);
    const char *tf = "{\"opacity\": [[0, 0], [255, 0.5]], \"preset\": \"oom_preset.json\", \"preset_name\": \"B\"}";
    tu_write_file("oom_tf.json", tf, strlen(tf));
    const char *preset = "[{\"Name\": \"A\", \"RGBPoints\": [0, 0, 0, 0]},"
                         " {\"Name\": \"B\", \"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1], \"Points\": [0, 0, 0.5, 0]}]";
    tu_write_file("oom_preset.json", preset, strlen(preset));
    volux_image env;
    assert_int_equal(volux_image_create(setup, 2, 1, &env), VOLUX_OK);
    assert_int_equal(volux_image_save(setup, tu_temp_path("oom_env.pfm"), &env, 0), VOLUX_OK);
    volux_image_free(setup, &env);
    volux_context_destroy(setup);
    const char *scene = "{\"volume\": {\"file\": \"oom.raw\", \"dims\": [4, 4, 4], \"type\": \"uint8\"},"
                        " \"transfer_function\": \"oom_tf.json\","
                        " \"lights\": [{\"type\": \"environment\", \"file\": \"oom_env.pfm\"},"
                        "              {\"type\": \"point\"}],"
                        " \"techniques\": {\"x\": {\"s\": \"string\", \"n\": 1}}}";
    const char *ov[] = {"lights.1.intensity=2"};
    int succeeded = 0;
    long k;
    for (k = 1; k < 10000 && !succeeded; k++) {
        failing_alloc f = {0, 0, 0};
        volux_context_desc d = {0};
        d.threads = 1;
        d.alloc = failing;
        d.alloc_user = &f;
        volux_context *ctx = NULL;
        assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
        f.fail_at = f.calls + k;
        volux_scene *s = NULL;
        volux_status st = volux_scene_load_string(ctx, scene, tu_temp_path(""), "oom.json", ov, 1, &s);
        if (st == VOLUX_OK) {
            succeeded = 1;
            assert_int_equal(volux_scene_transfer(s)->n_color, 2);
            volux_scene_destroy(s);
        } else {
            assert_null(s);
            if (!volux_context_error(ctx)[0]) fail_msg("allocation %ld: failed without a message", k);
        }
        volux_context_destroy(ctx);
        if (f.live != 0) fail_msg("allocation %ld failed: %lld bytes leaked (%s)", k, f.live, volux_status_name(st));
    }
    assert_true(succeeded);
    print_message("scene load survived %ld injected allocation failures\n", k - 2);
}

/* ------------------------------------------------------------------ CLI */

static const char *write_scene(const char *name, const char *json) { return tu_write_file(name, json, strlen(json)); }

static int exists(const char *path) { return access(path, F_OK) == 0; }

#define CLI_SCENE                                                                                      \
    "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [12, 12, 12]},"                                \
    " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]},"                                      \
    " \"render\": {\"technique\": \"ea\", \"width\": 8, \"height\": 8}}"

/* Runs `volux ARGS -o OUT` (OUT removed first) and checks the exit status,
 * that stderr contains each of `parts` (NULL-terminated), and that OUT
 * exists only on success. */
static void cli_case(const char *args, int want_rc, const char *const *parts) {
    const char *out = tu_temp_path("cli_out.png");
    unlink(out);
    char cmd[3000];
    snprintf(cmd, sizeof cmd, "%s -o '%s'", args, out);
    const char *err = NULL;
    int rc = tu_run_cli(cmd, &err);
    if (rc != want_rc) fail_msg("volux %s: exit %d, expected %d; stderr: %s", cmd, rc, want_rc, err);
    for (; parts && *parts; parts++)
        if (!strstr(err, *parts)) fail_msg("volux %s: expected \"%s\" in stderr: %s", cmd, *parts, err);
    if (want_rc == 0 && !exists(out)) fail_msg("volux %s: no output written", cmd);
    if (want_rc != 0 && exists(out)) fail_msg("volux %s: failed but left %s", cmd, out);
}

static void test_cli_exit_status_and_messages(void **state) {
    (void)state;
    char good[600], bad_key[600], missing_vol[600], nul[600], args[2000];
    snprintf(good, sizeof good, "%s", write_scene("cli_good.json", CLI_SCENE));
    snprintf(bad_key, sizeof bad_key, "%s",
             write_scene("cli_bad_key.json", "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                                             " \"transfer_function\": {\"opacity\": [[0, 1]]},"
                                             " \"render\": {\"widht\": 8}}"));
    snprintf(missing_vol, sizeof missing_vol, "%s",
             write_scene("cli_missing_vol.json", "{\"volume\": {\"file\": \"cli_missing_volume.nrrd\"},"
                                                 " \"transfer_function\": {\"opacity\": [[0, 1]]}}"));
    snprintf(nul, sizeof nul, "%s", tu_write_file("cli_nul.json", "{\"volume\"\0}", 11));

    snprintf(args, sizeof args, "render '%s'", good);
    cli_case(args, 0, NULL);
    snprintf(args, sizeof args, "render '%s' --set render.width=4 --set lights.0.type=directional --technique shaded",
             good);
    cli_case(args, 0, NULL);
    /* A long --set value (a whole opacity curve) is not cut short. */
    int len = snprintf(args, sizeof args, "render '%s' --set 'transfer_function.opacity=[[0, 0]", good);
    for (int i = 1; i < 60; i++) len += snprintf(args + len, sizeof args - (size_t)len, ", [%d, 0.5]", i * 4);
    snprintf(args + len, sizeof args - (size_t)len, "]'");
    assert_true(strlen(args) > 500);
    cli_case(args, 0, NULL);

    snprintf(args, sizeof args, "render '%s'", bad_key);
    cli_case(args, 2, (const char *const[]){"cli_bad_key.json", "render.widht: unknown key", NULL});
    snprintf(args, sizeof args, "render '%s'", missing_vol);
    cli_case(args, 2, (const char *const[]){"cli_missing_vol.json", "volume.file", "cli_missing_volume.nrrd", NULL});
    snprintf(args, sizeof args, "render '%s'", nul);
    cli_case(args, 2, (const char *const[]){"cli_nul.json", "NUL byte", NULL});
    snprintf(args, sizeof args, "render '%s'", tu_temp_path("cli_no_such_scene.json"));
    cli_case(args, 2, (const char *const[]){"cli_no_such_scene.json", NULL});
    snprintf(args, sizeof args, "render '%s'", tu_temp_path(""));
    /* a folder may be a DICOM series: this one holds none */
    cli_case(args, 2, (const char *const[]){"no DICOM image in the folder", NULL});

    /* Bad overrides. */
    snprintf(args, sizeof args, "render '%s' --set render.width=abc", good);
    cli_case(args, 2, (const char *const[]){"cli_good.json", "render.width: expected a number", NULL});
    snprintf(args, sizeof args, "render '%s' --set render.width", good);
    cli_case(args, 2, (const char *const[]){"--set render.width: expected dotted.path=value", NULL});
    snprintf(args, sizeof args, "render '%s' --set lights.3.type=point", good);
    cli_case(args, 2, (const char *const[]){"cli_good.json", "--set lights.3", NULL});
    snprintf(args, sizeof args, "render '%s' --set 'render.widht=8'", good);
    cli_case(args, 2, (const char *const[]){"render.widht: unknown key; did you mean 'width'?", NULL});
    snprintf(args, sizeof args, "render '%s' --set 'camera.orbit.azimut=8'", good);
    cli_case(args, 2, (const char *const[]){"camera.orbit.azimut: unknown key; did you mean 'azimuth'?", NULL});
    /* An output that cannot be created fails the check before the render
     * (root passes access() on /proc; creating the file does not). */
    {
        snprintf(args, sizeof args, "render '%s' -o /proc/volux_cannot_write.png", good);
        const char *err = NULL;
        int rc = tu_run_cli(args, &err);
        if (rc != 2 || !strstr(err, "cannot write '/proc/volux_cannot_write.png'"))
            fail_msg("volux %s: exit %d, stderr: %s", args, rc, err);
    }
    /* A fully transparent transfer function renders (exit 0) but warns. */
    {
        char clear[600];
        snprintf(clear, sizeof clear, "%s",
                 write_scene("cli_clear.json", "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                                               " \"transfer_function\": {\"opacity\": [[0, 0], [1, 0]]},"
                                               " \"render\": {\"width\": 8, \"height\": 8}}"));
        snprintf(args, sizeof args, "render '%s'", clear);
        cli_case(args, 0, (const char *const[]){"cli_clear.json: transfer_function: fully transparent", NULL});
        const char *err = NULL;
        snprintf(args, sizeof args, "render '%s' -o '%s'", good, tu_temp_path("cli_good_out.png"));
        assert_int_equal(tu_run_cli(args, &err), 0);
        assert_null(strstr(err, "fully transparent")); /* a visible one does not */
    }
    /* A progressive technique on a quick look accumulates (to a target
     * error or a time budget), never ending on one sample; one-pass
     * techniques keep one. */
    {
        const char *err = NULL;
        snprintf(args, sizeof args, "render procedural:sphere:16 --technique pathtrace --width 16 --height 16 -o '%s'",
                 tu_temp_path("cli_ql_pt.png"));
        assert_int_equal(tu_run_cli(args, &err), 0);
        const char *at = strstr(err, "pathtrace 16x16, ");
        if (!at || atoi(at + strlen("pathtrace 16x16, ")) < 2) fail_msg("quick-look pathtrace stopped early: %s", err);
        snprintf(args, sizeof args, "render procedural:sphere:16 --width 16 --height 16 -o '%s'",
                 tu_temp_path("cli_ql_sh.png"));
        assert_int_equal(tu_run_cli(args, &err), 0);
        if (!strstr(err, "shaded 16x16, 1 spp")) fail_msg("quick-look shaded: %s", err);
    }
    /* An option typo names the option it resembles. */
    snprintf(args, sizeof args, "render '%s' --widht 8", good);
    cli_case(args, 2, (const char *const[]){"unknown option '--widht'; did you mean '--width'?", NULL});
    snprintf(args, sizeof args, "render '%s' --ouput x.png", good);
    cli_case(args, 2, (const char *const[]){"unknown option '--ouput'; did you mean '--output'?", NULL});
    snprintf(args, sizeof args, "render '%s' --width 0", good);
    cli_case(args, 2, (const char *const[]){"render.width: 0 is outside", NULL});
    snprintf(args, sizeof args, "render '%s' --spp many", good);
    cli_case(args, 2, (const char *const[]){"--spp", NULL});

    /* Techniques and their parameters. */
    snprintf(args, sizeof args, "render '%s' --technique nope", good);
    cli_case(args, 2, (const char *const[]){"cli_good.json", "render.technique: unknown technique 'nope'", NULL});
    snprintf(args, sizeof args, "render '%s' --set techniques.ea.foo=1", good);
    cli_case(args, 2, (const char *const[]){"cli_good.json", "techniques.ea.foo: unknown parameter", NULL});
    snprintf(args, sizeof args, "render '%s' --set techniques.ea.early_termination=5", good);
    cli_case(args, 2, (const char *const[]){"techniques.ea.early_termination: 5 is outside", NULL});
    snprintf(args, sizeof args, "render '%s' --set techniques.nope.x=1", good);
    cli_case(args, 2, (const char *const[]){"techniques.nope: unknown technique", NULL});

    /* bench shares the loader and its exit statuses. */
    const char *err = NULL;
    snprintf(args, sizeof args, "bench '%s' --repeat 1", bad_key);
    int rc = tu_run_cli(args, &err);
    if (rc != 2 || !strstr(err, "render.widht")) fail_msg("volux %s: exit %d: %s", args, rc, err);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malformed_scenes_name_the_key),
        cmocka_unit_test(test_huge_arrays_deep_nesting_and_many_keys),
        cmocka_unit_test(test_nul_bytes_are_rejected_with_their_position),
        cmocka_unit_test(test_every_allocation_failure_is_reported_without_leaks),
        cmocka_unit_test(test_cli_exit_status_and_messages),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
