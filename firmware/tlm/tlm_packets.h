/* tlm_packets.h -- the MFNS telemetry packets and their encoding: one struct
 * per packet type in wire units, the CCSDS packet codec, and the wire-frame
 * encoder (CCSDS packet + CRC-16/CCITT-FALSE, COBS-stuffed, 0x00-terminated).
 * The flight program and the ground station share this code. Layouts, units
 * and codes: docs/telemetry.md.
 *
 * Fields are integers in named units so the wire is exact and the ground
 * prints exactly what was sent: _um = 0.001 mm, _udeg = 1e-6 deg,
 * _mpx = 0.001 px, _cdb = 0.01 dB, _us = microseconds, _permille = 0.1 %.
 * tlm_scale_i32/_u32/_u16 convert the flight code's floats with rounding
 * and saturation.
 */
#ifndef MFNS_TLM_PACKETS_H
#define MFNS_TLM_PACKETS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ccsds.h"
#include "cobs.h"
#include "tlm_err.h"

typedef enum {
    TLM_TYPE_NAV = 0,    /* navigation solution, every cycle */
    TLM_TYPE_CAMERA = 1, /* per-camera diagnostics, every cycle per camera */
    TLM_TYPE_HK = 2,     /* housekeeping, 1 Hz */
    TLM_TYPE_EVENT = 3,  /* events, when they happen */
    TLM_NUM_TYPES = 4
} tlm_type_t;

/* One APID per packet type. */
#define TLM_APID_NAV 0x101u
#define TLM_APID_CAMERA 0x102u
#define TLM_APID_HK 0x103u
#define TLM_APID_EVENT 0x104u

/* Payload sizes (bytes after the 12-byte CCSDS headers). The layouts are
 * those of the mission database ground/mdb/mfns_tm.xml (XTCE), which
 * tests/host/test_tlm_mdb.py holds this codec to. */
#define TLM_NAV_PAYLOAD_LEN 160u
#define TLM_CAMERA_PAYLOAD_LEN 22u
#define TLM_HK_PAYLOAD_LEN 76u
#define TLM_EVENT_PAYLOAD_LEN 16u
#define TLM_MAX_PAYLOAD 160u /* the largest payload: navigation */

/* Attitude quaternion on the wire: Q1.30 signed (value * 2^30), so every
 * component of a unit quaternion, 1.0 included, fits an int32 with a
 * resolution of 9.3e-10. */
#define TLM_Q30_SCALE 1073741824.0f
/* Values in the 6x6 pose covariance: the upper triangle, row-major. */
#define TLM_NAV_COV_DIM 6u
#define TLM_NAV_COV_N 21u
#define TLM_MAX_PACKET (TLM_CCSDS_HDR_LEN + TLM_MAX_PAYLOAD)
/* Decoded frame = packet + 2 CRC bytes; the receiver's buffer bound. */
#define TLM_MAX_FRAME (TLM_MAX_PACKET + 2u)
/* Bytes on the wire for the largest frame: COBS worst case + 0x00 delimiter. */
#define TLM_MAX_WIRE (TLM_COBS_MAX_ENCODED(TLM_MAX_FRAME) + 1u)

