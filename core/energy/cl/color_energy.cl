/* The colour energy E = sum_pixels sum_q d(I, a_q) V_q and its gradient
 * with respect to every Gaussian's centre mu_q and standard deviation
 * sigma_q (thesis eq. 4.6, 4.10, 4.13; dissimilarity of ch. 6.2.1).
 * Host side: core/energy/mc_cl.c (set-up) and core/energy/mc_cl_eval.c
 * (one evaluation); the reference in double: core/energy/mc_energy.c;
 * structure and conventions: docs/OPENCL.md.
 *
 * One work-item handles one sampled pixel at a time (a strided loop over
 * the pixel list).  Per pixel it
 *   1. culls the Gaussians whose ray magnitude c0_q < CULL_MAGNITUDE (a
 *      test on the squared distance to the ray, VW Gaussians at a time) and those
 *      dropped at random, keeping a compact private list of the n
 *      survivors, which it projects onto the ray (mu', c' with the smooth
 *      culling edge, dissimilarity to the pixel) VW at a time;
 *   2. lists the 5 n visibility samples and evaluates them VW at a time
 *      (SIMD lanes = samples): for each ray Gaussian p, erf and exp at the
 *      VW sample depths, giving the transmittance T, each sample's energy
 *      W = d_q sigma_q c'_q exp(-k^2/2) h T and its derivative along the ray;
 *   3. back-propagates through T to (mu'_p, sigma_p, c'_p) of every ray
 *      Gaussian (sums over the samples weighted by W, reusing the stored
 *      erf and exp values) and on to (mu_p, sigma_p), adding into the
 *      work-item's row of a work-group scratch array in local memory.
 * At the end the rows are summed per work-group into `partial`; the host
 * adds the work-group rows in double.  No atomics. */

#define MAXG 128            /* MC_MAX_GAUSSIANS */
#ifndef CULL_MAGNITUDE /* MC_CULL_MAGNITUDE, passed by mc_cl.c: no second copy here */
#error "CULL_MAGNITUDE must be defined by the host (-DCULL_MAGNITUDE=...)"
#endif
#define SQRT_HALF_PI 1.25331413732f
#define SQRT2 1.41421356237f
#define INV_SQRT2 0.70710678118f

/* Gaussian records (written by mc_cl_eval.c), 4 float4 per Gaussian q:
 *   gauss[4q + 0] mu.xyz, sigma
 *   gauss[4q + 1] c, r2_max (culled when the squared ray distance >= r2_max)
 *   gauss[4q + 2] albedo h, s, v, w_s
 *   gauss[4q + 3] w_d, w_g
 * then, from gauss + 4 MAXG, four float arrays of MAXG: mu.x, mu.y, mu.z
 * and r2_max (-1 past the last Gaussian), for the SIMD culling test. */

/* Dropout hash; mc_cl_dropped() in mc_cl.h is the same function. */
uint mc_lowbias32(uint x)
{
	x ^= x >> 16;
	x *= 0x7feb352du;
	x ^= x >> 15;
	x *= 0x846ca68bu;
	x ^= x >> 16;
	return x;
}

bool mc_dropped(uint seed_mix, uint cam, uint pixel, uint q, uint thr24)
{
	uint key = pixel * 0x9E3779B1u + cam * 0x85EBCA77u + q * 0xC2B2AE3Du;
	return (mc_lowbias32(seed_mix ^ key) >> 8) < thr24;
}

/* SIMD width: VW lanes hold VW Gaussians (culling, projection) or VW
 * visibility samples (transmittance).  Set by the host (-DVW=...) from the
 * device's preferred float vector width: 16 with AVX-512, 8 with AVX2; 1 on
 * GPUs, whose work-items are the SIMD lanes already. */
#ifndef VW
#define VW 8
#endif
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#if VW == 1
#define floatv float
#define intv int
#define VLOAD(i, p) ((p)[i])
#define VSTORE(v, i, p) ((p)[i] = (v))
#else
#define floatv CAT(float, VW)
#define intv CAT(int, VW)
#define VLOAD(i, p) CAT(vload, VW)(i, p)
#define VSTORE(v, i, p) CAT(vstore, VW)(v, i, p)
#endif

