/* Cameras: orbit convention, pixel convention, framing, orthographic. */
#include <math.h>
#include <string.h>

#include "core/vecmath.h"
#include "test_util.h"

static volux_camera resolve(const volux_camera_desc *d, int w, int h) {
    volux_context *ctx = tu_context(1);
    volux_camera cam;
    assert_int_equal(volux_camera_resolve(ctx, d, v3(1, 2, 3), 10.0f, w, h, &cam), VOLUX_OK);
    volux_context_destroy(ctx);
    return cam;
}

/* DESIGN §3: eye = C + distance·R·(cos el·sin az, sin el, cos el·cos az). */
static void test_orbit_eye_follows_the_contract(void **state) {
    (void)state;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.azimuth_deg = 90;
    d.elevation_deg = 0;
    d.distance = 3;
    volux_camera c = resolve(&d, 64, 64);
    assert_near(c.eye.x, 1 + 30, 1e-4);
    assert_near(c.eye.y, 2, 1e-4);
    assert_near(c.eye.z, 3, 1e-4);
    d.azimuth_deg = 0; /* az = el = 0 looks down −Z */
    c = resolve(&d, 64, 64);
    assert_near(c.forward.z, -1, 1e-6);
    assert_near(c.right.x, 1, 1e-6);
    assert_near(c.up.y, 1, 1e-6);
}

/* Pixel (0,0) is the top-left: its ray goes up and left of the centre. */
static void test_pixel_origin_is_top_left(void **state) {
    (void)state;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.azimuth_deg = d.elevation_deg = 0;
    volux_camera c = resolve(&d, 40, 30);
    volux_vec3 o, dir;
    volux_camera_ray(&c, 20, 15, &o, &dir); /* image centre */
    assert_near(dir.z, -1, 1e-6);
    volux_camera_ray(&c, 0.5f, 0.5f, &o, &dir);
    assert_true(dir.x < 0 && dir.y > 0);
    /* the top edge of the image is at fov_y/2 above the axis */
    volux_camera_ray(&c, 20, 0, &o, &dir);
    assert_near(atan2(dir.y, -dir.z) * 180.0 / M_PI, d.fov_y_deg / 2, 1e-3);
}

/* distance = 1/sin(fov/2) fits the bounding sphere exactly: the ray through
 * the top edge is tangent to the sphere of radius R. */
static void test_default_distance_fits_the_bounding_sphere(void **state) {
    (void)state;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    volux_camera c = resolve(&d, 32, 32);
    volux_vec3 o, dir;
    volux_camera_ray(&c, 16, 0, &o, &dir);
    volux_vec3 to_c = v3_sub(v3(1, 2, 3), o);
    float along = v3_dot(to_c, dir);
    float dist = v3_length(v3_sub(to_c, v3_scale(dir, along)));
    assert_near(dist, 10.0, 1e-3);
}

static void test_orthographic_rays_are_parallel_and_framed(void **state) {
    (void)state;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.projection = VOLUX_ORTHOGRAPHIC;
    d.azimuth_deg = d.elevation_deg = 0;
    d.distance = 2;
    volux_camera c = resolve(&d, 20, 10);
    volux_vec3 o0, d0, o1, d1;
    volux_camera_ray(&c, 0, 0, &o0, &d0);
    volux_camera_ray(&c, 20, 10, &o1, &d1);
    assert_near(v3_dot(d0, d1), 1, 1e-6);
    /* height = 2·distance·R·tan(fov/2) */
    assert_near(o0.y - o1.y, 2 * 2 * 10 * tan(15 * M_PI / 180), 1e-3);
    assert_near(o1.x - o0.x, 2 * (o0.y - o1.y), 1e-3); /* aspect 2:1 */
}