/* Navigation status. */
typedef enum { TLM_NAV_NO_FIX = 0, TLM_NAV_FIX = 1, TLM_NAV_DEGRADED = 2, TLM_NAV_STATUS_COUNT = 3 } tlm_nav_status_t;
/* Flight program mode. */
typedef enum {
    TLM_MODE_BOOT = 0,
    TLM_MODE_ACQUIRE = 1,
    TLM_MODE_TRACK = 2,
    TLM_MODE_SAFE = 3,
    TLM_MODE_STANDBY = 4, /* commanded standby (the uplink's SET_MODE) */
    TLM_MODE_COUNT = 5
} tlm_mode_t;
/* Camera link state (docs/telemetry.md 4.2). */
typedef enum {
    TLM_CAM_OK = 0,      /* frame used this cycle */
    TLM_CAM_LOST = 1,    /* no valid frame for MFNS_CAM_LOST_CYCLES cycles; being re-opened */
    TLM_CAM_OFF = 2,     /* given up (recovery exhausted), re-opened periodically */
    TLM_CAM_SKIPPED = 3, /* no usable frame this cycle: timeout, rejected, stale or out of step */
    TLM_CAM_ENDED = 4,   /* replay: its recorded frames ended before the others' */
    TLM_CAM_STATE_COUNT = 5
} tlm_cam_state_t;
#define TLM_NUM_CAMERAS 3u
/* Event codes (0 is never sent). */
typedef enum {
    TLM_EVT_BOOT = 1,             /* arg0 = software version, arg1 = board id */
    TLM_EVT_TABLE_LOADED = 2,     /* arg0 = table version, arg1 = table CRC-32 */
    TLM_EVT_TABLE_REFUSED = 3,    /* arg0 = loader error code, arg1 = table CRC-32 or 0 */
    TLM_EVT_CAMERA_LOST = 4,      /* subject = camera, arg0 = driver error code */
    TLM_EVT_CAMERA_RECOVERED = 5, /* subject = camera, arg0 = outage (ms) */
    TLM_EVT_MODE_CHANGE = 6,      /* arg0 = old mode, arg1 = new mode, subject = reason code */
    TLM_EVT_TLM_DROPPED = 7,      /* arg0 = frames dropped by the transmit queue since last event */
    TLM_EVT_CAMERA_STALE = 8,     /* subject = camera, arg0 = frame time - cycle time (us), arg1 = frame seq */
    TLM_EVT_CAMERA_OUT_OF_STEP = 9, /* subject = camera, arg0 = frame time - cycle time (us), arg1 = frame seq */
    TLM_EVT_FRAME_REJECTED = 10,  /* subject = camera, arg0 = driver error code, arg1 = frames rejected so far */
    TLM_EVT_CAMERA_ENDED = 11,    /* subject = camera, arg0 = last frame seq, arg1 = frames delivered */
    TLM_EVT_TLM_WRITE_ERROR = 12, /* arg0 = errno, arg1 = write errors so far */
    TLM_EVT_CMD_ACCEPTED = 13,    /* subject = opcode, arg0 = command sequence count, arg1 = per opcode */
    TLM_EVT_CMD_REJECTED = 14,    /* subject = opcode or 0, arg0 = sequence count or -1, arg1 = rejection code */
    TLM_EVT_CODE_COUNT = 15
} tlm_event_code_t;
typedef enum { TLM_SEV_INFO = 0, TLM_SEV_WARNING = 1, TLM_SEV_ERROR = 2, TLM_SEV_COUNT = 3 } tlm_severity_t;

typedef struct {
    uint32_t cycle;             /* navigation cycle counter (camera frame index) */
    uint8_t status;             /* tlm_nav_status_t */
    uint8_t reason;             /* why not FIX: the nav core's reason code, 0 = none */
    uint8_t mode;               /* tlm_mode_t */
    uint8_t beacons_used;       /* inlier beacons in the solution */
    uint8_t cams_used;          /* bit k set: camera k contributed (0 X, 1 Y, 2 Z) */
    uint8_t iterations;         /* solver iterations */
    uint16_t residual_rms_mpx;  /* inlier reprojection RMS, 0.001 px, saturates */
    int32_t pos_um[3];          /* r_wb_w (x, y, z), 0.001 mm */
    int32_t att_udeg[3];        /* 2-1-3 Euler of C_w_b (roll, pitch, yaw), 1e-6 deg */
    uint32_t sigma_pos_um[3];   /* 1-sigma of pos_um, 0.001 mm */
    uint32_t sigma_att_udeg[3]; /* 1-sigma of att_udeg, 1e-6 deg */
    int32_t q_q30[4];           /* unit quaternion (w, x, y, z) of C_b_w, w >= 0, Q1.30 (TLM_Q30_SCALE) */
    /* Pose covariance in ROS PoseWithCovariance order (x, y, z, rx, ry, rz:
     * r_wb_w in mm, attitude error about the world axes in deg), upper
     * triangle row-major (xx, xy, .. xrz, yy, .. rzrz): mm^2, mm deg, deg^2.
     * IEEE-754 binary32 big-endian on the wire; always finite. */
    float cov[TLM_NAV_COV_N];
} tlm_nav_t;

typedef struct {
    uint32_t cycle;
    uint8_t camera;             /* 0 X, 1 Y, 2 Z */
    uint8_t state;              /* tlm_cam_state_t */
    uint8_t blobs;              /* blobs found by the centroider (saturates at 255) */
    uint8_t beacons_identified; /* blobs matched to beacons */
    uint32_t exposure_us;
    int16_t gain_cdb;           /* 0.01 dB */
    uint32_t frame_seq;         /* the camera's frame sequence number */
    uint32_t frames_dropped;    /* cumulative, from sequence-number gaps */
} tlm_camera_t;