/* The lanes of a comparison result (-1 or 0 per lane) as a bit mask, lane
 * l at bit l: loops visit only the set bits, and a test of the whole
 * vector is one comparison with 0 (any() compiled to a chain of branches). */
uint lane_mask(intv pass)
{
#if VW == 1
	return pass ? 1u : 0u;
#else
#if VW == 16
	intv m = pass & (intv)(1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768);
	int8 a = m.lo | m.hi;
	int4 b = a.lo | a.hi;
#elif VW == 8
	intv m = pass & (intv)(1, 2, 4, 8, 16, 32, 64, 128);
	int4 b = m.lo | m.hi;
#elif VW == 4
	int4 b = pass & (intv)(1, 2, 4, 8);
#endif
	int2 c = b.lo | b.hi;
	return (uint)(c.x | c.y);
#endif
}

float hsum(floatv v)
{
#if VW == 16
	float8 a = v.lo + v.hi;
	float4 b = a.lo + a.hi;
#elif VW == 8
	float4 b = v.lo + v.hi;
#elif VW == 4
	float4 b = v;
#endif
#if VW == 1
	return v;
#else
	float2 c = b.lo + b.hi;
	return c.x + c.y;
#endif
}

/* erf(z) and exp(-z^2) together (Abramowitz-Stegun 7.1.26, |error| <
 * 1.5e-7); the exponential is needed by the gradient anyway. */
floatv erf_exp_v(floatv z, floatv *e)
{
	floatv az = fabs(z);
	floatv ez = exp(-z * z);
	floatv t = 1.0f / (1.0f + 0.3275911f * az);
	floatv poly = t * (0.254829592f + t * (-0.284496736f + t * (1.421413741f +
			t * (-1.453152027f + t * 1.061405429f))));
	*e = ez;
	return copysign(1.0f - poly * ez, z);
}

/* Where a visibility sample lies relative to the camera (docs/ENERGY.md,
 * "Samples near the camera", as near_camera() in mc_energy.c): within a
 * band of width lambda around the camera, x = s / lambda + 1/2 in (0, 1),
 * the sample is faded by h(x) = x^3 (6x^2 - 15x + 10) and T is read at the
 * soft-clamped depth t = lambda (x^3 - x^4 / 2); behind the band (x <= 0)
 * h = 0; beyond it h = 1 and t = s.  With x clamped to [0, 1] the same
 * polynomials give all three cases, except t, selected.  VW lanes. */
typedef struct {
	floatv h, dh_ds, dh_dl; /* weight and its derivatives (s, lambda) */
	floatv t, dt_ds, dt_dl; /* depth at which T is read */
} mc_samples;

mc_samples mc_near_camera(floatv s, floatv x, floatv lambda, floatv inv_lambda)
{
	mc_samples sp;
	floatv xc = clamp(x, 0.0f, 1.0f), x2 = xc * xc, y = 1.0f - xc;
	floatv dh_dx = 30.0f * x2 * y * y;
	sp.h = x2 * xc * (xc * (6.0f * xc - 15.0f) + 10.0f);
	sp.dh_ds = dh_dx * inv_lambda;
	sp.dh_dl = -dh_dx * s * inv_lambda * inv_lambda;
	sp.t = select(lambda * x2 * xc * (1.0f - 0.5f * xc), s, x >= 1.0f);
	sp.dt_ds = x2 * (3.0f - 2.0f * xc);
	sp.dt_dl = 1.5f * x2 * y * y;
	return sp;
}

#define MC_VIS_SAMPLES 5
#define SMAX (MC_VIS_SAMPLES * MAXG + VW) /* samples of one pixel, padded */
/* erf and exp of (ray Gaussian, sample vector) pairs kept from the forward
 * pass for the backward one; rays with more pairs compute them again. */
#define PAIRV_MAX (2048 / VW)

/* HSV dissimilarity d(m, i) in [-1, 1] (thesis 6.2.1, mc_hsv_dissimilarity)
 * of VW albedos m = (h, s, v) with weights w_s, w_d, w_g (normalised on the
 * host) to the pixel colour i. */
