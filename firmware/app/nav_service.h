/* nav_service.h -- mfns-nav as a supervised service (docs/operations.md):
 * the systemd notify protocol, memory locking, and why the last run ended.
 *
 * Supervision: under systemd (Type=notify, WatchdogSec=; boards/sitss-nav/
 * mfns-nav.service) the program says READY=1 once the table is loaded and
 * the cameras are open, pings WATCHDOG=1 from the cycle loop at half the
 * watchdog interval (so a hung loop, not only a crash, is restarted by the
 * supervisor), reports STATUS= lines, and says STOPPING=1 at the end. Outside
 * systemd (no NOTIFY_SOCKET) every call does nothing. libsystemd's sd_notify
 * speaks the protocol; nothing blocks (one datagram).
 *
 * Memory: --mlock locks every page (mlockall MCL_CURRENT | MCL_FUTURE) after
 * start-up, so a page fault never stalls a cycle; refused (no CAP_IPC_LOCK, a
 * low RLIMIT_MEMLOCK) it says so on stderr once and runs on unlocked.
 * Real-time scheduling is the supervisor's job (CPUSchedulingPolicy=fifo in
 * the unit: the program runs the same under either).
 *
 * The last exit: the unit's ExecStopPost records how the previous run ended
 * (systemd's SERVICE_RESULT, EXIT_CODE, EXIT_STATUS) in a file; --last-exit
 * FILE reads it at start and the BOOT event carries it, so the ground sees
 * why the program restarted (a crash, a hang caught by the watchdog, a
 * kill). */
#ifndef MFNS_NAV_SERVICE_H
#define MFNS_NAV_SERVICE_H

#include <stdbool.h>
#include <stdint.h>

/* How the previous run ended (the BOOT event's arg1; the dictionary lists them). */
typedef enum {
    NAV_EXIT_NONE = 0,     /* first start, or no record */
    NAV_EXIT_CLEAN = 1,    /* exited 0 (stopped) */
    NAV_EXIT_FAILED = 2,   /* exited with a non-zero status */
    NAV_EXIT_SIGNAL = 3,   /* killed by a signal */
    NAV_EXIT_CORE = 4,     /* dumped core (a crash) */
    NAV_EXIT_WATCHDOG = 5, /* the supervisor's watchdog fired: the loop hung */
    NAV_EXIT_OTHER = 6,    /* a record the program does not know (timeout, resources, ...) */
} nav_exit_reason_t;

typedef struct {
    uint64_t watchdog_us;     /* the supervisor's interval, 0 = no watchdog */
    uint64_t last_ping_us;
    bool notify;              /* NOTIFY_SOCKET is set */
} nav_service_t;

/* Reads the environment (NOTIFY_SOCKET, WATCHDOG_USEC). */
void nav_service_init(nav_service_t *s);
/* READY=1 with a status line. */
void nav_service_ready(nav_service_t *s, const char *status);
/* WATCHDOG=1 when half the interval has passed since the last ping (now_us:
 * CLOCK_MONOTONIC). Called every cycle. */
void nav_service_alive(nav_service_t *s, uint64_t now_us);
/* Any notify message (e.g. "STATUS=..."; "READY=1\nSTATUS=..."). */
void nav_service_notify(nav_service_t *s, const char *msg);
/* STOPPING=1 with a status line. */
void nav_service_stopping(nav_service_t *s, const char *status);
/* mlockall; false (after one stderr line) when refused. */
bool nav_service_lock_memory(void);

/* The reason recorded in text (systemd's "SERVICE_RESULT EXIT_CODE EXIT_STATUS",
 * e.g. "watchdog killed ABRT", "exit-code exited 3", "success exited 0",
 * "signal killed KILL", "core-dump dumped SEGV"). Pure: unit-tested. */
nav_exit_reason_t nav_service_parse_exit(const char *text);
/* The same from a file; NAV_EXIT_NONE when it cannot be read. */
nav_exit_reason_t nav_service_read_exit(const char *path);

#endif /* MFNS_NAV_SERVICE_H */
