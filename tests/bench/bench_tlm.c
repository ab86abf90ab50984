/* Throughput of the telemetry codec on this machine: frames encoded per
 * second and bytes decoded per second by the streaming decoder, against the
 * link's need (3.6 kB/s at 18.6 Hz, docs/telemetry.md section 5). */
#define _DEFAULT_SOURCE

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "firmware/tlm/tlm_decoder.h"
#include "firmware/tlm/tlm_packets.h"
#include "firmware/tlm/tlm_txq.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static uint8_t g_stream[4u << 20];

int main(void)
{
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    tlm_packet_t p;
    memset(&p, 0, sizeof p);
    p.type = TLM_TYPE_NAV;
    p.u.nav.status = TLM_NAV_FIX;
    p.u.nav.mode = TLM_MODE_TRACK;
    size_t pos = 0;
    unsigned long frames = 0;
    const double t0 = now_s();
    while (pos + TLM_MAX_WIRE <= sizeof g_stream) {
        p.u.nav.cycle = (uint32_t)frames;
        p.u.nav.pos_um[0] = (int32_t)(frames * 7u);
        size_t n = 0;
        if (tlm_frame_encode(&enc, &p, g_stream + pos, sizeof g_stream - pos, &n) != TLM_OK) {
            return 1;
        }
        pos += n;
        frames++;
    }
    const double t1 = now_s();
    static tlm_decoder_t d;
    tlm_decoder_init(&d);
    unsigned long got = 0;
    for (size_t i = 0; i < pos; i++) {
        tlm_packet_t q;
        got += tlm_decoder_push(&d, g_stream[i], &q) == 1;
    }
    const double t2 = now_s();
    if (got != frames) {
        fprintf(stderr, "bench-tlm: decoded %lu of %lu frames\n", got, frames);
        return 1;
    }
    const double need = 3627.7; /* bytes/s of the full telemetry load */
    printf("bench-tlm: encode %.0f nav frames/s (%.2f us/frame); decode %.1f MB/s (%.0fx the 18.6-Hz load)\n",
           (double)frames / (t1 - t0), 1e6 * (t1 - t0) / (double)frames, (double)pos / (t2 - t1) / 1e6,
           (double)pos / (t2 - t1) / need);
    printf("bench-tlm: static RAM: tlm_decoder_t %zu B, tlm_txq_t %zu B, tlm_encoder_t %zu B\n",
           sizeof(tlm_decoder_t), sizeof(tlm_txq_t), sizeof(tlm_encoder_t));
    return 0;
}