floatv dissimilarity_v(floatv h, floatv s, floatv v, floatv w_s, floatv w_d, floatv w_g, float3 i)
{
	floatv dh = fabs(h - i.x);
	floatv hue = 2.0f * fmin(dh, 1.0f - dh);
	floatv dv = v - i.z;
	floatv ds = s - i.y;
	/* d_s: hue, plus the saturation difference (the hue of a grey pixel is
	 * meaningless; docs/ENERGY.md) */
	floatv d_s = fmin(1.0f, hue * hue + fabs(ds));
	floatv x = clamp(w_s * d_s + w_d * 2.0f * dv * dv + w_g * (fabs(dv) + fabs(ds)), 0.0f, 1.0f);
	floatv u = 1.0f - x;
	floatv u2 = u * u;
	return 1.0f - u2 * u2 * (8.0f * x + 2.0f);
}

/* The same for one albedo record (h, s, v, w_s), (w_d, w_g, ...). */
float dissimilarity_s(float4 alb, float4 wdg, float3 i)
{
	floatv d = dissimilarity_v((floatv)alb.x, (floatv)alb.y, (floatv)alb.z, (floatv)alb.w, (floatv)wdg.x,
				   (floatv)wdg.y, i);
#if VW == 1
	return d;
#else
	return d.s0;
#endif
}

/* The Gaussians on one pixel's ray that survive culling and dropout,
 * projected onto the ray (eq. 4.4).  Arrays are padded to nv * VW entries
 * with inert lanes (c' = A = 0, sigma = 1, d = 0). */
typedef struct {
	int n, nv;        /* count, and count in vectors of VW */
	int idx[MAXG];    /* index in the scene */
	float m[MAXG];    /* mu' = (mu - o).n */
	float sg[MAXG];   /* sigma */
	float c[MAXG];    /* c', with the culling edge */
	float cfac[MAXG]; /* c0 dc'/dc0, c0 = c exp(-r^2 / (2 sigma^2)): chain rule */
	float A[MAXG];    /* sqrt(pi/2) sigma c': optical depth per unit of erf */
	float inv[MAXG];  /* 1 / (sqrt2 sigma) */
	float d[MAXG];    /* colour dissimilarity to the pixel */
	float erf0[MAXG], e0[MAXG]; /* erf(z0), exp(-z0^2), z0 = -mu' / (sqrt2 sigma) */
	float base;       /* sum_p A_p erf0_p: tau(t) = sum_p A_p erf(z_p(t)) - base */
	float sumA;       /* sum_p A_p: tau(infinity) = sumA - base */
} mc_ray_set;

/* The culling test, VW Gaussians at a time (c0 > CULL_MAGNITUDE <=> the
 * squared distance of mu from the ray < r2_max), and dropout.  The survivors'
 * records are gathered into rs and the scratch g; returns their count. */
typedef struct {
	float mx[MAXG], my[MAXG], mz[MAXG], h[MAXG], s[MAXG], v[MAXG], ws[MAXG], wd[MAXG], wg[MAXG];
} mc_gathered;

int mc_ray_cull(global const float4 *gauss, int ngauss, float3 o, float3 n, uint seed_mix, uint cam,
		uint pixel, uint thr24, mc_ray_set *rs, mc_gathered *g)
{
	global const float *soa = (global const float *)(gauss + 4 * MAXG);
	int na = 0;
	for (int v = 0; v * VW < ngauss; v++) {
		floatv dx = VLOAD(v, soa) - o.x, dy = VLOAD(v, soa + MAXG) - o.y, dz = VLOAD(v, soa + 2 * MAXG) - o.z;
		floatv mq = dx * n.x + dy * n.y + dz * n.z;
		uint mask = lane_mask(dx * dx + dy * dy + dz * dz - mq * mq < VLOAD(v, soa + 3 * MAXG));
		while (mask) {
			int q = v * VW + (31 - clz(mask & (~mask + 1u)));
			mask &= mask - 1u;
			if (thr24 && mc_dropped(seed_mix, cam, pixel, (uint)q, thr24))
				continue;
			float4 ms = gauss[4 * q], cw = gauss[4 * q + 1], alb = gauss[4 * q + 2], wdg = gauss[4 * q + 3];
			rs->idx[na] = q;
			g->mx[na] = ms.x;
			g->my[na] = ms.y;
			g->mz[na] = ms.z;
			rs->sg[na] = ms.w;
			rs->c[na] = cw.x;
			g->h[na] = alb.x;
			g->s[na] = alb.y;
			g->v[na] = alb.z;
			g->ws[na] = alb.w;
			g->wd[na] = wdg.x;
			g->wg[na] = wdg.y;
			na++;
		}
	}
	return na;
}

