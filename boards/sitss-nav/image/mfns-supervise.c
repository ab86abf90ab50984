/* mfns-supervise -- the image's supervisor of mfns-nav (docs/operations.md
 * "The image"). The image has no systemd, so this program does for the flight
 * program what mfns-nav.service does on a Debian board, speaking the same
 * protocol so the program needs no change:
 *
 *   - it listens on a Unix datagram socket and passes its path in
 *     NOTIFY_SOCKET, with WATCHDOG_USEC and WATCHDOG_PID, exactly as systemd
 *     does; mfns-nav's sd_notify (nav_service.h) then sends READY=1, STATUS=,
 *     WATCHDOG=1 and STOPPING=1 to it;
 *   - crash: any exit is restarted after --restart-ms;
 *   - hang: once READY=1 arrived, a gap of --watchdog-ms without WATCHDOG=1
 *     (or no READY=1 within --start-timeout-ms) sends SIGABRT and SIGCONT (a
 *     SIGSTOPped process acts on no other signal), then SIGKILL after
 *     --kill-grace-ms;
 *   - why: how each run ended is written, in systemd's words
 *     ("SERVICE_RESULT EXIT_CODE EXIT_STATUS", e.g. "watchdog killed ABRT",
 *     "signal killed KILL", "exit-code exited 3"), to --exit-file, which the
 *     next run reads with --last-exit and reports in its BOOT event;
 *   - real time: the child runs SCHED_FIFO at --rt-prio with RLIMIT_MEMLOCK
 *     unlimited (so its --mlock works); when the kernel refuses either, one
 *     warning is logged and it runs without (never a failed start);
 *   - logs: its own lines and every line the child writes on stdout/stderr
 *     go to syslog (facility daemon), and to its stderr (the console);
 *   - only the child: notify datagrams are taken only from the child's pid
 *     (SO_PASSCRED, the kernel's SCM_CREDENTIALS: systemd's NotifyAccess=main);
 *     a ping from any other process is ignored and logged once per run;
 *   - its descendants: the child leads its own process group; the log pipe is
 *     read without blocking, so a descendant holding it open (a grandchild
 *     that inherited stdout) never delays the restart, and once the child is
 *     reaped whatever is left of its group is killed (systemd's
 *     KillMode=control-group, as far as a process group reaches: a
 *     descendant that left the group with setsid escapes it).
 *   - user (--user NAME, issue 44): after what needs root (the real-time
 *     policy, the memory-lock limit) the child drops root as mfns-nav.service
 *     does: the bounding set cut to CAP_SYS_NICE and CAP_IPC_LOCK, NAME's
 *     groups (setgroups: video, dialout), setgid, setuid with those two kept
 *     as ambient capabilities (so mfns-nav's --mlock works), no new
 *     privileges; any step refused and the child does not run (never as root
 *     by accident). The notify socket is then owned by NAME.
 *
 * Usage: mfns-supervise [options] -- PROGRAM [ARGS...]
 * SIGTERM/SIGINT: the child gets SIGTERM, is waited for (SIGKILL after the
 * grace) and the supervisor exits 0.
 */
#define _GNU_SOURCE /* sigabbrev_np, pipe2 */

#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <linux/capability.h>
#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <syslog.h>
#include <time.h>
#include <unistd.h>

#define POLL_MS 100                   /* the loop's tick: watchdog and exit checks */
#define LINE_MAX_BYTES 512            /* one log line of the child */
#define NOTIFY_MAX_BYTES 1024         /* one sd_notify datagram */
#define BURST_RESTARTS 5              /* more restarts than this within BURST_WINDOW_MS ... */
#define BURST_WINDOW_MS 30000
#define BURST_PAUSE_MS 10000          /* ... and the next start waits this long */
#define MAX_GROUPS 32                 /* supplementary groups of --user */

typedef struct {
    long watchdog_ms, restart_ms, start_timeout_ms, kill_grace_ms;
    int rt_prio;
    const char *socket_path, *exit_file;
    const char *user;                 /* --user: drop root to it in the child (NULL: stay root) */
    uid_t uid;
    gid_t gid;
    gid_t groups[MAX_GROUPS];
    int n_groups;
    char **argv;
} opts_t;

