/* The colour energy E = sum_pixels sum_q d(I, a_q) V_q and its gradient
 * with respect to every Gaussian's centre mu_q and standard deviation
 * sigma_q (thesis eq. 4.6, 4.10, 4.13; dissimilarity of ch. 6.2.1).
 * Host side: core/mc_cl.c; the reference in double: core/mc_energy.c;
 * structure and conventions: docs/OPENCL.md.
 *
 * One work-item handles one sampled pixel at a time (a strided loop over
 * the pixel list).  Per pixel it
 *   1. culls the Gaussians whose ray magnitude c'_q < 1e-5 (a test on the
 *      squared distance to the ray) and those dropped at random, keeping a
 *      compact private list of the survivors;
 *   2. evaluates the transmittance at the five samples of every survivor,
 *      skipping the erf of Gaussians the sample is far from (their erf is
 *      saturated at -1 or +1), then V_q and the energy;
 *   3. back-propagates to (mu'_q, sigma_q, c'_q) of the ray Gaussians and
 *      on to (mu_q, sigma_q), adding into the work-item's row of a
 *      work-group scratch array in local memory.
 * At the end the rows are summed per work-group into `partial`; the host
 * adds the work-group rows in double.  No atomics. */

#define MAXG 128            /* MC_MAX_GAUSSIANS */
#define CULL_MAGNITUDE 1e-5f /* MC_CULL_MAGNITUDE */
#define SAT_Z 3.5f          /* |z| beyond this: erf(z) = +-1, exp(-z^2) = 0 */
#define SQRT_HALF_PI 1.25331413732f
#define SQRT2 1.41421356237f
#define INV_SQRT2 0.70710678118f

/* Gaussian record, 4 float4 per Gaussian (written by mc_cl.c):
 *   [0] mu.xyz, sigma
 *   [1] c, r2_max (cull when the squared ray distance >= r2_max), 0, 0
 *   [2] albedo h, s, v, w_s
 *   [3] w_d, w_g, 0, 0 */

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

/* erf and exp(-z^2) together (Abramowitz-Stegun 7.1.26, |error| < 1.5e-7);
 * the exponential is needed by the gradient anyway. */
float mc_erf_exp(float z, float *e)
{
	float az = fabs(z);
	float ez = exp(-z * z);
	float t = 1.0f / (1.0f + 0.3275911f * az);
	float poly = t * (0.254829592f + t * (-0.284496736f + t * (1.421413741f +
			t * (-1.453152027f + t * 1.061405429f))));
	*e = ez;
	return copysign(1.0f - poly * ez, z);
}

/* HSV dissimilarity d(m, i) in [-1, 1] (thesis 6.2.1).  m: albedo HSV and
 * its weight w_s; wdg: its w_d, w_g (weights normalised on the host). */
float mc_dissimilarity(float4 m, float2 wdg, float3 i)
{
	float dh = fabs(m.x - i.x);
	float hue = 2.0f * fmin(dh, 1.0f - dh);
	float dv = m.z - i.z;
	float ds = m.y - i.y;
	float x = m.w * hue * hue + wdg.x * 2.0f * dv * dv + wdg.y * (fabs(dv) + fabs(ds));
	x = clamp(x, 0.0f, 1.0f);
	float u = 1.0f - x;
	float u2 = u * u;
	return 1.0f - u2 * u2 * (8.0f * x + 2.0f);
}

/* Where a visibility sample lies relative to the camera (docs/ENERGY.md,
 * "Samples near the camera", as mc_energy.c's near_camera()): within a
 * band of width lambda around the camera, x = s / lambda + 1/2 in (0, 1),
 * the sample is faded by h(x) = x^3 (6x^2 - 15x + 10) and T is read at the
 * soft-clamped depth t = lambda (x^3 - x^4 / 2); behind the band the sample
 * is dropped (returns false), beyond it h = 1 and t = s. */
typedef struct {
	float h, dh_ds, dh_dl; /* weight and its derivatives (s, lambda) */
	float t, dt_ds, dt_dl; /* depth at which T is read */
} mc_sample;

