/* nav_app.c -- see nav_app.h. */
#define _DEFAULT_SOURCE /* sigaction, nanosleep under -std=c11 */

#include "firmware/app/nav_app.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "mfns_version.h"
#include "firmware/app/nav_cmds.h"
#include "firmware/app/nav_cmds_upload.h"
#include "firmware/app/nav_loop.h"
#include "firmware/app/nav_selftest.h"
#include "firmware/app/nav_tablestore.h"

#define NAV_APP_VERSION MFNS_VERSION_CODE /* the one version (mk/version.sh) */

/* The one mutable static: what a signal handler may touch. */
static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static void send_event_subject(nav_app_t *app, tlm_event_code_t code, tlm_severity_t sev, uint8_t subject, int32_t a0,
                               int32_t a1)
{
    const uint64_t t_us = app->clock_monotonic ? nav_app_now_us() : 0u;
    (void)nav_tlm_event(&app->tlm, 0, t_us, code, sev, subject, a0, a1); /* failures counted in tlm */
}

static void send_event(nav_app_t *app, tlm_event_code_t code, tlm_severity_t sev, int32_t a0, int32_t a1)
{
    /* start-up events: the flight clock now (CLOCK_MONOTONIC live; 0, the
     * first frame's time, in a replay) */
    const uint64_t t_us = app->clock_monotonic ? nav_app_now_us() : 0u;
    (void)nav_tlm_event(&app->tlm, 0, t_us, code, sev, 0, a0, a1); /* failures counted in tlm */
}

static void close_all(nav_app_t *app)
{
    nav_fixlog_close(&app->fixlog); /* no-op when not open */
    nav_cams_close(&app->cams);
    nav_tlm_flush_and_close(&app->tlm, app->cycle_now);
    nav_tc_in_close(&app->tc);
}

static void wait_status(nav_app_t *app, const nav_ts_start_t *info, mfns_caltable_status_t ts, const char *why,
                        bool ready)
{
    char status[NAV_TABLESTORE_PATH_MAX + 192];
    (void)snprintf(status, sizeof status,
                   "waiting for a calibration table: %s: %s%s%s; install one there or send TABLE_LOAD "
                   "(docs/operations.md \"First run\")",
                   info->path, mfns_caltable_strerror(ts), why != NULL ? ": " : "", why != NULL ? why : "");
    fprintf(stderr, "mfns-nav: %s\n", status); /* the journal, once per reason */
    char msg[sizeof status + 16];
    (void)snprintf(msg, sizeof msg, "%sSTATUS=%s", ready ? "READY=1\n" : "", status);
    nav_service_notify(&app->service, msg);
}

/* Supervised, no table: stay up and say why until one validates (nav_app.h).
 * 0 with the table in the current slot, or -1 when stopped by a signal. */
static int wait_for_table(nav_app_t *app, const nav_opts_t *o, nav_ts_start_t *info, mfns_caltable_status_t ts,
                          const char *why)
{
    mfns_caltable_t *table = &app->tables[app->table_cur];
    memset(table, 0, sizeof *table); /* housekeeping: no table (crc 0) */
    app->waiting_table = true;
    wait_status(app, info, ts, why, true);
    mfns_caltable_status_t last = ts;
    bool link_up = app->tlm.uart.connected;
    uint64_t last_try_us = nav_app_now_us(), last_hk_us = 0;
    const struct timespec tick = {0, (long)NAV_APP_WAIT_TICK_US * 1000L};
    while (!stop_requested && app->waiting_table) {
        (void)nanosleep(&tick, NULL); /* EINTR: a signal, seen at the loop's test */
        const uint64_t now = nav_app_now_us();
        const nav_cmd_ops_t ops = nav_cmds_ops_waiting(app);
        nav_cmds_upload_tick(app, now / 1000u); /* an idle upload abandoned */
        nav_tc_in_poll(&app->tc, &app->tlm.uart, &ops, now / 1000u); /* a TABLE_LOAD or UPLOAD_END ends the wait */
        if (app->waiting_table && now - last_try_us >= NAV_APP_WAIT_RETRY_US) {
            last_try_us = now;
            const mfns_caltable_status_t t2 = nav_tablestore_load_start(o->state_dir, o->table_path, app->table_buf,
                                                                        sizeof app->table_buf, table, info);
            if (t2 == MFNS_CALTABLE_OK) {
                app->waiting_table = false;
                fprintf(stderr, "mfns-nav: calibration table %s validated (crc %08x): starting\n", info->path,
                        table->crc32);
                break;
            }
            memset(table, 0, sizeof *table);
            if (t2 != last) { /* a new reason (the file appeared but is refused, ...): said once */
                last = t2;
                send_event(app, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, (int32_t)t2, 0);
                wait_status(app, info, t2, NULL, false);
            }
        }
        if (app->tlm.uart.connected && !link_up) { /* the ground just came: tell it why there is no fix */
            send_event(app, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, (int32_t)last, 0);
        }
        link_up = app->tlm.uart.connected;
        if (now - last_hk_us >= NAV_LOOP_HK_PERIOD_US) {
            nav_loop_housekeeping(app, 0u, 0u, app->clock_monotonic ? now : 0u); /* a replay: its first frame's time */
            last_hk_us = now;
        }
        nav_tlm_drain(&app->tlm, 0u, now / 1000u);
        nav_service_alive(&app->service, now);
    }
    if (app->waiting_table) {
        app->waiting_table = false;
        return -1;
    }
    nav_service_notify(&app->service, "STATUS=calibration table loaded: starting");
    return 0;
}

