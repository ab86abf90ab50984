/* main.c -- mfns-nav, the MFNS flight program (firmware/app/nav_app.h). */
#include <stdio.h>

#include "nav_app.h"

int main(int argc, char **argv)
{
    nav_app_opts_t o;
    const int rc = nav_app_parse_args(argc, argv, &o, stdout, stderr);
    if (rc != 0) {
        return rc > 0 ? 0 : 2;
    }
    return nav_app_run(&o);
}
