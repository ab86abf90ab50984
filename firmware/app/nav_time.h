/* nav_time.h -- UTC for the flight clock: the time correlation housekeeping
 * carries (hk_utc_s, hk_utc_us, hk_time_quality; docs/telemetry.md "Time").
 *
 * Every packet is stamped with the flight clock: the capture time of the
 * cycle's frames (CLOCK_MONOTONIC for V4L2 and libcamera, whose buffer stamps
 * are monotonic; the recorded time of a replay), or the program's clock when
 * no camera delivered. That clock has no calendar: a ground system that reads
 * it as UNIX time puts every run on 1970-01-01. So each housekeeping packet
 * pairs its own flight time with UTC, in the manner of CCSDS time
 * correlation, and the ground maps every packet's flight time to UTC with the
 * latest pair (mfns-ground: the utc and time_source columns, and the times it
 * forwards to Yamcs).
 *
 * The pair: for a monotonic flight clock, UTC(t) = UTC(now) - (mono(now) - t),
 * read back to back (each housekeeping pairs afresh: the ground follows the
 * clocks' drift); for a replay, whose recorded times are not on this board's
 * clock, the recording's first paired time is anchored to the moment it is
 * flown and every later pair keeps that offset (a replay appears at the time
 * it ran, as if flown in real time, and its UTC never goes back however fast
 * the replay runs). The quality says what the UTC is
 * worth: NONE when the board's clock was never set (before 2020-01-01: no
 * board in service is), SYNCED when the kernel reports the clock synchronised
 * (ntp_adjtime: not TIME_ERROR, STA_UNSYNC clear: NTP, PTP or GNSS via chrony),
 * else SYSTEM (set, not known to be synchronised). Nothing blocks; two clock
 * reads and one adjtimex call per housekeeping packet. */
#ifndef MFNS_NAV_TIME_H
#define MFNS_NAV_TIME_H

#include <stdbool.h>
#include <stdint.h>

/* 2020-01-01T00:00:00Z in UNIX seconds: a realtime clock before it was never set. */
#define NAV_TIME_UTC_PLAUSIBLE_S 1577836800LL

typedef struct {
    uint32_t utc_s;  /* UNIX seconds (0 with quality NONE) */
    uint32_t utc_us; /* 0..999999 */
    uint8_t quality; /* tlm_time_quality_t */
} nav_time_pair_t;

/* The pair from given clock readings (pure: unit-tested). utc_now_us: UTC
 * now (us since 1970); mono_now_us: the monotonic clock now; t_flight_us: the
 * packet's flight time; monotonic: the flight clock is the monotonic clock
 * (false: a replay's recorded time); synced: the kernel says synchronised. */
nav_time_pair_t nav_time_correlate(int64_t utc_now_us, uint64_t mono_now_us, uint64_t t_flight_us, bool monotonic,
                                   bool synced);

/* The kernel's clock discipline as adjtimex reports it, reduced to what
 * housekeeping carries (hk_time_quality, hk_time_error_us, hk_time_offset_us). */
#define NAV_TIME_ERROR_UNKNOWN_US UINT32_MAX /* not synchronised: no error bound */
typedef struct {
    bool synced;         /* not TIME_ERROR, STA_UNSYNC clear */
    uint32_t error_us;   /* esterror, or NAV_TIME_ERROR_UNKNOWN_US when not synced */
    int32_t offset_us;   /* the discipline's offset (us; STA_NANO: ns / 1000), 0 when not synced */
} nav_time_sync_t;

/* From adjtimex's return (state), status bits, esterror (us), offset (us, or
 * ns when STA_NANO is set). Pure: unit-tested with made-up readings. */
nav_time_sync_t nav_time_sync_from(int state, int status, long esterror_us, long offset);

/* A clock step: CLOCK_REALTIME moved against CLOCK_MONOTONIC between two
 * cycles by more than this (a time daemon's step, a manual date; a slew is
 * at most 500 ppm, 0.05 ms in 100 ms, far below). */
#define NAV_TIME_STEP_THRESHOLD_US 100000LL

/* The correlation state of one run (caller-owned): a replay's anchor, and
 * the last clock pair the step watch compares against. */
typedef struct {
    bool monotonic;      /* the flight clock is CLOCK_MONOTONIC (else a recording's time) */
    bool anchored;       /* replay: the offset below is set */
    int64_t offset_us;   /* replay: UTC - recorded time, from the first pair */
    bool have_last;      /* step watch: a previous reading */
    int64_t last_utc_us; /* CLOCK_REALTIME at the previous reading */
    uint64_t last_mono_us; /* CLOCK_MONOTONIC at the previous reading */
    uint32_t n_steps;    /* steps seen since start */
} nav_time_t;

/* The step watch, from given readings (pure: unit-tested). Returns the step,
 * us (UTC's advance minus the monotonic clock's), when its magnitude is above
 * NAV_TIME_STEP_THRESHOLD_US (and counts it in n_steps), else 0. The first
 * reading only primes it. */
int64_t nav_time_step_check(nav_time_t *t, int64_t utc_now_us, uint64_t mono_now_us);

/* The same from this board's clocks (called once per cycle; two clock reads). */
int64_t nav_time_step_now(nav_time_t *t);

/* The kernel's synchronisation state now (one adjtimex call). */
nav_time_sync_t nav_time_sync_now(void);

void nav_time_init(nav_time_t *t, bool monotonic);

/* The pair for flight time t_flight_us now, from this board's clocks (a
 * replay: from its anchor, set by the first call that has UTC). */
nav_time_pair_t nav_time_pair_now(nav_time_t *t, uint64_t t_flight_us);

#endif /* MFNS_NAV_TIME_H */
