/*
 * Telemetry downlink payload (format version 1) and the loop's compute-time window, as
 * flightcode/telemetry.py; docs/telemetry.md documents the 90 bytes (little-endian, fixed
 * layout: <BBHIH10f4H4f8H). One payload per XBee TX16 frame, every telemetry.divider-th sample.
 */
#ifndef FW_TELEMETRY_H
#define FW_TELEMETRY_H

#include <stdint.h>

#define TELEMETRY_VERSION 1
#define TELEMETRY_PAYLOAD_LEN 90

/* Bits of the flags field. */
enum {
    TM_RC_VALID = 0x0001,           /* a good RC frame within failsafe.rc_loss_s */
    TM_ADC_VALID = 0x0002,          /* this sample's ADC read succeeded */
    TM_MIXER_SATURATED = 0x0004,    /* the mixer clipped this sample */
    TM_BARO_REF_READY = 0x0008,     /* the boot pressure reference is fixed */
    TM_ACCEL_FROM_XSENS = 0x0010,   /* vertical acceleration from the XSENS (configured, or the ADXL335's offset moved) */
    TM_PAPER_LITERAL_LAW = 0x0020,  /* attitude.law = "paper_literal" */
    TM_IMU_SAMPLES_SKIPPED = 0x0040, /* the loop fell behind and skipped samples in this window */
    TM_BARO_MOTION_REFUSED = 0x0080 /* the barometer's motion disagrees with the accelerometers' */
};

/* Everything one frame carries (body FRD, world NED, z up); counters are totals since boot. */
typedef struct {
    uint32_t seq;
    int64_t t_ns;
    uint8_t mode;
    uint16_t flags;
    float euler_rad[3];
    float z_hat_m, vz_hat_mps, z_baro_m; /* z_baro_m NaN: no reading this sample */
    float roll_ref_rad, pitch_ref_rad, yaw_rate_ref_radps, z_ref_m;
    float pulses_us[4];
    float collective;
    float tau_applied_Nm[3];
    float compute_last_us, compute_max_us, compute_mean_us;
    uint32_t imu_gap_samples, imu_skipped_samples, adc_failed_reads, rc_errors, telemetry_dropped;
} telemetry_record_t;

/* The version-1 payload of rec into out[TELEMETRY_PAYLOAD_LEN]. */
void telemetry_encode(const telemetry_record_t *rec, uint8_t out[TELEMETRY_PAYLOAD_LEN]);

/* Compute-time statistics over the samples since the last take, ns. */
typedef struct {
    uint64_t last_ns, max_ns, sum_ns;
    uint32_t n;
} compute_window_t;

void compute_window_add(compute_window_t *w, uint64_t compute_ns);
/* (last, max, mean) in us over the window; starts a new window. */
void compute_window_take(compute_window_t *w, float *last_us, float *max_us, float *mean_us);

#endif