/* Projects the gathered Gaussians onto the ray (o, n): mu', c' with the
 * culling edge, the erf terms at the camera, the dissimilarities. */
void mc_ray_project(float3 o, float3 n, float3 colour, mc_ray_set *rs, mc_gathered *g)
{
	rs->nv = (rs->n + VW - 1) / VW;
	for (int p = rs->n; p < rs->nv * VW; p++) {
		g->mx[p] = g->my[p] = g->mz[p] = rs->c[p] = g->h[p] = g->s[p] = g->v[p] = g->ws[p] = g->wd[p] =
			g->wg[p] = 0.0f;
		rs->sg[p] = 1.0f;
	}
	floatv basev = 0.0f, sumAv = 0.0f;
	for (int v = 0; v < rs->nv; v++) {
		/* r^2 from the perpendicular offset, free of the cancellation in
		 * the culling test */
		floatv dx = VLOAD(v, g->mx) - o.x, dy = VLOAD(v, g->my) - o.y, dz = VLOAD(v, g->mz) - o.z;
		floatv mr = dx * n.x + dy * n.y + dz * n.z;
		dx -= mr * n.x;
		dy -= mr * n.y;
		dz -= mr * n.z;
		floatv sv = VLOAD(v, rs->sg);
		floatv c0 = VLOAD(v, rs->c) * exp(-(dx * dx + dy * dy + dz * dz) / (2.0f * sv * sv));
		/* The culling edge (docs/ENERGY.md, "Culling"): c' = c0 F(c0 / C -
		 * 1), F a smooth step from 0 at c0 = C to 1 at c0 = 2C. */
		floatv x = clamp(c0 * (1.0f / CULL_MAGNITUDE) - 1.0f, 0.0f, 1.0f), y = 1.0f - x;
		floatv F = x * x * x * (x * (6.0f * x - 15.0f) + 10.0f);
		floatv cq = c0 * F;
		floatv A = sv * cq * SQRT_HALF_PI, inv = INV_SQRT2 / sv;
		VSTORE(c0 * (F + (x + 1.0f) * 30.0f * x * x * y * y), v, rs->cfac);
		VSTORE(mr, v, rs->m);
		VSTORE(cq, v, rs->c);
		VSTORE(A, v, rs->A);
		VSTORE(inv, v, rs->inv);
		VSTORE(dissimilarity_v(VLOAD(v, g->h), VLOAD(v, g->s), VLOAD(v, g->v), VLOAD(v, g->ws),
				       VLOAD(v, g->wd), VLOAD(v, g->wg), colour),
		       v, rs->d);
		floatv e;
		floatv ef = erf_exp_v(-mr * inv, &e);
		VSTORE(ef, v, rs->erf0);
		VSTORE(e, v, rs->e0);
		basev += A * ef;
		sumAv += A;
	}
	rs->base = hsum(basev);
	rs->sumA = hsum(sumAv);
}

/* The visibility samples s = mu'_q + k sigma_q, k = -4..0, of every ray
 * Gaussian q, k-major: sample (k, q) at (k + 4) n + q, padded to nv * VW
 * with samples of no weight; and what the forward pass finds for each. */