bool mc_near_camera(float s, float lambda, mc_sample *sp)
{
	float x = s / lambda + 0.5f;
	if (x >= 1.0f) {
		sp->h = 1.0f;
		sp->t = s;
		sp->dt_ds = 1.0f;
		sp->dh_ds = sp->dh_dl = sp->dt_dl = 0.0f;
		return true;
	}
	if (x <= 0.0f)
		return false;
	float x2 = x * x, y = 1.0f - x;
	float dh_dx = 30.0f * x2 * y * y;
	sp->h = x2 * x * (x * (6.0f * x - 15.0f) + 10.0f);
	sp->dh_ds = dh_dx / lambda;
	sp->dh_dl = -dh_dx * s / (lambda * lambda);
	sp->t = lambda * x2 * x * (1.0f - 0.5f * x);
	sp->dt_ds = x2 * (3.0f - 2.0f * x);
	sp->dt_dl = 1.5f * x2 * y * y;
	return true;
}

/* The ray Gaussians of one pixel that survived culling and dropout. */
typedef struct {
	int n;
	int idx[MAXG];   /* Gaussian index in the scene */
	float m[MAXG];   /* mu' */
	float sg[MAXG];  /* sigma */
	float c[MAXG];   /* c' */
	float A[MAXG];   /* sigma c' sqrt(pi/2): optical depth per unit erf */
	float inv[MAXG]; /* 1 / (sqrt2 sigma) */
	float hw[MAXG];  /* SAT_Z sqrt2 sigma: half-width of the erf's unsaturated range */
	float d[MAXG];   /* colour dissimilarity to the pixel */
} mc_ray_set;

float mc_pixel(global const float4 *gauss, int ngauss, float3 o, float3 n, float3 colour,
	       uint seed_mix, uint cam, uint pixel, uint thr24, local float *row)
{
	mc_ray_set rs;
	rs.n = 0;
	for (int q = 0; q < ngauss; q++) {
		float4 ms = gauss[4 * q];
		float r2max = gauss[4 * q + 1].y;
		float3 dv = ms.xyz - o;
		float m = dot(dv, n);
		if (dot(dv, dv) - m * m >= r2max)
			continue;
		if (thr24 && mc_dropped(seed_mix, cam, pixel, (uint)q, thr24))
			continue;
		/* The perpendicular offset, free of the cancellation above. */
		float3 perp = dv - m * n;
		float sg = ms.w;
		float cq = gauss[4 * q + 1].x * exp(-dot(perp, perp) / (2.0f * sg * sg));
		if (cq < CULL_MAGNITUDE)
			continue;
		int k = rs.n++;
		rs.idx[k] = q;
		rs.m[k] = m;
		rs.sg[k] = sg;
		rs.c[k] = cq;
		rs.A[k] = sg * cq * SQRT_HALF_PI;
		rs.inv[k] = INV_SQRT2 / sg;
		rs.hw[k] = SAT_Z * SQRT2 * sg;
		rs.d[k] = mc_dissimilarity(gauss[4 * q + 2], gauss[4 * q + 3].xy, colour);
	}
	if (rs.n == 0)
		return 0.0f;

	/* Optical depth offset: tau(s) = sum_p A_p (erf(z_p(s)) - erf(z0_p)). */
	float erf0[MAXG], e0[MAXG];
	float base = 0.0f;
	for (int p = 0; p < rs.n; p++) {
		erf0[p] = mc_erf_exp(-rs.m[p] * rs.inv[p], &e0[p]);
		base += rs.A[p] * erf0[p];
	}

	/* Per-Gaussian sums over all samples j, weighted by the sample's energy
	 * W_j: W erf_p(s_j), W exp(-z_p^2), W z_p exp(-z_p^2); and the direct
	 * gradient terms of each Gaussian's own samples. */
	float sE[MAXG], se[MAXG], sze[MAXG], gm[MAXG], gs[MAXG], gc[MAXG];
	float erfp[MAXG], ep[MAXG], zp[MAXG];
	float wtot = 0.0f, energy = 0.0f;
	for (int p = 0; p < rs.n; p++)
		sE[p] = se[p] = sze[p] = 0.0f;

	for (int q = 0; q < rs.n; q++) {
		gm[q] = gs[q] = gc[q] = 0.0f;
		if (rs.d[q] == 0.0f)
			continue; /* contributes nothing; still occludes */
		float vis = 0.0f, gpos_m = 0.0f, gpos_s = 0.0f;
		float sg = rs.sg[q];
		float pre = rs.d[q] * sg * rs.c[q];
		for (int k = -4; k <= 0; k++) {
			float s = rs.m[q] + k * sg;
			mc_sample sp;
			if (!mc_near_camera(s, sg, &sp))
				continue;
			float tau = -base, dens = 0.0f;
			for (int p = 0; p < rs.n; p++) {
				float u = sp.t - rs.m[p];
				if (u > rs.hw[p]) {
					erfp[p] = 1.0f;
					ep[p] = zp[p] = 0.0f;
					tau += rs.A[p];
				} else if (u < -rs.hw[p]) {
					erfp[p] = -1.0f;
					ep[p] = zp[p] = 0.0f;
					tau -= rs.A[p];
				} else {
					float z = u * rs.inv[p];
					float e;
					float ef = mc_erf_exp(z, &e);
					erfp[p] = ef;
					ep[p] = e;
					zp[p] = z;
					tau += rs.A[p] * ef;
					dens += rs.c[p] * e;
				}
			}
			float wkT = exp(-0.5f * k * k - tau); /* exp(-k^2/2) T(t) */
			float W = pre * sp.h * wkT;           /* this sample's energy */
			vis += sp.h * wkT;
			/* The sample depth s moves with mu' (ds/dmu' = 1) and sigma
			 * (ds/dsigma = k); near the camera h and t depend on s and
			 * lambda = sigma too. */
			float dE_dt = -W * dens, dE_dh = pre * wkT;
			float dE_ds = dE_dt * sp.dt_ds + dE_dh * sp.dh_ds;
			gpos_m += dE_ds;
			gpos_s += dE_dt * sp.dt_dl + dE_dh * sp.dh_dl + k * dE_ds;
			wtot += W;
			for (int p = 0; p < rs.n; p++) {
				sE[p] += W * erfp[p];
				se[p] += W * ep[p];
				sze[p] += W * zp[p] * ep[p];
			}
		}
		energy += pre * vis;
		gm[q] = gpos_m;
		gs[q] = gpos_s + rs.d[q] * rs.c[q] * vis;
		gc[q] = rs.d[q] * sg * vis;
	}

	/* Occlusion terms (through tau), then the chain rule from the ray
	 * Gaussian (mu', sigma, c') to (mu, sigma). */
	for (int p = 0; p < rs.n; p++) {
		float cp = rs.c[p], sg = rs.sg[p];
		float z0 = -rs.m[p] * rs.inv[p];
		float dE = sE[p] - erf0[p] * wtot;
		float g_m = gm[p] - cp * (e0[p] * wtot - se[p]);
		float g_c = gc[p] - sg * SQRT_HALF_PI * dE;
		float g_s = gs[p] - cp * SQRT_HALF_PI * dE + SQRT2 * cp * (sze[p] - z0 * e0[p] * wtot);

		int q = rs.idx[p];
		float3 dv = gauss[4 * q].xyz - o;
		float3 perp = dv - rs.m[p] * n;
		float inv_s2 = 1.0f / (sg * sg);
		float gcc = g_c * cp * inv_s2;
		float3 gmu = g_m * n - gcc * perp;
		float gsig = g_s + gcc * dot(perp, perp) / sg;
		row[4 * q + 0] += gmu.x;
		row[4 * q + 1] += gmu.y;
		row[4 * q + 2] += gmu.z;
		row[4 * q + 3] += gsig;
	}
	return energy;
}

