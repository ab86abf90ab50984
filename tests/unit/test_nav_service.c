/* Unit tests of firmware/app/nav_service: how the previous run ended, read
 * from what the unit's ExecStopPost records; the notify calls are no-ops
 * outside systemd. */
#define _DEFAULT_SOURCE /* mkstemp, setenv under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/app/nav_service.h"

static void test_parse_exit(void **state)
{
    (void)state;
    assert_int_equal(nav_service_parse_exit("success exited 0\n"), NAV_EXIT_CLEAN);
    assert_int_equal(nav_service_parse_exit("exit-code exited 3"), NAV_EXIT_FAILED);
    assert_int_equal(nav_service_parse_exit("signal killed KILL"), NAV_EXIT_SIGNAL);
    assert_int_equal(nav_service_parse_exit("signal killed TERM"), NAV_EXIT_SIGNAL);
    assert_int_equal(nav_service_parse_exit("core-dump dumped SEGV"), NAV_EXIT_CORE);
    assert_int_equal(nav_service_parse_exit("watchdog killed ABRT"), NAV_EXIT_WATCHDOG);
    assert_int_equal(nav_service_parse_exit("watchdog dumped ABRT"), NAV_EXIT_WATCHDOG);
    assert_int_equal(nav_service_parse_exit("timeout killed KILL"), NAV_EXIT_SIGNAL);
    assert_int_equal(nav_service_parse_exit("resources unknown unknown"), NAV_EXIT_OTHER);
    assert_int_equal(nav_service_parse_exit(""), NAV_EXIT_NONE);
    assert_int_equal(nav_service_parse_exit("   \n"), NAV_EXIT_NONE);
    assert_int_equal(nav_service_parse_exit(NULL), NAV_EXIT_NONE);
    /* a record far longer than a field is read bounded */
    char longer[200];
    memset(longer, 'w', sizeof longer - 1);
    longer[sizeof longer - 1] = '\0';
    assert_int_equal(nav_service_parse_exit(longer), NAV_EXIT_OTHER);
}

static void test_read_exit_and_no_supervisor(void **state)
{
    (void)state;
    assert_int_equal(nav_service_read_exit(NULL), NAV_EXIT_NONE);
    assert_int_equal(nav_service_read_exit("/nonexistent/last-exit"), NAV_EXIT_NONE); /* first start */
    char path[] = "/tmp/mfns-last-exit-XXXXXX";
    const int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    assert_non_null(f);
    assert_true(fputs("watchdog killed ABRT\n", f) >= 0);
    assert_int_equal(fclose(f), 0);
    assert_int_equal(nav_service_read_exit(path), NAV_EXIT_WATCHDOG);
    assert_int_equal(remove(path), 0);
    /* outside systemd: nothing to notify, no watchdog, and the calls are harmless */
    assert_int_equal(unsetenv("NOTIFY_SOCKET"), 0);
    assert_int_equal(unsetenv("WATCHDOG_USEC"), 0);
    nav_service_t s;
    nav_service_init(&s);
    assert_false(s.notify);
    assert_int_equal(s.watchdog_us, 0u);
    nav_service_ready(&s, "test");
    nav_service_alive(&s, 123456u);
    nav_service_stopping(&s, "test");
    /* a watchdog of 200 ms: pings at most every 100 ms */
    assert_int_equal(setenv("WATCHDOG_USEC", "200000", 1), 0);
    nav_service_init(&s);
    assert_int_equal(s.watchdog_us, 200000u);
    nav_service_alive(&s, 1000000u);
    assert_int_equal(s.last_ping_us, 1000000u);
    nav_service_alive(&s, 1050000u);
    assert_int_equal(s.last_ping_us, 1000000u);
    nav_service_alive(&s, 1100000u);
    assert_int_equal(s.last_ping_us, 1100000u);
    assert_int_equal(unsetenv("WATCHDOG_USEC"), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_exit),
        cmocka_unit_test(test_read_exit_and_no_supervisor),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
