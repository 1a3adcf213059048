/* mc_one_euro: the One-Euro filter (Casiez, Roussel and Vogel, CHI 2012)
 * on 3-vectors, for smoothing noisy tracked positions in real time.
 *
 * A first-order low-pass whose cutoff rises with speed:
 *   dx      = (x_i - x_{i-1}) / dt           (consecutive raw samples)
 *   dx_hat  = lowpass(dx, d_cutoff_hz)       (the velocity estimate)
 *   fc      = min_cutoff_hz + beta * |dx_hat|
 *   x_hat   = lowpass(x, fc),  alpha(fc, dt) = 1 / (1 + 1 / (2 pi fc dt))
 * At rest the cutoff is min_cutoff_hz and jitter is smoothed hard; when the
 * point moves the cutoff rises and the lag shrinks.  On a ramp at speed v
 * the output lags the input by tau = 1 / (2 pi (min_cutoff_hz + beta v))
 * seconds, whatever the frame rate (mc_one_euro_lag_s).
 *
 * The velocity comes from consecutive raw samples rather than from the
 * previous output (the paper writes the latter; the authors' reference
 * code does the former): on a ramp it is then the true speed, not the
 * speed plus the output's lag over dt, so it can drive a prediction.
 *
 * The speed is the length of the low-passed velocity vector, so on a
 * curved path, where the velocity turns, it reads low (0.86 of the speed
 * on a circle at 3.3 rad/s with d_cutoff 1 Hz) and the lag there is
 * somewhat longer than tau at the true speed.
 *
 * Timestamps are real (dt varies); the first sample after a reset passes
 * through unchanged with zero velocity. */
#ifndef MC_ONE_EURO_H
#define MC_ONE_EURO_H

#include "base/mc_math.h"

#include <stdbool.h>

typedef struct {
	double min_cutoff_hz; /* cutoff at rest, > 0 */
	double beta;          /* cutoff added per unit of speed (Hz per m/s), >= 0 */
	double d_cutoff_hz;   /* cutoff of the velocity estimate, > 0 */
} mc_one_euro_params;

/* The daemon's defaults (docs/CONFIG.md, "[output]"): 1 Hz, 8 Hz per m/s, 1 Hz. */
void mc_one_euro_params_default(mc_one_euro_params *p);

/* The smoothing factor of a first-order low-pass at cutoff_hz over dt_s. */
double mc_one_euro_alpha(double cutoff_hz, double dt_s);

/* The steady lag, in seconds, of the output behind a ramp at `speed`. */
double mc_one_euro_lag_s(const mc_one_euro_params *p, double speed);

typedef struct {
	bool started;
	mc_vec3 raw;      /* the previous input */
	mc_vec3 value;    /* the previous output */
	mc_vec3 velocity; /* dx_hat: units per second */
} mc_one_euro3;

void mc_one_euro3_reset(mc_one_euro3 *f);

/* Filters one sample dt_s after the previous one (ignored for the first;
 * must be > 0 otherwise).  Returns the smoothing factor used (1 for a
 * first sample: the input passes through), so that quantities tied to
 * this point can be smoothed alike; the output is f->value. */
double mc_one_euro3_step(mc_one_euro3 *f, const mc_one_euro_params *p, mc_vec3 x, double dt_s);

#endif