/* Everything that may fail hard, in order (nav_app.h). 0, or the exit code. */
static int start_up(nav_app_t *app, const nav_opts_t *o)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    if (sigaction(SIGINT, &sa, NULL) != 0 || sigaction(SIGTERM, &sa, NULL) != 0) {
        fprintf(stderr, "mfns-nav: cannot install signal handlers: %s\n", strerror(errno));
        return 2;
    }
    nav_tlm_init(&app->tlm);
    mfns_cycle_stats_reset(&app->stats);
    mfns_cycle_stats_reset(&app->latency);
    app->solver = o->solver;
    nav_cams_init(&app->cams, o->sync_window_us);
    if (nav_tlm_open(&app->tlm, o) != 0 || nav_tc_in_open(&app->tc, o) != 0) {
        mfns_uart_close(&app->tlm.uart);
        return 2;
    }
    app->t0_us = nav_app_now_us();
    app->clock_monotonic = o->backend != MFNS_CAM_BACKEND_REPLAY;
    nav_time_init(&app->time, app->clock_monotonic);
    /* BOOT says how the previous run ended (the service unit records it):
     * a restart after a crash or a hang is an event the ground sees */
    const nav_exit_reason_t last = nav_service_read_exit(o->last_exit);
    send_event_subject(app, TLM_EVT_BOOT, last == NAV_EXIT_NONE || last == NAV_EXIT_CLEAN ? TLM_SEV_INFO : TLM_SEV_WARNING,
                       (uint8_t)last, NAV_APP_VERSION, 0);
    if (o->tc_kind != NAV_TC_NONE) { /* the uplink's security, once: epoch 0 = not authenticated */
        send_event(app, TLM_EVT_TC_AUTH, app->tc.auth.insecure ? TLM_SEV_WARNING : TLM_SEV_INFO,
                   (int32_t)app->tc.auth.epoch, (int32_t)app->tc.auth.n_keys);
        if (app->tc.auth.insecure) {
            send_event(app, TLM_EVT_TC_UNPROTECTED, TLM_SEV_WARNING, o->tc_insecure_from_config ? 2 : 1, 0);
        } else if (app->tc.state_fault != TC_STATE_OK) {
            /* the uplink state: a wiped directory (missing) is told, damaged or unwritable warned */
            const int kind = app->tc.state_fault == TC_STATE_MISSING ? 0 : (app->tc.state_fault == TC_STATE_DAMAGED ? 1 : 2);
            send_event_subject(app, TLM_EVT_STORAGE_FAULT, kind == 0 ? TLM_SEV_INFO : TLM_SEV_WARNING, 0u,
                               app->tc.state_errno, kind);
            app->n_storage_errors += kind == 0 ? 0u : 1u;
        }
    }

    mfns_caltable_t *table = &app->tables[app->table_cur];
    app->state_dir = o->state_dir;
    app->budget_units = o->budget_units;
    nav_ts_start_t ts_info;
    const mfns_caltable_status_t ts =
        nav_tablestore_load_start(o->state_dir, o->table_path, app->table_buf, sizeof app->table_buf, table, &ts_info);
    nav_selftest_table(app, &ts_info, ts, ts == MFNS_CALTABLE_OK ? table->crc32 : 0u);
    if (ts != MFNS_CALTABLE_OK) {
        /* a file that cannot be opened: say why (missing, no permission), not only that */
        const char *why = ts == MFNS_CALTABLE_E_FILE_OPEN && access(ts_info.path, R_OK) != 0 ? strerror(errno) : NULL;
        fprintf(stderr, "mfns-nav: calibration table %s refused: %s%s%s (at byte %u)\n", ts_info.path,
                mfns_caltable_strerror(ts), why != NULL ? ": " : "", why != NULL ? why : "", ts_info.first_err_offset);
        send_event(app, TLM_EVT_TABLE_REFUSED, TLM_SEV_ERROR, (int32_t)ts, 0);
        if (!app->service.notify || wait_for_table(app, o, &ts_info, ts, why) != 0) {
            close_all(app); /* by hand: exit 2 (nav_app.h); supervised: stopped while waiting */
            return 2;
        }
    }
    if (ts_info.source != NAV_TS_SRC_INITIAL && o->verbose) {
        fprintf(stderr, "mfns-nav: table from the store: %s (crc %08x)\n", ts_info.path, table->crc32);
    }
    if (ts_info.initial_differs) {
        fprintf(stderr,
                "mfns-nav: --table %s differs from the stored table, which runs (%s, crc %08x); send TABLE_LOAD %s "
                "to switch\n",
                o->table_path, ts_info.path, table->crc32, o->table_path);
        send_event(app, TLM_EVT_TABLE_ARG_OVERRIDDEN, TLM_SEV_WARNING,
                   (int32_t)(ts_info.initial_size > INT32_MAX ? INT32_MAX : ts_info.initial_size), (int32_t)table->crc32);
    }
    send_event(app, TLM_EVT_TABLE_LOADED, TLM_SEV_INFO, table->format_version, (int32_t)table->crc32);
    nav_app_apply_budget(app, table);
    send_event_subject(app, TLM_EVT_CYCLE_BUDGET, TLM_SEV_INFO, (uint8_t)(app->budget_units != 0u ? 1 : 0), 0,
                       (int32_t)table->index.budget_units);
    nav_selftest_uart(app, o);
    app->tlm_opened_at_start = app->tlm.uart.connected;
    nav_selftest_clock(app);
    app->nav_filter_period_us = o->nav_filter_period_ms * 1000u;
    if (mfns_nav_init(&app->nav, table, o->solver) != MFNS_NAV_OK ||
        mfns_nav_enable_filter(&app->nav, app->nav_filter_period_us) != MFNS_NAV_OK) {
        close_all(app);
        return 2;
    }
    const int cams_rc = nav_cams_open(&app->cams, o, table);
    nav_selftest_cameras(app, o);
    nav_selftest_done(app);
    if (cams_rc != 0) {
        close_all(app);
        return 2;
    }
    if (o->fixlog_dir != NULL && nav_fixlog_open(&app->fixlog, o->fixlog_dir, o->fixlog_file_kb * 1024u, o->fixlog_files) != 0) {
        /* a storage fault degrades, never stops: navigation and telemetry go on without the log */
        fprintf(stderr, "mfns-nav: --fixlog %s: no fix log this run; navigating\n", o->fixlog_dir);
        send_event_subject(app, TLM_EVT_STORAGE_FAULT, TLM_SEV_WARNING, 1u, errno, 0);
        app->fixlog_open_failed = true;
    }
    if (o->have_init_pose) {
        const float *ip = o->init_pose;
        if (nav_app_set_prior(app, ip[0], ip[1], ip[2], ip[3], ip[4], ip[5]) != MFNS_NAV_OK) {
            fprintf(stderr, "mfns-nav: --init-pose refused\n");
            close_all(app);
            return 2;
        }
    }
    return 0;
}