static volatile sig_atomic_t g_stop;

static void on_stop(int sig)
{
    (void)sig;
    g_stop = 1;
}

static int64_t now_ms(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts); /* CLOCK_MONOTONIC cannot fail */
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

static int usage(void)
{
    fprintf(stderr, "usage: mfns-supervise [--watchdog-ms N] [--restart-ms N] [--start-timeout-ms N]\n"
                    "         [--kill-grace-ms N] [--rt-prio N] [--user NAME] --socket PATH --exit-file PATH -- PROGRAM [ARGS]\n");
    return 2;
}

static bool parse_ms(const char *s, long *out)
{
    char *end = NULL;
    errno = 0;
    const long v = strtol(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < 0 || v > 3600000L) {
        return false;
    }
    *out = v;
    return true;
}

static int parse(int argc, char **argv, opts_t *o)
{
    *o = (opts_t){.watchdog_ms = 2000, .restart_ms = 1000, .start_timeout_ms = 30000, .kill_grace_ms = 2000,
                  .rt_prio = 50};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--") == 0) {
            o->argv = i + 1 < argc ? &argv[i + 1] : NULL;
            break;
        }
        if (i + 1 >= argc) {
            return usage();
        }
        const char *v = argv[++i];
        long n = 0;
        bool ok = true;
        if (strcmp(a, "--socket") == 0) {
            o->socket_path = v;
        } else if (strcmp(a, "--exit-file") == 0) {
            o->exit_file = v;
        } else if (strcmp(a, "--user") == 0) {
            o->user = v;
        } else if (strcmp(a, "--watchdog-ms") == 0) {
            ok = parse_ms(v, &o->watchdog_ms) && o->watchdog_ms > 0;
        } else if (strcmp(a, "--restart-ms") == 0) {
            ok = parse_ms(v, &o->restart_ms);
        } else if (strcmp(a, "--start-timeout-ms") == 0) {
            ok = parse_ms(v, &o->start_timeout_ms) && o->start_timeout_ms > 0;
        } else if (strcmp(a, "--kill-grace-ms") == 0) {
            ok = parse_ms(v, &o->kill_grace_ms);
        } else if (strcmp(a, "--rt-prio") == 0) {
            ok = parse_ms(v, &n) && n <= 99;
            o->rt_prio = (int)n;
        } else {
            ok = false;
        }
        if (!ok) {
            fprintf(stderr, "mfns-supervise: bad option %s %s\n", a, v);
            return usage();
        }
    }
    if (o->argv == NULL || o->socket_path == NULL || o->exit_file == NULL) {
        return usage();
    }
    return 0;
}

/* The notify socket: a datagram socket at a path only root can reach. */
static int notify_socket(const char *path)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    const size_t len = strlen(path);
    if (len >= sizeof sa.sun_path) {
        syslog(LOG_ERR, "notify socket path too long: %s", path);
        return -1;
    }
    memcpy(sa.sun_path, path, len + 1u);
    const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) {
        syslog(LOG_ERR, "notify socket: %m");
        return -1;
    }
    (void)unlink(path); /* a stale socket of a previous supervisor; absent is fine */
    const int on = 1;
    if (bind(fd, (const struct sockaddr *)&sa, sizeof sa) != 0 || chmod(path, 0600) != 0 ||
        setsockopt(fd, SOL_SOCKET, SO_PASSCRED, &on, sizeof on) != 0) {
        syslog(LOG_ERR, "notify socket %s: %m", path);
        (void)close(fd);
        return -1;
    }
    return fd;
}

/* --user: NAME's ids and groups, once, before any child (getpwnam may read files). */
static int resolve_user(opts_t *o)
{
    if (o->user == NULL) {
        return 0;
    }
    const struct passwd *pw = getpwnam(o->user);
    if (pw == NULL || pw->pw_uid == 0) {
        fprintf(stderr, "mfns-supervise: --user %s: no such user (or root)\n", o->user);
        return -1;
    }
    o->uid = pw->pw_uid;
    o->gid = pw->pw_gid;
    int n = MAX_GROUPS;
    if (getgrouplist(o->user, pw->pw_gid, o->groups, &n) < 0) {
        fprintf(stderr, "mfns-supervise: --user %s: more than %d groups\n", o->user, MAX_GROUPS);
        return -1;
    }
    o->n_groups = n;
    return 0;
}