typedef struct {
    uint32_t cycle;
    uint8_t mode;               /* tlm_mode_t */
    uint16_t cpu_load_permille; /* 0..1000 */
    uint32_t cycle_p50_us;      /* cycle-time percentiles over the last report interval */
    uint32_t cycle_p95_us;
    uint32_t cycle_p99_us;
    uint32_t cycle_max_us;
    uint32_t n_cycles;          /* cumulative counters since boot */
    uint32_t n_fix;
    uint32_t n_no_fix;
    uint32_t n_tlm_dropped;     /* frames dropped by the transmit queue */
    uint32_t n_cam_errors;
    uint32_t table_crc32;       /* CRC-32 of the loaded calibration table, 0 = none */
    uint32_t n_acquire;         /* cumulative cycles that ran lost-in-space acquisition */
    uint32_t acq_units_max;     /* most acquisition work (units, acquire.h) of one cycle in the interval */
    uint32_t acq_units_last;    /* the work of the last acquisition cycle (own + carried search) */
    uint8_t acq_band_last;      /* rank window it reached (1, 2, 4, .. 32; 0 none) */
    uint8_t acq_best_last;      /* inliers of its best candidate (0 none) */
    uint32_t n_degraded;        /* cumulative DEGRADED solutions (n_fix counts FIX only) */
    uint32_t n_cmd_accepted;    /* telecommands accepted since boot (or RESET_COUNTERS) */
    uint32_t n_cmd_rejected;    /* telecommands rejected */
    uint16_t cmd_seq_last;      /* sequence count of the last accepted telecommand */
    uint8_t cams_enabled;       /* bit k set: camera k enabled (0x7 all) */
} tlm_hk_t;

typedef struct {
    uint32_t cycle;
    uint16_t code;    /* tlm_event_code_t */
    uint8_t severity; /* tlm_severity_t */
    uint8_t subject;  /* camera index, or code-specific (see tlm_event_code_t) */
    int32_t arg0;
    int32_t arg1;
} tlm_event_t;

typedef struct {
    tlm_type_t type;
    uint16_t seq;    /* CCSDS sequence count: written by tlm_frame_encode, read by the decoder */
    tlm_time_t time; /* CUC time of the data (the camera exposure for nav/camera) */
    union {
        tlm_nav_t nav;
        tlm_camera_t camera;
        tlm_hk_t hk;
        tlm_event_t event;
    } u;
} tlm_packet_t;

/* Per-APID 14-bit sequence counters of one sender. */
typedef struct {
    uint16_t next_seq[TLM_NUM_TYPES];
} tlm_encoder_t;

void tlm_encoder_init(tlm_encoder_t *enc);

uint16_t tlm_type_apid(tlm_type_t type);              /* 0 for an invalid type */
int tlm_apid_type(uint16_t apid);                     /* tlm_type_t, or TLM_ERR_APID */
size_t tlm_payload_len(tlm_type_t type);              /* 0 for an invalid type */
const char *tlm_type_name(tlm_type_t type);           /* "nav", "camera", "housekeeping", "event" */
const char *tlm_nav_status_name(uint8_t status);      /* "NO_FIX", "FIX", "DEGRADED", "?" */
const char *tlm_mode_name(uint8_t mode);              /* "BOOT", "ACQUIRE", "TRACK", "SAFE", "?" */
const char *tlm_cam_state_name(uint8_t state);        /* "OK", "LOST", "OFF", "SKIPPED", "ENDED", "?" */
const char *tlm_event_name(uint16_t code);            /* "BOOT", "TABLE_LOADED", ... "?" */
const char *tlm_severity_name(uint8_t severity);      /* "INFO", "WARNING", "ERROR", "?" */

/* The CCSDS packet (headers + payload, no CRC, no framing) with sequence count
 * seq. TLM_ERR_PAYLOAD when a field is out of range (unknown enum value,
 * camera > 2, a covariance value not finite), TLM_ERR_ARG for a bad type or seq > 16383. */
int tlm_packet_encode(const tlm_packet_t *pkt, uint16_t seq, uint8_t *out, size_t cap, size_t *out_len);
/* Parse one CCSDS packet of exactly len bytes. On error *out is zeroed and
 * the code says why; on success every field (and struct padding) is set. */
int tlm_packet_decode(const uint8_t *in, size_t len, tlm_packet_t *out);

/* The wire frame of one packet: COBS(packet || CRC16 big-endian) then 0x00.
 * Takes the next sequence count of the packet's APID from enc, writes it to
 * pkt->seq and advances the counter only on success. cap >= TLM_MAX_WIRE
 * always suffices. */
int tlm_frame_encode(tlm_encoder_t *enc, tlm_packet_t *pkt, uint8_t *out, size_t cap, size_t *out_len);

/* value * scale rounded to nearest (ties away from zero) and saturated to the
 * type; NaN gives 0 with *ok (if given) cleared; saturation also clears *ok. */
int32_t tlm_scale_i32(float value, float scale, bool *ok);
uint32_t tlm_scale_u32(float value, float scale, bool *ok);
uint16_t tlm_scale_u16(float value, float scale, bool *ok);

/* IEEE-754 binary32 <-> its big-endian wire bytes (bit copy, no rounding). */
void tlm_put_f32(uint8_t *p, float v);
float tlm_get_f32(const uint8_t *p);

#endif /* MFNS_TLM_PACKETS_H */