static void print_summary(const nav_app_t *app, const char *why, uint32_t cycles, uint32_t lost_frames,
                          uint32_t produced, bool verbose)
{
    fprintf(stderr,
            "mfns-nav: stopped (%s) after %u cycles: %u fix, %u degraded, %u no fix, %u telemetry frames dropped\n",
            why, cycles, app->count.n_fix, app->count.n_degraded, app->count.n_no_fix, lost_frames);
    nav_cams_print_faults(&app->cams);
    if (app->tc.cmd.rx.frames > 0) {
        fprintf(stderr, "mfns-nav: commands: %u accepted, %u rejected (since boot or RESET_COUNTERS)\n",
                app->tc.cmd.n_accepted, app->tc.cmd.n_rejected);
        const tc_auth_t *a = &app->tc.auth;
        fprintf(stderr,
                "mfns-nav: authentication (epoch %u): %u passed, refused %u missing, %u unknown key, %u bad MAC, "
                "%u replayed, %u stale epoch, %u awaiting re-synchronisation, %u count exhausted; %u "
                "re-synchronisations\n",
                a->epoch, a->n_ok, a->n_rej[0], a->n_rej[1], a->n_rej[2], a->n_rej[3], a->n_rej[4], a->n_rej[5],
                a->n_rej[6], a->n_resync);
    }
    if (app->fixlog.dir[0] != '\0') {
        /* honest: only records on disk are "written" (issue 45: a full disk said 118 recorded) */
        fprintf(stderr, "mfns-nav: fix log %s: %u fixes written, %u lost to write errors (%u write errors), %u dropped\n",
                app->fixlog.dir, atomic_load(&app->fixlog.written_records), atomic_load(&app->fixlog.lost_records),
                atomic_load(&app->fixlog.write_errors), atomic_load(&app->fixlog.dropped_records));
    }
    if (verbose && app->latency.count > 0u) {
        fprintf(stderr,
                "mfns-nav: latency, frame stamp to nav packet out of the queue: median %.2f ms, p99 %.2f ms, "
                "max %.2f ms (%u cycles)\n",
                (double)mfns_cycle_stats_percentile(&app->latency, 50.0f) * 1e-3,
                (double)mfns_cycle_stats_percentile(&app->latency, 99.0f) * 1e-3, (double)app->latency.max_us * 1e-3,
                app->latency.count);
    }
    if (app->tlm.write_errors > 0 || lost_frames > 0) {
        fprintf(stderr, "mfns-nav: telemetry: %u frames produced, %u sent, %u lost (%u write errors)\n", produced,
                app->tlm.q.sent, lost_frames, app->tlm.write_errors);
    }
}