static void test_degenerate_cameras_are_rejected(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.use_orbit = 0;
    d.eye = d.look_at = v3(1, 1, 1);
    volux_camera c;
    assert_int_equal(volux_camera_resolve(ctx, &d, v3(0, 0, 0), 1, 8, 8, &c), VOLUX_ERR_INVALID);
    d.look_at = v3(1, 5, 1); /* looking along up */
    assert_int_equal(volux_camera_resolve(ctx, &d, v3(0, 0, 0), 1, 8, 8, &c), VOLUX_ERR_INVALID);
    volux_camera_desc_defaults(&d);
    d.fov_y_deg = 180;
    assert_int_equal(volux_camera_resolve(ctx, &d, v3(0, 0, 0), 1, 8, 8, &c), VOLUX_ERR_INVALID);
    volux_context_destroy(ctx);
}

/* An orbit around another up axis: the DESIGN §3 formula in the basis
 * that takes +Y to up; up = +Y gives exactly the old camera. */
static void test_orbit_up_axis(void **state) {
    (void)state;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.azimuth_deg = 0;
    d.elevation_deg = 0;
    d.distance = 3;
    d.up = v3(0, 0, 1); /* z-up (medical): az = el = 0 is the front, −Y */
    volux_camera c = resolve(&d, 64, 64);
    assert_near(c.eye.x, 1, 1e-4);
    assert_near(c.eye.y, 2 - 30, 1e-4);
    assert_near(c.eye.z, 3, 1e-4);
    assert_near(c.forward.y, 1, 1e-6);
    assert_near(c.up.z, 1, 1e-6);
    assert_near(c.right.x, 1, 1e-6);
    d.elevation_deg = 90; /* straight above: eye on +Z, still a valid frame */
    c = resolve(&d, 64, 64);
    assert_near(c.eye.z, 3 + 30, 1e-3);
    assert_near(c.forward.z, -1, 1e-6);
    assert_near(fabsf(c.right.x) + fabsf(c.right.y), 1, 1e-5);
    d.elevation_deg = 20;
    d.azimuth_deg = 35;
    d.up = v3(0, -2, 0); /* upside down: eye mirrored in y and z */
    volux_camera_desc y = d;
    y.up = v3(0, 1, 0);
    volux_camera a = resolve(&d, 64, 64), b = resolve(&y, 64, 64);
    assert_near(a.eye.x - 1, b.eye.x - 1, 1e-4);
    assert_near(a.eye.y - 2, -(b.eye.y - 2), 1e-4);
    assert_near(a.eye.z - 3, -(b.eye.z - 3), 1e-4);
    assert_near(a.up.y, -b.up.y, 1e-5);
    /* An arbitrary axis: the eye's elevation is measured from it. */
    d.up = v3(1, 1, 0);
    c = resolve(&d, 64, 64);
    volux_vec3 off = v3_sub(c.eye, v3(1, 2, 3));
    assert_near(v3_dot(v3_normalize(off), v3_normalize(d.up)), sinf(20 * VOLUX_PI / 180), 1e-5);
    /* +Y is bit-identical to the formula (existing images do not move). */
    d.up = v3(0, 1, 0);
    c = resolve(&d, 64, 64);
    float az = 35 * VOLUX_PI / 180.0f, el = 20 * VOLUX_PI / 180.0f, r = 30.0f;
    assert_true(c.eye.x == 1 + r * cosf(el) * sinf(az));
    assert_true(c.eye.y == 2 + r * sinf(el));
    assert_true(c.eye.z == 3 + r * cosf(el) * cosf(az));
}

static void test_zero_up_is_rejected(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    d.up = v3(0, 0, 0);
    volux_camera cam;
    assert_int_equal(volux_camera_resolve(ctx, &d, v3(0, 0, 0), 1.0f, 8, 8, &cam), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "camera.up"));
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orbit_up_axis),
        cmocka_unit_test(test_zero_up_is_rejected),
        cmocka_unit_test(test_orbit_eye_follows_the_contract),
        cmocka_unit_test(test_pixel_origin_is_top_left),
        cmocka_unit_test(test_default_distance_fits_the_bounding_sphere),
        cmocka_unit_test(test_orthographic_rays_are_parallel_and_framed),
        cmocka_unit_test(test_degenerate_cameras_are_rejected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
