/* main.c -- mfns-ground: the MFNS telemetry ground station (see ground.h,
 * docs/telemetry.md). */
#include <stdio.h>

#include "ground.h"

int main(int argc, char **argv)
{
    ground_opts_t o;
    const int rc = ground_parse_args(argc, argv, &o, stderr);
    if (rc != 0) {
        return rc > 0 ? 0 : 2;
    }
    return ground_run(&o, NULL);
}