int nav_app_run(nav_app_t *app, const nav_opts_t *o)
{
    memset(app, 0, sizeof *app);
    nav_upload_init(&app->upload, app->upload_buf, (uint32_t)sizeof app->upload_buf, 0u);
    nav_service_init(&app->service);
    const int rc = start_up(app, o);
    if (rc != 0) {
        return rc;
    }
    /* housekeeping at start (n_cycles 0): its time correlation reaches the
     * ground before the first nav packet, so every packet of the run has the
     * flight's UTC (docs/telemetry.md "Time"), and the ground sees the table
     * and the cameras enabled before the first cycle */
    nav_loop_housekeeping(app, 0u, 0u, app->clock_monotonic ? nav_app_now_us() : 0u);
    if (o->mlock) {
        (void)nav_service_lock_memory(); /* refused: said on stderr, runs unlocked */
    }
    nav_service_ready(&app->service, "navigating");
    nav_tlm_drain(&app->tlm, app->cycle_now, nav_app_now_us() / 1000u);

    uint32_t cycles = 0;
    const char *why = nav_loop_run(app, o, &stop_requested, &cycles);
    nav_cams_release_held(&app->cams);
    /* The final report: stamped with the flight clock (the last cycle's
     * time, so time never runs backwards on the ground) and counting the
     * cycles that ran. */
    nav_loop_housekeeping(app, cycles > 0u ? cycles - 1u : 0u, cycles, app->last_t_us);
    nav_service_stopping(&app->service, why);
    close_all(app);
    /* Exact: every frame produced was sent, dropped by the queue, or is still
     * queued (never sent) now. */
    const uint32_t lost = app->tlm.q.dropped + (uint32_t)tlm_txq_frames(&app->tlm.q);
    const uint32_t produced = app->tlm.q.sent + lost;
    if (!o->quiet) {
        print_summary(app, why, cycles, o->tlm_kind == NAV_TLM_NONE ? app->tlm.q.dropped : lost, produced,
                      o->verbose);
    }
    if (app->tlm.write_errors > 0) {
        fprintf(stderr, "mfns-nav: telemetry incomplete: %u write errors (exit 3)\n", app->tlm.write_errors);
        return 3;
    }
    if (o->tlm_kind != NAV_TLM_NONE && produced > 0u && app->tlm.q.sent == 0u) {
        /* nothing reached the ground, which is a failure however cleanly the
         * loop ran (issue 24: it exited 0); the message says which way */
        const mfns_uart_t *u = &app->tlm.uart;
        if (app->tlm_opened_at_start || u->stats.reconnects > 0u) {
            fprintf(stderr,
                    "mfns-nav: telemetry %s opened but none of %u frames left the queue (%llu bytes written, %u short "
                    "writes, %u disconnects%s%s) (exit 3)\n",
                    o->tlm_target, produced, (unsigned long long)u->stats.bytes_written, u->stats.short_writes,
                    u->stats.disconnects, u->last_errno != 0 ? "; last error: " : "",
                    u->last_errno != 0 ? strerror(u->last_errno) : "");
            return 3;
        }
        fprintf(stderr, "mfns-nav: telemetry %s never opened (%s after %u attempts): none of %u frames sent (exit 3)\n",
                o->tlm_target, app->tlm.uart.last_errno != 0 ? strerror(app->tlm.uart.last_errno) : "not connected",
                app->tlm.uart.stats.open_failures, produced);
        return 3;
    }
    return 0;
}