typedef struct {
	int n, nv;
	float s[SMAX];   /* depth s */
	float x[SMAX];   /* s / lambda + 1/2 (near-camera rule) */
	float l[SMAX];   /* lambda = sigma_q */
	float il[SMAX];  /* 1 / lambda */
	float pre[SMAX]; /* d_q sigma_q exp(-k^2/2) */
	float c[SMAX];   /* c'_q */
	float k[SMAX];
	/* forward results */
	float t[SMAX];   /* depth at which T is read */
	float W[SMAX];   /* the sample's energy d sigma c' exp(-k^2/2) h T */
	float V[SMAX];   /* W / c' */
	float gm[SMAX], gs[SMAX]; /* dW/dmu'_q, dW/dsigma_q through the sample's position */
	float wtot;      /* sum of W, and of W_bg */
	float wbg;       /* W_bg = d(I, background) B: the background term */
} mc_sample_set;

void mc_samples_make(const mc_ray_set *rs, mc_sample_set *ss)
{
	for (int ki = 0; ki < MC_VIS_SAMPLES; ki++) {
		const float k = ki - 4, wk = exp(-0.5f * k * k);
		/* Block ki; each block's last vector spills into the next block,
		 * which is written after it (SMAX leaves room past the last). */
		const int off = ki * rs->n;
		for (int v = 0; v < rs->nv; v++) {
			floatv mv = VLOAD(v, rs->m), sv = VLOAD(v, rs->sg), il = 1.0f / sv;
			VSTORE(mv + k * sv, v, ss->s + off);
			VSTORE(mv * il + (k + 0.5f), v, ss->x + off);
			VSTORE(sv, v, ss->l + off);
			VSTORE(il, v, ss->il + off);
			VSTORE(VLOAD(v, rs->d) * sv * wk, v, ss->pre + off);
			VSTORE(VLOAD(v, rs->c), v, ss->c + off);
			VSTORE((floatv)k, v, ss->k + off);
		}
	}
	ss->n = MC_VIS_SAMPLES * rs->n;
	ss->nv = (ss->n + VW - 1) / VW;
	for (int j = ss->n; j < ss->nv * VW; j++) {
		ss->s[j] = ss->x[j] = ss->pre[j] = ss->c[j] = ss->k[j] = 0.0f;
		ss->l[j] = ss->il[j] = 1.0f;
	}
}

/* Forward pass, VW samples at a time: T at each sample (eq. 4.6), its
 * energy W, and W's derivatives through the sample's own depth.  The erf
 * and exp of every (ray Gaussian, sample vector) pair go to erfbuf and
 * ebuf ([p * nv + J]) when `keep`.  d_bg (0: no background model) weighs
 * the background visibility B = T(infinity), which enters the backward
 * pass as one more sample, at infinite depth (erf = 1, exp = 0). */
void mc_samples_forward(const mc_ray_set *rs, mc_sample_set *ss, bool keep, floatv *erfbuf, floatv *ebuf,
			float d_bg)
{
	floatv wtotv = 0.0f;
	for (int J = 0; J < ss->nv; J++) {
		floatv s = VLOAD(J, ss->s);
		floatv x = VLOAD(J, ss->x);
		mc_samples sp;
		if (lane_mask(x < 1.0f)) {
			sp = mc_near_camera(s, x, VLOAD(J, ss->l), VLOAD(J, ss->il));
		} else { /* the common case: no sample near the camera */
			sp.h = sp.dt_ds = 1.0f;
			sp.dh_ds = sp.dh_dl = sp.dt_dl = 0.0f;
			sp.t = s;
		}
		floatv tau = -rs->base, dens = 0.0f;
		for (int p = 0; p < rs->n; p++) {
			floatv e;
			floatv ef = erf_exp_v((sp.t - rs->m[p]) * rs->inv[p], &e);
			if (keep) {
				erfbuf[p * ss->nv + J] = ef;
				ebuf[p * ss->nv + J] = e;
			}
			tau += rs->A[p] * ef;
			dens += rs->c[p] * e;
		}
		floatv cs = VLOAD(J, ss->c);
		floatv preT = VLOAD(J, ss->pre) * exp(-tau); /* d sigma exp(-k^2/2) T */
		floatv V = preT * sp.h;
		floatv W = V * cs;
		preT *= cs;
		/* The depth s moves with mu' (ds/dmu' = 1) and sigma (ds/dsigma =
		 * k); near the camera h and t depend on s and lambda = sigma too. */
		floatv dE_dt = -W * dens;
		floatv dE_ds = dE_dt * sp.dt_ds + preT * sp.dh_ds;
		VSTORE(sp.t, J, ss->t);
		VSTORE(W, J, ss->W);
		VSTORE(V, J, ss->V);
		VSTORE(dE_ds, J, ss->gm);
		VSTORE(dE_dt * sp.dt_dl + preT * sp.dh_dl + VLOAD(J, ss->k) * dE_ds, J, ss->gs);
		wtotv += W;
	}
	ss->wbg = d_bg != 0.0f ? d_bg * exp(rs->base - rs->sumA) : 0.0f;
	ss->wtot = hsum(wtotv) + ss->wbg;
}

