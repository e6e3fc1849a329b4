/*
 * baro_motion.h - does the barometer move with the vehicle? Its height change against the
 * accelerometers'.
 *
 * The C twin of flightcode/estimation/baro_motion.py (docs/flightcode.md, "The barometer
 * against the accelerometers"). A blocked static port traps the air the sensor sees: its
 * readings go on moving by the sensor's own noise at a believable pressure, so no range, step
 * or flat-line test refuses them, and in a climb the filter holds the height near the trapped
 * level while the altitude loop climbs on.
 *
 * Over a sliding window of blocks_back blocks of block_ns, judged at the end of every block,
 * two height changes between the window's first and last blocks are compared: the barometer's
 * (the difference of the two blocks' mean barometric altitudes) and the inertial one (the
 * vertical acceleration integrated twice over the same samples, started at the end of the
 * first block from the estimator's vertical velocity there). Beyond max_m the barometer is
 * refused (baro_motion_t.refusing) and the estimate is to be moved to the inertial height and
 * velocity at the end of the window (baro_motion_take_reanchor); it is taken back when a whole
 * window agrees again and its level is within max_m of the estimate.
 *
 * A block holding a reading the estimator's gate refused (baro_motion_reading_rejected), or
 * with fewer than half its samples with a reading, is dropped and the window starts again
 * after it. A block closes at the sample after its last, once the gate has judged that last
 * reading. Judged only while the caller says so (flying clear of the ground) and only from one
 * window after that started.
 *
 * Time is counted in integer nanoseconds since the check's restart, so the blocks close on the
 * sample grid exactly; the inertial height and the block times are kept in single precision
 * relative to the end of the newest block (rebased at every block), so their resolution does
 * not decay over a long flight. Differences, which are all the judgement uses, are unchanged by
 * the rebase (the velocity's own rounding before a window cancels in the window's judgement).
 */
#ifndef FW_ESTIMATION_BARO_MOTION_H
#define FW_ESTIMATION_BARO_MOTION_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Ring capacity in blocks (a window of blocks_back blocks needs blocks_back + 1). */
#define BARO_MOTION_MAX_BLOCKS 16u

typedef struct {
    bool enabled;          /* plausibility.baro_motion_window_s > 0; off: add() never refuses */
    int64_t block_ns;      /* round(plausibility.baro_motion_block_s x 1e9) */
    uint16_t blocks_back;  /* window in blocks: round(window_s / block_s), 2..BARO_MOTION_MAX_BLOCKS - 1 */
    float max_m;           /* plausibility.baro_motion_max_m */
} baro_motion_params_t;

/*
 * Fill params from the config's window and block (ns: round(s x 1e9)) and max_m. window_ns = 0
 * turns the check off. False if the values are unusable (block <= 0, a window shorter than two
 * blocks or longer than the ring holds, max_m <= 0).
 */
bool baro_motion_params_make(baro_motion_params_t *params, int64_t window_ns, int64_t block_ns, float max_m);

/* One closed block: means over its samples with a barometer reading, and its end state. Times
 * and inertial heights are relative to the rebase point (see the file comment). */
typedef struct {
    float t_s;             /* mean sample time, s */
    float baro_m;          /* mean barometric altitude, m */
    float z_in_m;          /* mean inertial height, m */
    float z_hat_m;         /* mean estimate, m */
    float t_end_s;         /* time of the block's last sample, s */
    float z_in_end_m;      /* inertial height there, m */
    float v_in_end_mps;    /* inertial velocity there, m/s */
    float z_hat_end_m;     /* the estimator's height there, m */
    float vz_hat_end_mps;  /* the estimator's velocity there, m/s */
} baro_motion_block_t;

typedef struct {
    uint32_t windows;       /* windows judged */
    uint32_t disagreements; /* refusals started */
    uint32_t taken_back;    /* refusals ended by agreement */
} baro_motion_counters_t;

typedef struct {
    baro_motion_params_t p;
    /* the window: ring of closed blocks, oldest at ring_head */
    baro_motion_block_t ring[BARO_MOTION_MAX_BLOCKS];
    uint16_t ring_head;
    uint16_t ring_len;
    uint32_t blocks;        /* blocks closed since the restart */
    int64_t elapsed_ns;     /* sensor time since the restart (0: nothing judged since) */
    int64_t block_end_ns;   /* the open block ends at this elapsed time */
    int64_t rebase_ns;      /* the elapsed time the float times below are relative to */
    float z_m;              /* inertial height, relative to the rebase point, m */
    float v_mps;            /* inertial velocity since the restart, m/s */
    /* the open block */
    uint32_t m;             /* samples */
    uint32_t n;             /* of them with a barometer reading */
    bool tainted;           /* one of its readings was an outlier to the estimator's gate */
    float st, sb, sz, shat; /* sums of time, baro, inertial height, estimate over readings */
    bool full;              /* its last sample is in: it closes at the next sample */
    float full_z_hat_m, full_vz_hat_mps;
    /* the acceleration held when a sample has none */
    bool have_a;
    float a_last_mps2;
    /* verdict */
    bool refusing;          /* true: do not fuse the barometer */
    float worst_m;          /* largest disagreement judged while believed (baro_motion_take_worst) */
    bool have_reanchor;
    float reanchor_z_m, reanchor_vz_mps;
    baro_motion_counters_t counters;
} baro_motion_t;

void baro_motion_init(baro_motion_t *bm, const baro_motion_params_t *params);

/*
 * Take one sample; returns true if its barometer reading must not be fused (refusing).
 *   dt_ns       sensor time since the previous sample, ns
 *   baro_valid  a barometric altitude this sample (z_baro_m, m up)
 *   acc_valid   a believable vertical acceleration this sample (a_up_mps2, m/s^2 up); else the
 *               last one is held
 *   z_hat_m, vz_hat_mps  the estimator's height and velocity before this sample's update
 *   judging     the vehicle flies clear of the ground (controllers on, estimate above the
 *               ground effect, no ground contact); false restarts the window
 */
bool baro_motion_add(baro_motion_t *bm, int64_t dt_ns, bool baro_valid, float z_baro_m, bool acc_valid,
                     float a_up_mps2, float z_hat_m, float vz_hat_mps, bool judging);

/* The estimator's gate refused this sample's reading (an outlier): the open block is dropped. */
void baro_motion_reading_rejected(baro_motion_t *bm);

/* Once, when a refusal starts: true and the (height m, velocity m/s) the estimate must move to. */
bool baro_motion_take_reanchor(baro_motion_t *bm, float *z_m, float *vz_mps);

/* The largest disagreement judged since the last call, m (the stats line's margin); clears it. */
float baro_motion_take_worst(baro_motion_t *bm);

/* The controllers are off (on the ground): a refusal ends and the window starts again. */
void baro_motion_on_ground(baro_motion_t *bm);

#ifdef __cplusplus
}
#endif

#endif /* FW_ESTIMATION_BARO_MOTION_H */
