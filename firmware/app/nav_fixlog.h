/* nav_fixlog.h -- the fix record (docs/self_survey.md): for every usable fix,
 * what it used (camera, beacon survey id, measured centroid and its
 * covariance: one FIXOBS packet, APID 261, per inlier association) and the
 * pose it gave (the cycle's NAV packet, pose and full covariance), kept in a
 * bounded on-board log for the ground's self-survey (`mfns map refine`).
 *
 * The format is the telemetry dictionary's (contract/mfns_tm.xml):
 * the log is a stream of the same wire frames the link carries (CCSDS packet,
 * CRC-16, COBS, 0x00), so the ground reads it with the same dictionary, and
 * the downlink carries the same records at a low rate (nav_loop.c: about one
 * fix per second; docs/telemetry.md section 5 has the budget).
 *
 * Never blocking the cycle: nav_fixlog_record only encodes into a scratch of
 * its own and copies the record into a preallocated ring (single producer, the
 * loop; single consumer, a writer thread that does every file operation). A
 * record that does not fit whole is dropped and counted (dropped_records),
 * never waited for. Rotation: files fixlog_NNNNNN.tlm in DIR, a new one when
 * the current holds NAV_FIXLOG_FILE_BYTES or more (always at a record boundary:
 * the writer appends its whole batch of records first, so a file can pass the
 * limit by up to NAV_FIXLOG_RING_BYTES), the oldest deleted so that at most
 * NAV_FIXLOG_FILES remain: on disk at most FILES x (FILE_BYTES + RING_BYTES). Write errors are
 * counted (write_errors, and the records they cost in lost_records; only
 * records on disk count as written_records) and the record given up; the loop
 * never sees them (housekeeping n_fixlog_errors and a STORAGE_FAULT event do).
 *
 * What it misses: records dropped while the ring is full (a stalled disk) are
 * gone (counted); a crash loses what the ring held (at most the ring's size,
 * about NAV_FIXLOG_RING_BYTES / 700 fixes).
 */
#ifndef MFNS_NAV_FIXLOG_H
#define MFNS_NAV_FIXLOG_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/nav/cycle/nav_cycle.h"
#include "firmware/tlm/tlm_packets.h"

/* One fix: its NAV frame and one FIXOBS frame per association. */
#define NAV_FIXLOG_MAX_ASSOC (MFNS_NUM_CAMERAS * MFNS_MAX_OBS_PER_CAMERA)
#define NAV_FIXLOG_MAX_RECORD ((NAV_FIXLOG_MAX_ASSOC + 1u) * TLM_MAX_WIRE)
/* About 700 bytes per fix of 12 beacons at 18.6 Hz: 13 kB/s, so the ring holds
 * about 20 s of fixes while the writer is held up. */
#define NAV_FIXLOG_RING_BYTES (256u * 1024u)
#define NAV_FIXLOG_FILE_BYTES (8u * 1024u * 1024u) /* ~10 min of fixes per file */
#define NAV_FIXLOG_FILES 16u                       /* kept: ~2.5 h of flight, 128 MiB */
#define NAV_FIXLOG_PATH_MAX 512u
#define NAV_FIXLOG_REC_SLOTS 16384u /* ring bytes / slots = 16 < the smallest record (two frames) */

_Static_assert(NAV_FIXLOG_MAX_ASSOC <= 255u, "fix_index and fix_count are u8 on the wire");
_Static_assert(NAV_FIXLOG_RING_BYTES >= 4u * NAV_FIXLOG_MAX_RECORD, "the ring holds several worst-case fixes");
_Static_assert(NAV_FIXLOG_RING_BYTES / NAV_FIXLOG_REC_SLOTS < 2u * (TLM_CCSDS_HDR_LEN + 3u), "a record (two frames at least) is longer than a length slot's share of the ring");

typedef struct {
    bool open;
    char dir[NAV_FIXLOG_PATH_MAX];
    uint32_t file_bytes_max;
    uint32_t files_max;
    tlm_encoder_t enc; /* the log's own sequence counters (the link keeps its own) */
    uint8_t scratch[NAV_FIXLOG_MAX_RECORD];
    uint8_t ring[NAV_FIXLOG_RING_BYTES];
    atomic_size_t head; /* bytes ever written by the loop (mod ring when indexing) */
    atomic_size_t tail; /* bytes ever taken by the writer */
    atomic_uint records, dropped_records, write_errors;
    /* honest counts (issue 45): records queued (records) are not records
     * written: the writer counts each record it wrote (written_records) or
     * could not write (lost_records: a full or read-only disk); it knows the
     * records of a batch by the length ring below */
    atomic_uint written_records, lost_records;
    uint32_t rec_len[NAV_FIXLOG_REC_SLOTS]; /* length of each record in the ring, in order */
    atomic_size_t rec_head;                 /* records ever published (the loop) */
    size_t rec_tail;                        /* writer side: records accounted for */
    size_t rec_bytes_left;                  /* writer side: bytes of the record at rec_tail not yet taken */
    atomic_bool stop;
    pthread_t thread;
    /* writer-thread side only */
    int fd;
    uint32_t file_no;  /* number of the file being written */
    uint64_t in_file;  /* bytes in it */
} nav_fixlog_t;

/* The FIXOBS packets of a usable fix (status OK or DEGRADED): one per inlier
 * association of out->sol over obs (used 1), beacons named by their survey
 * id in map; then (gate_px > 0) every other blob associated with the beacon
 * predicted nearest at the fix's pose within gate_px that no blob of its
 * camera is associated with (used 0: a beacon the fix gated out or integrity
 * holds out is exactly what the self-survey must see). Returns how many were
 * written to pkts (at most max; 0 for no fix). */
unsigned nav_fixlog_packets(const mfns_nav_output_t *out, const mfns_obs_frame_t *obs, const mfns_rig_t *rig,
                            const mfns_beacon_map_t *map, float gate_px, uint32_t cycle, uint64_t t_us,
                            tlm_packet_t *pkts, unsigned max);

/* Start the log in dir (created if absent; existing fixlog files there are
 * counted in the rotation). file_bytes 0 / files 0: the defaults above.
 * 0, or -1 after one line on stderr (the directory cannot be made, the
 * thread cannot start). */
int nav_fixlog_open(nav_fixlog_t *l, const char *dir, uint32_t file_bytes, uint32_t files);

/* Record a cycle: nothing unless nav_pkt is a usable fix; else its NAV frame
 * and FIXOBS frames go into the ring whole, or the record is dropped and
 * counted. Returns true when recorded. Never blocks; l may be closed. */
bool nav_fixlog_record(nav_fixlog_t *l, const tlm_packet_t *nav_pkt, const tlm_packet_t *fix, unsigned n_fix);

/* Stop: the writer empties the ring, closes the file and ends. */
void nav_fixlog_close(nav_fixlog_t *l);

#endif /* MFNS_NAV_FIXLOG_H */
