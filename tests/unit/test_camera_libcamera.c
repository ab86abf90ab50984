/* Unit tests of the libcamera backend as far as a machine without cameras
 * allows: the CameraManager starts and stops cleanly, and asking for a camera
 * that does not exist gives MFNS_CAM_E_NO_CAMERA with a clear message (the
 * path the flight program takes when the board's cameras are missing). Where
 * libcamera is not built in (the aarch64 cross build), selecting the backend
 * gives MFNS_CAM_E_BACKEND instead. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE 1
#endif
#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>

#include "drivers/camera/camera.h"
#if defined(MFNS_HAVE_LIBCAMERA)
#include "drivers/camera/camera_libcamera.h"
#endif

static bool has(const char *msg, const char *needle)
{
    if (!strstr(msg, needle)) {
        print_error("message \"%s\" lacks \"%s\"\n", msg, needle);
        return false;
    }
    return true;
}

#if defined(MFNS_HAVE_LIBCAMERA)

static void test_missing_camera_is_reported(void **state)
{
    (void)state;
    const int n = mfns_lcam_camera_count();
    assert_true(n >= 0); /* the CameraManager started */
    char msg[MFNS_CAM_MSG_LEN];
    mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_LIBCAMERA, "mfns-test-no-such-camera");
    s.width = 1280;
    s.height = 1024;
    s.pixfmt = MFNS_CAM_PIX_GREY;
    /* more attempts than handles: a failed open must give its handle back */
    for (unsigned k = 0; k < MFNS_CAM_MAX_HANDLES + 2u; k++) {
        mfns_cam_t *cam = (mfns_cam_t *)(void *)&s;
        assert_int_equal(mfns_cam_open(&s, &cam, msg, sizeof msg), MFNS_CAM_E_NO_CAMERA);
        assert_null(cam);
        assert_true(has(msg, "no camera 'mfns-test-no-such-camera'"));
    }
    if (n == 0) {
        /* this machine: no camera at all, and "first camera" says so */
        mfns_cam_t *cam = NULL;
        s.path = "";
        assert_int_equal(mfns_cam_open(&s, &cam, msg, sizeof msg), MFNS_CAM_E_NO_CAMERA);
        assert_null(cam);
        assert_true(has(msg, "no cameras on this system"));
    }
    assert_string_not_equal(mfns_cam_strerror(MFNS_CAM_E_NO_CAMERA), mfns_cam_strerror(MFNS_CAM_E_OPEN));
    /* the manager is released each time: counting again starts it afresh */
    assert_int_equal(mfns_lcam_camera_count(), n);
}

#else

static void test_backend_not_built(void **state)
{
    (void)state;
    char msg[MFNS_CAM_MSG_LEN];
    mfns_cam_t *cam = NULL;
    const mfns_cam_settings_t s = mfns_cam_default_settings(MFNS_CAM_BACKEND_LIBCAMERA, "");
    assert_int_equal(mfns_cam_open(&s, &cam, msg, sizeof msg), MFNS_CAM_E_BACKEND);
    assert_null(cam);
    assert_true(has(msg, "libcamera backend not built"));
}

#endif

int main(void)
{
    /* libcamera warns about its IPA modules on every start; errors still show */
    (void)setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
    const struct CMUnitTest tests[] = {
#if defined(MFNS_HAVE_LIBCAMERA)
        cmocka_unit_test(test_missing_camera_is_reported),
#else
        cmocka_unit_test(test_backend_not_built),
#endif
    };
    return cmocka_run_group_tests_name("camera_libcamera", tests, NULL, NULL);
}
