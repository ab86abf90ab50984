/* main.c -- mfns-ground: the MFNS telemetry ground station (see ground.h,
 * docs/telemetry.md) with its command uplink and UDP side (uplink.h,
 * docs/uplink.md). */
#include <stdio.h>
#include <string.h>

#include "ground/ground.h"
#include "ground/uplink.h"

int main(int argc, char **argv)
{
    static char *rest[512];
    static uplink_t up; /* static: the command queue holds 4 kB */
    uplink_opts_t uo;
    int n_rest = 0;
    if (argc >= (int)(sizeof rest / sizeof rest[0]) || uplink_parse_args(argc, argv, &uo, rest, &n_rest, stderr) != 0) {
        return 2;
    }
    ground_opts_t o;
    const int rc = ground_parse_args(n_rest, rest, &o, stderr);
    if (rc != 0) {
        for (int i = 1; rc > 0 && i < n_rest; i++) {
            if (strcmp(rest[i], "--help") == 0 || strcmp(rest[i], "-h") == 0) {
                uplink_usage(stdout);
                break;
            }
        }
        return rc > 0 ? 0 : 2;
    }
    if (uo.out == UPLINK_OUT_LINK && o.src != GROUND_SRC_TTY && o.src != GROUND_SRC_SERIAL) {
        fprintf(stderr, "mfns-ground: --uplink sends on the source link: give --tty or --serial\n");
        return 2;
    }
    if (!uplink_wanted(&uo)) {
        return ground_run(&o, NULL);
    }
    uo.out_dir = o.out_dir;
    uo.baud = o.baud;
    uo.quiet = o.quiet != 0;
    if (uplink_open(&up, &uo) != 0) {
        return 1;
    }
    o.hooks = &up.hooks;
    o.source_rw = uo.out == UPLINK_OUT_LINK;
    const int run = ground_run(&o, NULL);
    const int cl = uplink_close(&up);
    return run != 0 ? run : cl;
}