/* rays: one per ray-table pixel of every camera, concatenated: direction
 *       xyz (rig frame), w = camera index, or w < 0 for an invalid pixel;
 * image: HSV of every such pixel (w unused);
 * cam_origin / cam_first: per camera, centre (rig frame) and first ray index;
 * pixels: the sampled ray indices;
 * thr24: a Gaussian is dropped when its 24-bit hash < thr24 (0: never);
 * acc: local scratch, get_local_size(0) rows of 4 ngauss + 1 floats;
 * partial: per work-group, 4 ngauss gradient sums (dmu xyz, dsigma per
 *          Gaussian) and the energy last. */
kernel void color_energy(global const float4 *rays, global const float4 *image,
			 constant float4 *cam_origin, constant uint *cam_first,
			 global const float4 *gauss, int ngauss,
			 global const uint *pixels, int npixels, uint seed, uint thr24,
			 local float *acc, global float *partial)
{
	const int stride = 4 * ngauss + 1;
	const int lid = get_local_id(0);
	const int lsize = get_local_size(0);
	local float *row = acc + lid * stride;
	for (int i = 0; i < stride; i++)
		row[i] = 0.0f;

	const uint seed_mix = mc_lowbias32(seed);
	float energy = 0.0f;
	for (int i = get_global_id(0); i < npixels; i += get_global_size(0)) {
		uint r = pixels[i];
		float4 ray = rays[r];
		if (ray.w < 0.0f)
			continue;
		uint cam = (uint)ray.w;
		energy += mc_pixel(gauss, ngauss, cam_origin[cam].xyz, ray.xyz, image[r].xyz, seed_mix, cam,
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
