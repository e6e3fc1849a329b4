/*
 * ADC codes -> physical units: the barometer and accelerometer analog chains, the boot
 * pressure reference and the accelerometer's rest offsets. As flightcode/drivers/analog.py:
 *
 *   MCP3204: code = floor(4096 v / vref_V); the inverse uses the bin centre.
 *   MPX5100AP: v_sensor = supply_V (k_per_kPa P_kPa - offset_ratio), then the stage
 *     v_adc = gain (v_sensor - offset_V) + ref_V.
 *   Altitude: ISA troposphere h(P) = T0/L (1 - (P/101325)^(R L / g0 M)), relative to the
 *     pressure averaged at boot.
 *   ADXL335: v = supply_V (zero_g_ratio + sens_ratio_per_g a_g) per sensor axis; mount_B maps
 *     sensor axes (with sign) to body FRD.
 */
#ifndef FW_ANALOG_H
#define FW_ANALOG_H

#include <stdbool.h>
#include <stdint.h>

#define ANALOG_RESOLUTION_CODES 4096
#define G0_MPS2 9.80665f

typedef struct {
    float supply_V, k_per_kPa, offset_ratio, gain, offset_V, ref_V, zero_average_s, rail_margin_V;
} baro_chain_params_t;

typedef struct {
    float supply_V, zero_g_ratio, sens_ratio_per_g;
    /* for body x, y, z: sensor axis index 0..2 and sign +-1 */
    uint8_t mount_axis[3];
    int8_t mount_sign[3];
} accel_chain_params_t;

/* Parse ("+X", "-Y", "-Z") into axis/sign; false if not a signed permutation. */
bool analog_parse_mount(const char *const entries[3], uint8_t axis[3], int8_t sign[3]);

/* ISA pressure altitude above the 101325 Pa level, m. */
float isa_altitude_m(float p_Pa);

typedef struct {
    float vref_V;
    baro_chain_params_t baro;
    accel_chain_params_t accel;
    float v_per_code;
    int rail_lo_code, rail_hi_code; /* codes at or beyond these are refused */
    float acc_zero_V, acc_mps2_per_V;
} analog_chain_t;

void analog_init(analog_chain_t *a, float vref_V, const baro_chain_params_t *baro, const accel_chain_params_t *accel);
/* ADC input voltage at the centre of the code's bin, V. */
float analog_volts(const analog_chain_t *a, int code);
/* Absolute pressure, Pa; false if the code lies within rail_margin_V of either rail. */
bool analog_baro_Pa(const analog_chain_t *a, int code, float *p_Pa);
/* Specific force in body FRD, m/s^2 (about (0, 0, -9.81) level at rest). */
void analog_accel_B(const analog_chain_t *a, int code_x, int code_y, int code_z, float f_B[3]);

/* The accelerometer's offsets in body axes, learnt at rest during the boot averaging (the
 * mean of measured - R_NB^T (0, 0, -g)); beyond limit on any axis rejected (offsets 0). */
typedef struct {
    float limit_mps2;
    double sum[3];
    uint32_t n;
    float offset_B_mps2[3];
    bool rejected;
} accel_rest_offset_t;

void accel_offset_init(accel_rest_offset_t *o);
void accel_offset_add(accel_rest_offset_t *o, const float f_B[3], float roll_rad, float pitch_rad);
void accel_offset_fix(accel_rest_offset_t *o);
void accel_offset_correct(const accel_rest_offset_t *o, float f_B[3]);

/* The pressure averaged over the first average_ns of sensor time; then the altitude zero. */
typedef struct {
    int64_t average_ns;
    bool started, ready;
    int64_t t_first_ns;
    double sum;
    uint32_t n;
    float p_ref_Pa, h_ref_m;
} baro_reference_t;

void baro_ref_init(baro_reference_t *r, int64_t average_ns);
/* Accumulate one reading; true once the reference is fixed. */
bool baro_ref_add(baro_reference_t *r, float p_Pa, int64_t t_ns);
/* Height above the boot reference, m (positive up). */
float baro_ref_altitude_m(const baro_reference_t *r, float p_Pa);

#endif