/* In the child: root dropped as the unit does (header). 0, or -1 after a log line. */
static int drop_root(const opts_t *o)
{
    if (o->user == NULL) {
        return 0;
    }
    static const int keep[] = {CAP_SYS_NICE, CAP_IPC_LOCK};
    for (int c = 0; c <= CAP_LAST_CAP; c++) { /* bounding set: the two only (needs CAP_SETPCAP: before setuid) */
        if (c != CAP_SYS_NICE && c != CAP_IPC_LOCK && prctl(PR_CAPBSET_DROP, (unsigned long)c, 0UL, 0UL, 0UL) != 0 &&
            errno != EINVAL) {
            syslog(LOG_ERR, "--user: dropping capability %d from the bounding set: %m", c);
            return -1;
        }
    }
    if (setgroups((size_t)o->n_groups, o->groups) != 0 || setgid(o->gid) != 0) {
        syslog(LOG_ERR, "--user %s: setgroups/setgid: %m", o->user);
        return -1;
    }
    if (prctl(PR_SET_KEEPCAPS, 1UL, 0UL, 0UL, 0UL) != 0 || setuid(o->uid) != 0) {
        syslog(LOG_ERR, "--user %s: setuid: %m", o->user);
        return -1;
    }
    struct __user_cap_header_struct h = {.version = _LINUX_CAPABILITY_VERSION_3, .pid = 0};
    struct __user_cap_data_struct d[_LINUX_CAPABILITY_U32S_3];
    memset(d, 0, sizeof d);
    _Static_assert(CAP_SYS_NICE < 32 && CAP_IPC_LOCK < 32, "both capabilities in the first word");
    d[0].effective = d[0].permitted = d[0].inheritable = (1u << CAP_SYS_NICE) | (1u << CAP_IPC_LOCK);
    if (syscall(SYS_capset, &h, d) != 0) {
        syslog(LOG_ERR, "--user %s: capset: %m", o->user);
        return -1;
    }
    for (size_t i = 0; i < sizeof keep / sizeof keep[0]; i++) {
        if (prctl(PR_CAP_AMBIENT, (unsigned long)PR_CAP_AMBIENT_RAISE, (unsigned long)keep[i], 0UL, 0UL) != 0) {
            syslog(LOG_ERR, "--user %s: ambient capability %d: %m", o->user, keep[i]);
            return -1;
        }
    }
    if (prctl(PR_SET_NO_NEW_PRIVS, 1UL, 0UL, 0UL, 0UL) != 0 || setuid(0) == 0) {
        syslog(LOG_ERR, "--user %s: root not dropped", o->user); /* setuid(0) must fail now */
        return -1;
    }
    return 0;
}

/* The child: real-time priority and the memory-lock limit where permitted,
 * the notify environment, stdout/stderr into the log pipe, then exec. */
static void child_exec(const opts_t *o, int log_w)
{
    (void)setpgid(0, 0); /* its own process group: its descendants can be found and ended */
    const struct rlimit unlimited = {RLIM_INFINITY, RLIM_INFINITY};
    if (setrlimit(RLIMIT_MEMLOCK, &unlimited) != 0) {
        syslog(LOG_WARNING, "RLIMIT_MEMLOCK not raised (%m): --mlock may be refused");
    }
    if (o->rt_prio > 0) {
        const struct sched_param sp = {.sched_priority = o->rt_prio};
        if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) {
            syslog(LOG_WARNING, "SCHED_FIFO %d refused (%m): running at normal priority", o->rt_prio);
        }
    }
    if (drop_root(o) != 0) {
        _exit(127); /* never run the program as root when told not to */
    }
    char pid[24], usec[32];
    (void)snprintf(pid, sizeof pid, "%ld", (long)getpid());
    (void)snprintf(usec, sizeof usec, "%ld", o->watchdog_ms * 1000L);
    if (setenv("NOTIFY_SOCKET", o->socket_path, 1) != 0 || setenv("WATCHDOG_PID", pid, 1) != 0 ||
        setenv("WATCHDOG_USEC", usec, 1) != 0) {
        syslog(LOG_ERR, "setenv: %m");
        _exit(127);
    }
    if (dup2(log_w, STDOUT_FILENO) < 0 || dup2(log_w, STDERR_FILENO) < 0) {
        syslog(LOG_ERR, "dup2: %m");
        _exit(127);
    }
    (void)close(log_w);
    (void)execv(o->argv[0], o->argv);
    syslog(LOG_ERR, "exec %s: %m", o->argv[0]);
    _exit(127);
}