/* Backward pass: for every ray Gaussian p, dE/d(mu'_p, sigma_p, c'_p)
 * through its own samples and, through T = exp(-tau), through every
 * sample: dtau/dmu'_p = c'_p (e0_p - e_p), dtau/dc'_p = sqrt(pi/2) sigma_p
 * (erf_p - erf0_p), dtau/dsigma_p = sqrt(pi/2) c'_p (erf_p - erf0_p) -
 * sqrt2 c'_p (z_p e_p - z0_p e0_p), weighted by the samples' W; then the
 * chain rule to (mu_p, sigma_p), added into row.  Returns the energy. */
float mc_samples_backward(global const float4 *gauss, float3 o, float3 n, const mc_ray_set *rs,
			  const mc_sample_set *ss, bool keep, const floatv *erfbuf, const floatv *ebuf,
			  local float *row)
{
	const float wtot = ss->wtot;
	float energy = 0.0f;
	for (int p = 0; p < rs->n; p++) {
		/* own samples: (k, p) at k-block offsets */
		float gV = 0.0f, gm = 0.0f, gs = 0.0f;
		for (int ki = 0; ki < MC_VIS_SAMPLES; ki++) {
			gV += ss->V[ki * rs->n + p];
			gm += ss->gm[ki * rs->n + p];
			gs += ss->gs[ki * rs->n + p];
		}
		/* every sample, through T */
		floatv aE = 0.0f, ae = 0.0f, aze = 0.0f;
		for (int J = 0; J < ss->nv; J++) {
			floatv W = VLOAD(J, ss->W);
			floatv z = (VLOAD(J, ss->t) - rs->m[p]) * rs->inv[p];
			floatv ef, e;
			if (keep) {
				ef = erfbuf[p * ss->nv + J];
				e = ebuf[p * ss->nv + J];
			} else {
				ef = erf_exp_v(z, &e);
			}
			aE += W * ef;
			ae += W * e;
			aze += W * z * e;
		}
		float cp = rs->c[p], s = rs->sg[p], e0 = rs->e0[p];
		float z0 = -rs->m[p] * rs->inv[p];
		float dE = hsum(aE) + ss->wbg - rs->erf0[p] * wtot;
		float g_m = gm - cp * (e0 * wtot - hsum(ae));
		float g_c = gV - s * SQRT_HALF_PI * dE;
		float g_s = gs + cp * gV / s - cp * SQRT_HALF_PI * dE + SQRT2 * cp * (hsum(aze) - z0 * e0 * wtot);
		energy += cp * gV;

		/* dmu'/dmu = n, dc0/dmu = -c0 (d - mu' n) / sigma^2,
		 * dc0/dsigma = c0 r^2 / sigma^3 */
		int q = rs->idx[p];
		float3 perp = gauss[4 * q].xyz - o - rs->m[p] * n;
		float gcc = g_c * rs->cfac[p] / (s * s);
		float3 gmu = g_m * n - gcc * perp;
		row[4 * q + 0] += gmu.x;
		row[4 * q + 1] += gmu.y;
		row[4 * q + 2] += gmu.z;
		row[4 * q + 3] += g_s + gcc * dot(perp, perp) / s;
	}
	return energy;
}

