/* main.c -- mfns-nav, the MFNS flight program: the options (nav_opts.h),
 * then the program (nav_app.h) on its state, which lives here. */
#include <stdio.h>

#include "firmware/app/nav_app.h"
#include "firmware/app/nav_opts.h"

/* The program's whole state (tables, queue, cameras: a few MB), in static
 * storage so nothing is allocated after start-up; handed to nav_app_run. */
static nav_app_t g_app;

int main(int argc, char **argv)
{
    nav_opts_t o;
    const int rc = nav_opts_parse(argc, argv, &o, stdout, stderr);
    if (rc != 0) {
        return rc > 0 ? 0 : 2;
    }
    return nav_app_run(&g_app, &o);
}