/* One datagram of the child: READY=1, WATCHDOG=1, STATUS=..., STOPPING=1. */
static void on_notify(char *msg, bool *ready, int64_t *last_ping, pid_t child)
{
    char *save = NULL;
    for (char *line = strtok_r(msg, "\n", &save); line != NULL; line = strtok_r(NULL, "\n", &save)) {
        if (strcmp(line, "READY=1") == 0) {
            if (!*ready) {
                syslog(LOG_INFO, "mfns-nav[%ld] ready", (long)child);
            }
            *ready = true;
            *last_ping = now_ms();
        } else if (strcmp(line, "WATCHDOG=1") == 0) {
            *last_ping = now_ms();
        } else if (strncmp(line, "STATUS=", 7) == 0) {
            syslog(LOG_INFO, "mfns-nav[%ld] status: %s", (long)child, line + 7);
        } else if (strcmp(line, "STOPPING=1") == 0) {
            syslog(LOG_INFO, "mfns-nav[%ld] stopping", (long)child);
        }
    }
}

/* One notify datagram, taken only when the kernel says it came from the child. */
static void recv_notify(int nfd, bool *ready, int64_t *last_ping, pid_t child, bool *foreign_said)
{
    char msg[NOTIFY_MAX_BYTES];
    union {
        struct cmsghdr align;
        char buf[CMSG_SPACE(sizeof(struct ucred))];
    } ctl;
    struct iovec iov = {.iov_base = msg, .iov_len = sizeof msg - 1};
    struct msghdr mh = {.msg_iov = &iov, .msg_iovlen = 1, .msg_control = ctl.buf, .msg_controllen = sizeof ctl.buf};
    const ssize_t n = recvmsg(nfd, &mh, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
    if (n <= 0) {
        return;
    }
    pid_t from = 0;
    for (struct cmsghdr *c = CMSG_FIRSTHDR(&mh); c != NULL; c = CMSG_NXTHDR(&mh, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_CREDENTIALS &&
            c->cmsg_len == CMSG_LEN(sizeof(struct ucred))) {
            struct ucred cr;
            memcpy(&cr, CMSG_DATA(c), sizeof cr);
            from = cr.pid;
        }
    }
    if (from != child) {
        if (!*foreign_said) {
            *foreign_said = true;
            syslog(LOG_WARNING, "notify datagram from pid %ld ignored: only mfns-nav[%ld] is heard", (long)from,
                   (long)child);
        }
        return;
    }
    msg[n] = '\0';
    on_notify(msg, ready, last_ping, child);
}

/* The child's output, line by line, into the log. buf keeps a partial line.
 * Never blocks (the read end is O_NONBLOCK: a descendant may hold the pipe).
 * Returns the bytes read (0: none now, or the end). */
static ssize_t on_log(int fd, char *buf, size_t *len, pid_t child)
{
    const ssize_t n = read(fd, buf + *len, LINE_MAX_BYTES - 1 - *len);
    if (n <= 0) {
        return 0;
    }
    *len += (size_t)n;
    buf[*len] = '\0';
    char *start = buf;
    for (char *nl = strchr(start, '\n'); nl != NULL; nl = strchr(start, '\n')) {
        *nl = '\0';
        syslog(LOG_NOTICE, "mfns-nav[%ld]: %s", (long)child, start);
        start = nl + 1;
    }
    size_t rest = *len - (size_t)(start - buf);
    if (rest == LINE_MAX_BYTES - 1) { /* a line longer than the buffer: log it in pieces */
        syslog(LOG_NOTICE, "mfns-nav[%ld]: %s", (long)child, start);
        rest = 0;
    }
    memmove(buf, start, rest);
    *len = rest;
    return n;
}

/* systemd's words for how a run ended (nav_service_parse_exit reads them). */
static void record_exit(const char *path, int status, bool watchdog, bool timeout)
{
    char text[96];
    if (WIFEXITED(status)) {
        const int code = WEXITSTATUS(status);
        (void)snprintf(text, sizeof text, "%s exited %d", code == 0 ? "success" : "exit-code", code);
    } else {
        const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
        const char *name = sigabbrev_np(sig);
        const char *result = watchdog ? "watchdog" : timeout ? "timeout" : WCOREDUMP(status) ? "core-dump" : "signal";
        (void)snprintf(text, sizeof text, "%s %s %s", result, WCOREDUMP(status) ? "dumped" : "killed",
                       name ? name : "UNKNOWN");
    }
    syslog(WIFEXITED(status) && WEXITSTATUS(status) == 0 ? LOG_INFO : LOG_WARNING, "mfns-nav ended: %s", text);
    char tmp[512];
    (void)snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (f == NULL || fprintf(f, "%s\n", text) < 0 || fclose(f) != 0 || rename(tmp, path) != 0) {
        syslog(LOG_ERR, "cannot record the exit in %s: %m", path);
    }
}

/* One run: start, watch, reap. Returns false when the supervisor is to stop. */
static bool run_once(const opts_t *o, int nfd)
{
    int pipefd[2];
    if (pipe2(pipefd, O_CLOEXEC) != 0) {
        syslog(LOG_ERR, "pipe: %m");
        return !g_stop;
    }
    const pid_t child = fork();
    if (child < 0) {
        syslog(LOG_ERR, "fork: %m");
        (void)close(pipefd[0]);
        (void)close(pipefd[1]);
        return !g_stop;
    }
    if (child == 0) {
        child_exec(o, pipefd[1]); /* does not return */
    }
    (void)close(pipefd[1]);
    (void)setpgid(child, child); /* as the child does: no race with its exec */
    const int fl = fcntl(pipefd[0], F_GETFL);
    if (fl < 0 || fcntl(pipefd[0], F_SETFL, fl | O_NONBLOCK) != 0) {
        syslog(LOG_WARNING, "log pipe not made non-blocking: %m");
    }
    syslog(LOG_INFO, "started mfns-nav[%ld]", (long)child);
    const int64_t started = now_ms();
    int64_t last_ping = started, kill_at = -1;
    bool ready = false, watchdog = false, timeout = false, terminating = false, foreign_said = false;
    char logbuf[LINE_MAX_BYTES];
    size_t loglen = 0;
    int status = 0;
    for (;;) { /* until the child has been reaped */
        struct pollfd p[2] = {{.fd = nfd, .events = POLLIN}, {.fd = pipefd[0], .events = POLLIN}};
        const int pr = poll(p, 2, POLL_MS);
        if (pr > 0 && (p[0].revents & POLLIN)) {
            recv_notify(nfd, &ready, &last_ping, child, &foreign_said);
        }
        if (pr > 0 && (p[1].revents & (POLLIN | POLLHUP))) {
            (void)on_log(pipefd[0], logbuf, &loglen, child);
        }
        const pid_t w = waitpid(child, &status, WNOHANG);
        if (w == child) {
            break;
        }
        const int64_t t = now_ms();
        if (g_stop && !terminating) {
            terminating = true;
            syslog(LOG_INFO, "stopping mfns-nav[%ld] (SIGTERM)", (long)child);
            (void)kill(child, SIGTERM);
            (void)kill(child, SIGCONT);
            kill_at = t + o->kill_grace_ms;
        }
        if (!terminating && !watchdog && !timeout) {
            if (ready && t - last_ping > o->watchdog_ms) {
                watchdog = true;
                syslog(LOG_WARNING, "mfns-nav[%ld]: watchdog: no ping for %lld ms (limit %ld): SIGABRT", (long)child,
                       (long long)(t - last_ping), o->watchdog_ms);
            } else if (!ready && t - started > o->start_timeout_ms) {
                timeout = true;
                syslog(LOG_WARNING, "mfns-nav[%ld]: not ready after %ld ms: SIGABRT", (long)child,
                       o->start_timeout_ms);
            }
            if (watchdog || timeout) {
                (void)kill(child, SIGABRT);
                (void)kill(child, SIGCONT); /* a stopped process acts on SIGABRT only once continued */
                kill_at = t + o->kill_grace_ms;
            }
        }
        if (kill_at >= 0 && t > kill_at) {
            syslog(LOG_WARNING, "mfns-nav[%ld] still there after %ld ms: SIGKILL", (long)child, o->kill_grace_ms);
            (void)kill(child, SIGKILL);
            kill_at = -1;
        }
    }
    /* its descendants go with it (a grandchild holding the log pipe, a
     * forgotten helper): the group is ended, never waited for */
    if (kill(-child, SIGKILL) == 0) {
        syslog(LOG_WARNING, "mfns-nav[%ld] left processes in its group: killed", (long)child);
    }
    for (int i = 0; i < 64 && on_log(pipefd[0], logbuf, &loglen, child) > 0; i++) {
        /* what is left in the pipe: bounded, never blocking */
    }
    (void)close(pipefd[0]);
    record_exit(o->exit_file, status, watchdog, timeout);
    return !g_stop;
}

static void sleep_ms(long ms)
{
    const int64_t until = now_ms() + ms;
    while (!g_stop && now_ms() < until) { /* bounded by the deadline; a signal ends it early */
        (void)poll(NULL, 0, POLL_MS);
    }
}

int main(int argc, char **argv)
{
    opts_t o;
    const int rc = parse(argc, argv, &o);
    if (rc != 0) {
        return rc;
    }
    openlog("mfns-supervise", LOG_PID | LOG_PERROR, LOG_DAEMON);
    struct sigaction sa = {.sa_handler = on_stop};
    (void)sigemptyset(&sa.sa_mask);
    if (sigaction(SIGTERM, &sa, NULL) != 0 || sigaction(SIGINT, &sa, NULL) != 0) {
        syslog(LOG_ERR, "sigaction: %m");
        return 1;
    }
    if (resolve_user(&o) != 0) {
        return 2;
    }
    const int nfd = notify_socket(o.socket_path);
    if (nfd < 0) {
        return 1;
    }
    if (o.user != NULL && chown(o.socket_path, o.uid, o.gid) != 0) { /* the child, as --user, sends to it */
        syslog(LOG_ERR, "notify socket %s: chown: %m", o.socket_path);
        return 1;
    }
    syslog(LOG_INFO, "supervising %s: watchdog %ld ms, restart after %ld ms, SCHED_FIFO %d", o.argv[0], o.watchdog_ms,
           o.restart_ms, o.rt_prio);
    int64_t burst[BURST_RESTARTS] = {0};
    unsigned runs = 0;
    while (run_once(&o, nfd)) { /* until SIGTERM */
        const int64_t t = now_ms();
        const int64_t oldest = burst[runs % BURST_RESTARTS];
        burst[runs % BURST_RESTARTS] = t;
        runs++;
        long pause = o.restart_ms;
        if (runs > BURST_RESTARTS && t - oldest < BURST_WINDOW_MS) {
            syslog(LOG_WARNING, "%d restarts within %d ms: pausing %d ms", BURST_RESTARTS, BURST_WINDOW_MS,
                   BURST_PAUSE_MS);
            pause = BURST_PAUSE_MS;
        }
        sleep_ms(pause);
        if (g_stop) {
            break;
        }
    }
    (void)close(nfd);
    (void)unlink(o.socket_path);
    syslog(LOG_INFO, "stopped");
    return 0;
}
