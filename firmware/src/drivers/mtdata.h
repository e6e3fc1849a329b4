/*
 * XSENS measurement payloads: MTData2 (mk4) and legacy MTData decoding, and the output
 * configuration the flight code asks for. Sans-I/O. Wire facts (docs/protocols.md 1.8, 1.9;
 * MT0100P, MT0605P): fields big-endian; MTData2 = packets of XDI(u16) size(u8) data, XDI bits
 * 3-2 the coordinate system, bits 1-0 the precision; legacy MTData = the items of
 * SetOutputMode/SetOutputSettings in a fixed order.
 */
#ifndef FW_MTDATA_H
#define FW_MTDATA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define MTDATA_SAMPLE_TIME_FINE_HZ 10000u /* SampleTimeFine counts 10 kHz ticks */
#define MTDATA_LEGACY_PERIOD_CLOCK_HZ 115200u /* legacy SetPeriod unit: 1/115200 s */

/* MTData2 data identifiers with the coordinate/precision bits cleared. */
typedef enum {
    XDI_PACKET_COUNTER = 0x1020,
    XDI_SAMPLE_TIME_FINE = 0x1060,
    XDI_EULER_ANGLES = 0x2030,
    XDI_ACCELERATION = 0x4020,
    XDI_RATE_OF_TURN = 0x8020,
    XDI_STATUS_WORD = 0xE020
} xdi_t;

typedef enum { XDI_FLOAT32 = 0, XDI_FP1220 = 1, XDI_FP1632 = 2, XDI_FLOAT64 = 3 } xdi_precision_t;

/* Legacy SetOutputMode / SetOutputSettings bits (MT0100P p.27-28). */
enum {
    LEGACY_MODE_TEMPERATURE = 0x0001,
    LEGACY_MODE_CALIBRATED = 0x0002,
    LEGACY_MODE_ORIENTATION = 0x0004,
    LEGACY_MODE_AUXILIARY = 0x0008,
    LEGACY_MODE_POSITION = 0x0010,
    LEGACY_MODE_VELOCITY = 0x0020,
    LEGACY_MODE_STATUS = 0x0800
};
#define LEGACY_SET_SAMPLE_COUNTER 0x00000001u
#define LEGACY_SET_ORIENT_EULER 0x00000004u
#define LEGACY_SET_ORIENT_MATRIX 0x00000008u
#define LEGACY_SET_DISABLE_ACC 0x00000010u
#define LEGACY_SET_DISABLE_GYR 0x00000020u
#define LEGACY_SET_DISABLE_MAG 0x00000040u
#define LEGACY_SET_FIXED_1220 0x00000100u
#define LEGACY_SET_DISABLE_AIN1 0x00000400u
#define LEGACY_SET_DISABLE_AIN2 0x00000800u
#define LEGACY_SET_NED 0x80000000u

/* The legacy configuration: calibrated data + orientation; sample counter, Euler, NED. */
#define LEGACY_OUTPUT_MODE (LEGACY_MODE_CALIBRATED | LEGACY_MODE_ORIENTATION)
#define LEGACY_OUTPUT_SETTINGS (LEGACY_SET_SAMPLE_COUNTER | LEGACY_SET_ORIENT_EULER | LEGACY_SET_NED)

/* The flight code's mk4 output configuration: six entries of (XDI, frequency). */
#define MTDATA_MK4_ENTRIES 6
/* Its SetOutputConfiguration payload (4 bytes an entry) into out[24]. */
void mtdata_mk4_output_configuration(uint16_t rate_hz, uint8_t out[4 * MTDATA_MK4_ENTRIES]);
/* The MTData2 payload length a mk4 sends for it. */
#define MTDATA_MK4_PAYLOAD_LEN 64u

/* SetPeriod value (units of 1/115200 s) for rate_hz; 400 Hz -> 288. */
uint16_t mtdata_legacy_period(uint32_t rate_hz);
/* MTData payload length for (mode, settings) with 4-byte scalars. */
size_t mtdata_legacy_length(uint16_t mode, uint32_t settings);

/* Decoded measurement in the device's units and output frame (NED/FRD as configured). */
typedef struct {
    uint16_t counter;
    bool has_sample_time_fine; /* false for legacy MTData */
    uint32_t sample_time_fine;
    float euler_deg[3];
    float rate_of_turn_radps[3];
    float acceleration_mps2[3];
    uint32_t status;
} xsens_data_t;

typedef struct {
    uint32_t mtdata2_truncated;
    uint32_t mtdata2_incomplete;
    uint32_t mtdata_bad_length;
    uint32_t mtdata_unsupported_layout;
    uint32_t mtdata_incomplete;
} mtdata_counters_t;

/* Decode an MTData2 payload; false (counted) unless PacketCounter, SampleTimeFine,
 * EulerAngles, RateOfTurn and Acceleration are present and finite (StatusWord optional). */
bool mtdata_decode2(const uint8_t *payload, size_t len, xsens_data_t *out, mtdata_counters_t *c);

/* Decode a legacy MTData payload laid out by mode/settings; false (counted) otherwise. */
bool mtdata_decode_legacy(const uint8_t *payload, size_t len, uint16_t mode, uint32_t settings,
                          xsens_data_t *out, mtdata_counters_t *c);

#endif
