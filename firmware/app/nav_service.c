/* nav_service.c -- see nav_service.h. */
#define _DEFAULT_SOURCE /* mlockall under -std=c11 */

#include "firmware/app/nav_service.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <systemd/sd-daemon.h>

void nav_service_init(nav_service_t *s)
{
    memset(s, 0, sizeof *s);
    const char *sock = getenv("NOTIFY_SOCKET");
    s->notify = sock != NULL && sock[0] != '\0';
    uint64_t usec = 0;
    /* > 0: a watchdog for this process (WATCHDOG_USEC, and WATCHDOG_PID when set is ours) */
    if (sd_watchdog_enabled(0, &usec) > 0) {
        s->watchdog_us = usec;
    }
}

static void notify(const nav_service_t *s, const char *msg)
{
    if (s->notify) {
        (void)sd_notify(0, msg); /* < 0: no supervisor listening; nothing to do about it here */
    }
}

void nav_service_notify(nav_service_t *s, const char *msg)
{
    notify(s, msg);
}

void nav_service_ready(nav_service_t *s, const char *status)
{
    char msg[256];
    (void)snprintf(msg, sizeof msg, "READY=1\nSTATUS=%s", status);
    notify(s, msg);
}

void nav_service_alive(nav_service_t *s, uint64_t now_us)
{
    if (s->watchdog_us == 0u || now_us - s->last_ping_us < s->watchdog_us / 2u) {
        return;
    }
    s->last_ping_us = now_us;
    notify(s, "WATCHDOG=1");
}

void nav_service_stopping(nav_service_t *s, const char *status)
{
    char msg[256];
    (void)snprintf(msg, sizeof msg, "STOPPING=1\nSTATUS=%s", status);
    notify(s, msg);
}

bool nav_service_lock_memory(void)
{
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
        fprintf(stderr, "mfns-nav: --mlock: memory not locked (%s): running unlocked; a page fault may delay a cycle\n",
                strerror(errno));
        return false;
    }
    return true;
}

nav_exit_reason_t nav_service_parse_exit(const char *text)
{
    char result[32] = "", code[32] = "", status[32] = "";
    if (text == NULL || sscanf(text, "%31s %31s %31s", result, code, status) < 1) {
        return NAV_EXIT_NONE;
    }
    if (strcmp(result, "watchdog") == 0) {
        return NAV_EXIT_WATCHDOG;
    }
    if (strcmp(result, "core-dump") == 0 || strcmp(code, "dumped") == 0) {
        return NAV_EXIT_CORE;
    }
    if (strcmp(result, "signal") == 0 || strcmp(code, "killed") == 0) {
        return NAV_EXIT_SIGNAL;
    }
    if (strcmp(code, "exited") == 0) {
        return strcmp(status, "0") == 0 ? NAV_EXIT_CLEAN : NAV_EXIT_FAILED;
    }
    if (strcmp(result, "success") == 0) {
        return NAV_EXIT_CLEAN;
    }
    if (strcmp(result, "exit-code") == 0) {
        return NAV_EXIT_FAILED;
    }
    return NAV_EXIT_OTHER;
}

nav_exit_reason_t nav_service_read_exit(const char *path)
{
    if (path == NULL) {
        return NAV_EXIT_NONE;
    }
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        return NAV_EXIT_NONE; /* first start: no record yet */
    }
    char line[128] = "";
    const bool got = fgets(line, sizeof line, f) != NULL;
    (void)fclose(f); /* read-only: nothing to lose */
    return got ? nav_service_parse_exit(line) : NAV_EXIT_NONE;
}