/* E of one pixel; adds its gradient into row[4 q .. 4 q + 3].  d_bg:
 * the pixel's dissimilarity to the background colour, 0 without one. */
float mc_pixel(global const float4 *gauss, int ngauss, float3 o, float3 n, float3 colour, float d_bg,
	       uint seed_mix, uint cam, uint pixel, uint thr24, local float *row)
{
	mc_ray_set rs;
	mc_gathered g;
	rs.n = mc_ray_cull(gauss, ngauss, o, n, seed_mix, cam, pixel, thr24, &rs, &g);
	if (rs.n == 0)
		return d_bg; /* B = 1 */
	mc_ray_project(o, n, colour, &rs, &g);

	mc_sample_set ss;
	mc_samples_make(&rs, &ss);
	const bool keep = rs.n * ss.nv <= PAIRV_MAX;
	floatv erfbuf[PAIRV_MAX], ebuf[PAIRV_MAX];
	mc_samples_forward(&rs, &ss, keep, erfbuf, ebuf, d_bg);
	return mc_samples_backward(gauss, o, n, &rs, &ss, keep, erfbuf, ebuf, row) + ss.wbg;
}

/* rays: one per ray-table pixel of every camera, concatenated: direction
 *       xyz (rig frame), w = camera index, or w < 0 for an invalid pixel;
 * image: HSV of every such pixel (w unused);
 * cam_origin / cam_first: per camera, centre (rig frame) and first ray index;
 * input: the Gaussian records (5 MAXG float4, layout above), then the
 *        npixels ray indices of the sampled pixels, then the group table:
 *        work-group g takes the pixels from its entry to the next one's
 *        (mc_cl_plan_groups; a group holds one camera's pixels);
 * thr24: a Gaussian is dropped when its 24-bit hash < thr24 (0: never);
 * bg_albedo, bg_weights: the background colour model, as a Gaussian's
 *     albedo record (h, s, v, w_s) and (w_d, w_g, enabled, unused);
 * acc: local scratch, get_local_size(0) rows of 4 ngauss + 1 floats;
 * partial: per work-group, 4 ngauss gradient sums (dmu xyz, dsigma per
 *          Gaussian) and the energy last. */
kernel void color_energy(global const float4 *rays, global const float4 *image,
			 constant float4 *cam_origin, constant uint *cam_first,
			 global const float4 *input, int ngauss, int npixels, uint seed, uint thr24,
			 float4 bg_albedo, float4 bg_weights, local float *acc, global float *partial)
{
	const int stride = 4 * ngauss + 1;
	const int lid = get_local_id(0);
	const int lsize = get_local_size(0);
	local float *row = acc + lid * stride;
	for (int i = 0; i < stride; i++)
		row[i] = 0.0f;

	global const float4 *gauss = input;
	global const uint *pixels = (global const uint *)(input + 5 * MAXG);
	const uint seed_mix = mc_lowbias32(seed);
	float energy = 0.0f;
	global const uint *group_first = pixels + npixels;
	const uint end = group_first[get_group_id(0) + 1];
	for (uint i = group_first[get_group_id(0)] + lid; i < end; i += lsize) {
		uint r = pixels[i];
		float4 ray = rays[r];
		if (ray.w < 0.0f)
			continue;
		uint cam = (uint)ray.w;
		float d_bg = bg_weights.z != 0.0f ? dissimilarity_s(bg_albedo, bg_weights, image[r].xyz) : 0.0f;
		energy += mc_pixel(gauss, ngauss, cam_origin[cam].xyz, ray.xyz, image[r].xyz, d_bg, seed_mix, cam,
				   r - cam_first[cam], thr24, row);
	}
	row[4 * ngauss] = energy;

	barrier(CLK_LOCAL_MEM_FENCE);
	for (int col = lid; col < stride; col += lsize) {
		float sum = 0.0f;
		for (int w = 0; w < lsize; w++)
			sum += acc[w * stride + col];
		partial[get_group_id(0) * stride + col] = sum;
	}
}
