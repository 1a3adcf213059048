#include "base/mc_one_euro.h"

#include <math.h>

void mc_one_euro_params_default(mc_one_euro_params *p)
{
	p->min_cutoff_hz = 1.0;
	p->beta = 8.0;
	p->d_cutoff_hz = 1.0;
}

double mc_one_euro_alpha(double cutoff_hz, double dt_s)
{
	double tau = 1.0 / (2.0 * M_PI * cutoff_hz);
	return 1.0 / (1.0 + tau / dt_s);
}

/* A first-order low-pass with factor alpha lags a ramp by (1 - alpha) /
 * alpha samples, which is tau / dt: tau seconds at any rate. */
double mc_one_euro_lag_s(const mc_one_euro_params *p, double speed)
{
	return 1.0 / (2.0 * M_PI * (p->min_cutoff_hz + p->beta * fabs(speed)));
}

void mc_one_euro3_reset(mc_one_euro3 *f)
{
	f->started = false;
	f->raw = f->value = f->velocity = mc_v3(0, 0, 0);
}

static mc_vec3 lerp(mc_vec3 from, mc_vec3 to, double alpha)
{
	return mc_v3_axpy(alpha, mc_v3_sub(to, from), from);
}

double mc_one_euro3_step(mc_one_euro3 *f, const mc_one_euro_params *p, mc_vec3 x, double dt_s)
{
	if (!f->started || !(dt_s > 0)) {
		f->started = true;
		f->raw = f->value = x;
		f->velocity = mc_v3(0, 0, 0);
		return 1.0;
	}
	mc_vec3 dx = mc_v3_scale(mc_v3_sub(x, f->raw), 1.0 / dt_s);
	f->velocity = lerp(f->velocity, dx, mc_one_euro_alpha(p->d_cutoff_hz, dt_s));
	double cutoff = p->min_cutoff_hz + p->beta * mc_v3_norm(f->velocity);
	double alpha = mc_one_euro_alpha(cutoff, dt_s);
	f->value = lerp(f->value, x, alpha);
	f->raw = x;
	return alpha;
}
