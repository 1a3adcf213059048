/* Camera models: see mc_camera.h for the formulas and conventions. */
#include "geom/mc_camera.h"

#include <string.h>

/* Newton iterations stop when the step is below this (radians or normalised
 * image units): the inverse is exact to well below a micro-pixel. */
#define SOLVE_TOL 1e-12
#define SOLVE_MAX_ITER 100
/* Samples used to check that a distortion model is monotonic. */
#define MONOTONIC_SAMPLES 2048

static const char *const model_names[] = {"pinhole", "equidistant", "ocam"};

const char *mc_camera_model_name(mc_camera_model m)
{
	if ((int)m < 0 || (int)m >= (int)(sizeof(model_names) / sizeof(model_names[0])))
		return "unknown";
	return model_names[m];
}

int mc_camera_model_parse(const char *name, mc_camera_model *m)
{
	for (int i = 0; i < (int)(sizeof(model_names) / sizeof(model_names[0])); i++) {
		if (strcmp(name, model_names[i]) == 0) {
			*m = (mc_camera_model)i;
			return 0;
		}
	}
	return -1;
}

/* A pixel is inside the image when it lies on the sensor: pixel centres run
 * from 0 to width-1, so pixel areas cover [-0.5, width-0.5). */
static bool in_image(const mc_camera *cam, double u, double v)
{
	return u >= -0.5 && u < cam->width - 0.5 && v >= -0.5 && v < cam->height - 0.5;
}

/* Angle of a ray from the optical axis, 0..pi. */
static double ray_angle(mc_vec3 p)
{
	return atan2(hypot(p.x, p.y), p.z);
}

/* ---- pinhole with OpenCV radial-tangential distortion ---------------- */

/* Distorts normalised coordinates (x, y); optionally returns the Jacobian
 * d(xd, yd)/d(x, y) as J[row][col]. */
static void pinhole_distort(const double k[5], double x, double y, double *xd, double *yd, double J[2][2])
{
	double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4];
	double r2 = x * x + y * y;
	double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
	*xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
	*yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
	if (J) {
		double dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2); /* d radial / d r2 */
		J[0][0] = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x;
		J[0][1] = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y;
		J[1][0] = J[0][1];
		J[1][1] = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x;
	}
}

/* max_theta: the field to project within (the camera's, or wider for an
 * unbounded projection). */
static bool pinhole_project(const mc_camera *cam, mc_vec3 p, double max_theta, double *u, double *v)
{
	if (!(p.z > 0) || ray_angle(p) > max_theta)
		return false;
	double xd, yd;
	pinhole_distort(cam->k, p.x / p.z, p.y / p.z, &xd, &yd, NULL);
	*u = cam->fx * xd + cam->cx;
	*v = cam->fy * yd + cam->cy;
	return true;
}

/* Undistorts by damped Newton from the distorted point; the residual must
 * shrink at every accepted step, which keeps the solve on the monotonic
 * branch that mc_camera_validate checked. */
static bool pinhole_undistort(const double k[5], double xd, double yd, double *x, double *y)
{
	double cx = xd, cy = yd, fx, fy;
	pinhole_distort(k, cx, cy, &fx, &fy, NULL);
	double res = hypot(fx - xd, fy - yd);
	for (int it = 0; it < SOLVE_MAX_ITER && res > 1e-15; it++) {
		double J[2][2];
		pinhole_distort(k, cx, cy, &fx, &fy, J);
		double det = J[0][0] * J[1][1] - J[0][1] * J[1][0];
		if (!(fabs(det) > 1e-300))
			return false;
		double rx = fx - xd, ry = fy - yd;
		double dx = -(J[1][1] * rx - J[0][1] * ry) / det;
		double dy = -(-J[1][0] * rx + J[0][0] * ry) / det;
		/* Halve the step until the residual shrinks. */
		double step = 1, nres = INFINITY, nx = cx, ny = cy;
		for (int half = 0; half < 40; half++, step *= 0.5) {
			double gx, gy;
			nx = cx + step * dx, ny = cy + step * dy;
			pinhole_distort(k, nx, ny, &gx, &gy, NULL);
			nres = hypot(gx - xd, gy - yd);
			if (nres < res)
				break;
		}
		if (!(nres < res))
			break;
		cx = nx, cy = ny, res = nres;
		if (hypot(dx, dy) * step < SOLVE_TOL * 1e-3)
			break;
	}
	*x = cx, *y = cy;
	return res < 1e-10;
}

static bool pinhole_unproject(const mc_camera *cam, double u, double v, mc_vec3 *ray)
{
	double x, y;
	if (!pinhole_undistort(cam->k, (u - cam->cx) / cam->fx, (v - cam->cy) / cam->fy, &x, &y))
		return false;
	mc_vec3 r = mc_v3_normalize(mc_v3(x, y, 1));
	if (ray_angle(r) > cam->max_theta * (1 + 1e-12))
		return false;
	*ray = r;
	return true;
}

/* ---- equidistant (Kannala-Brandt as OpenCV cv::fisheye) --------------- */

static double kb_theta_d(const double k[5], double t)
{
	double t2 = t * t;
	return t * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}

static double kb_dtheta_d(const double k[5], double t)
{
	double t2 = t * t;
	return 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
}

static bool equidistant_project(const mc_camera *cam, mc_vec3 p, double max_theta, double *u, double *v)
{
	double rxy = hypot(p.x, p.y);
	if (rxy == 0 && !(p.z > 0))
		return false;
	double theta = atan2(rxy, p.z);
	if (theta > max_theta)
		return false;
	double td = kb_theta_d(cam->k, theta);
	/* td / rxy scales the unit direction in the image plane; at the axis the
	 * point maps to the principal point. */
	double s = rxy > 0 ? td / rxy : 0;
	*u = cam->fx * p.x * s + cam->cx;
	*v = cam->fy * p.y * s + cam->cy;
	return true;
}

/* Solves f(x) = target for x in the bracket [lo, hi], f increasing there:
 * Newton from x, falling back to bisection whenever a step leaves the
 * bracket; stops when a step is below tol. */
typedef struct {
	double (*f)(const void *ctx, double x);
	double (*df)(const void *ctx, double x);
	const void *ctx;
} increasing_fn;

static double solve_increasing(increasing_fn fn, double target, double lo, double hi, double x, double tol)
{
	for (int it = 0; it < SOLVE_MAX_ITER; it++) {
		double f = fn.f(fn.ctx, x) - target;
		if (f > 0)
			hi = x;
		else
			lo = x;
		double d = fn.df(fn.ctx, x);
		double next = d > 0 ? x - f / d : -1;
		if (!(next > lo && next < hi))
			next = 0.5 * (lo + hi);
		double step = fabs(next - x);
		x = next;
		if (step < tol)
			break;
	}
	return x;
}

static double kb_f(const void *k, double t)
{
	return kb_theta_d(k, t);
}

static double kb_df(const void *k, double t)
{
	return kb_dtheta_d(k, t);
}

/* Solves kb_theta_d(theta) = td for theta in [0, hi], where kb_theta_d is
 * increasing (validated). */
static double kb_solve_theta(const double k[5], double td, double hi)
{
	increasing_fn fn = {kb_f, kb_df, k};
	return solve_increasing(fn, td, 0, hi, fmin(td, hi), SOLVE_TOL);
}

static bool equidistant_unproject(const mc_camera *cam, double u, double v, mc_vec3 *ray)
{
	double xd = (u - cam->cx) / cam->fx, yd = (v - cam->cy) / cam->fy;
	double td = hypot(xd, yd);
	if (td == 0) {
		*ray = mc_v3(0, 0, 1);
		return true;
	}
	if (td > kb_theta_d(cam->k, cam->max_theta) * (1 + 1e-12))
		return false;
	double theta = kb_solve_theta(cam->k, td, cam->max_theta);
	double s = sin(theta) / td;
	*ray = mc_v3(xd * s, yd * s, cos(theta));
	return true;
}

/* ---- ocam (Scaramuzza), already in OpenCV axes ------------------------ */

static double poly_eval(const double *c, int n, double x)
{
	double r = 0;
	for (int i = n - 1; i >= 0; i--)
		r = r * x + c[i];
	return r;
}

static double poly_deriv(const double *c, int n, double x)
{
	double r = 0;
	for (int i = n - 1; i >= 1; i--)
		r = r * x + i * c[i];
	return r;
}

/* Angle from the optical axis of the ray (rho, w(rho)) and its derivative. */
static double ocam_theta(const mc_camera *cam, double rho)
{
	return atan2(rho, poly_eval(cam->ocam_pol, cam->ocam_pol_len, rho));
}

static double ocam_dtheta(const mc_camera *cam, double rho)
{
	double w = poly_eval(cam->ocam_pol, cam->ocam_pol_len, rho);
	double dw = poly_deriv(cam->ocam_pol, cam->ocam_pol_len, rho);
	return (w - rho * dw) / (rho * rho + w * w);
}

/* The distance from the distortion centre, in the undistorted (u', v')
 * plane, of the image corner farthest from it: no valid pixel lies beyond. */
static double ocam_rho_limit(const mc_camera *cam)
{
	double det = cam->ocam_c - cam->ocam_d * cam->ocam_e, best = 0;
	for (int i = 0; i < 4; i++) {
		double du = (i & 1 ? cam->width - 0.5 : -0.5) - cam->ocam_xc;
		double dv = (i & 2 ? cam->height - 0.5 : -0.5) - cam->ocam_yc;
		double up = (du - cam->ocam_d * dv) / det, vp = (-cam->ocam_e * du + cam->ocam_c * dv) / det;
		best = fmax(best, hypot(up, vp));
	}
	return best;
}

static bool ocam_unproject(const mc_camera *cam, double u, double v, mc_vec3 *ray)
{
	double du = u - cam->ocam_xc, dv = v - cam->ocam_yc;
	double det = cam->ocam_c - cam->ocam_d * cam->ocam_e;
	double up = (du - cam->ocam_d * dv) / det, vp = (-cam->ocam_e * du + cam->ocam_c * dv) / det;
	double rho = hypot(up, vp);
	double w = poly_eval(cam->ocam_pol, cam->ocam_pol_len, rho);
	mc_vec3 r = mc_v3_normalize(mc_v3(up, vp, w));
	/* Beyond a fold of w(rho) the same angles repeat: such pixels are not
	 * part of the lens' field (validation makes the valid set a disc). */
	if (ray_angle(r) > cam->max_theta * (1 + 1e-12) || (rho > 0 && !(ocam_dtheta(cam, rho) > 0)))
		return false;
	*ray = r;
	return true;
}

/* Solves ocam_theta(rho) = theta for rho: brackets the root by scanning out
 * from the centre (theta(rho) increases up to the edge of the valid field),
 * then Newton with bisection safeguard, started from the inverse polynomial
 * when there is one. Returns false if the angle is not reached. */
static double ocam_f(const void *cam, double r)
{
	return ocam_theta(cam, r);
}

static double ocam_df(const void *cam, double r)
{
	return ocam_dtheta(cam, r);
}

static bool ocam_solve_rho(const mc_camera *cam, double theta, double *rho_out)
{
	const int nscan = 64;
	double limit = ocam_rho_limit(cam), h = limit / nscan;
	double lo = 0, hi = -1;
	for (int i = 1; i <= nscan; i++) {
		double r = i * h;
		if (!(ocam_dtheta(cam, r) > 0) && ocam_theta(cam, r) < theta)
			return false; /* folded before reaching the angle */
		if (ocam_theta(cam, r) >= theta) {
			hi = r;
			break;
		}
		lo = r;
	}
	if (hi < 0)
		return false;
	double r = 0.5 * (lo + hi);
	if (cam->ocam_invpol_len > 0) {
		double guess = poly_eval(cam->ocam_invpol, cam->ocam_invpol_len, theta - M_PI / 2);
		if (guess > lo && guess < hi)
			r = guess;
	}
	increasing_fn fn = {ocam_f, ocam_df, cam};
	*rho_out = solve_increasing(fn, theta, lo, hi, r, SOLVE_TOL * fmax(1, limit));
	return true;
}

static bool ocam_project(const mc_camera *cam, mc_vec3 p, double *u, double *v)
{
	double rxy = hypot(p.x, p.y);
	double up = 0, vp = 0;
	if (rxy == 0 && !(p.z > 0))
		return false;
	if (rxy > 0) {
		double theta = atan2(rxy, p.z), rho;
		if (theta > cam->max_theta || !ocam_solve_rho(cam, theta, &rho))
			return false;
		up = p.x / rxy * rho;
		vp = p.y / rxy * rho;
	}
	*u = cam->ocam_xc + cam->ocam_c * up + cam->ocam_d * vp;
	*v = cam->ocam_yc + cam->ocam_e * up + vp;
	return true;
}

/* ---- dispatch ---------------------------------------------------------- */

/* The lens formula alone; an unbounded projection lifts max_theta for the
 * pinhole (to 90 degrees) and equidistant (to 180) models. */
static bool project_model(const mc_camera *cam, mc_vec3 p_cam, bool bounded, double *u, double *v)
{
	if (!mc_v3_isfinite(p_cam))
		return false;
	switch (cam->model) {
	case MC_CAM_PINHOLE: return pinhole_project(cam, p_cam, bounded ? cam->max_theta : M_PI / 2, u, v);
	case MC_CAM_EQUIDISTANT: return equidistant_project(cam, p_cam, bounded ? cam->max_theta : M_PI, u, v);
	case MC_CAM_OCAM: return ocam_project(cam, p_cam, u, v);
	default: return false;
	}
}

bool mc_camera_project(const mc_camera *cam, mc_vec3 p_cam, double *u, double *v)
{
	double pu, pv;
	if (!project_model(cam, p_cam, true, &pu, &pv) || !in_image(cam, pu, pv))
		return false;
	*u = pu, *v = pv;
	return true;
}

bool mc_camera_project_unbounded(const mc_camera *cam, mc_vec3 p_cam, double *u, double *v)
{
	return project_model(cam, p_cam, false, u, v);
}

bool mc_camera_unproject(const mc_camera *cam, double u, double v, mc_vec3 *ray)
{
	if (!isfinite(u) || !isfinite(v) || !in_image(cam, u, v))
		return false;
	switch (cam->model) {
	case MC_CAM_PINHOLE: return pinhole_unproject(cam, u, v, ray);
	case MC_CAM_EQUIDISTANT: return equidistant_unproject(cam, u, v, ray);
	case MC_CAM_OCAM: return ocam_unproject(cam, u, v, ray);
	}
	return false;
}

bool mc_camera_project_rig(const mc_camera *cam, mc_vec3 p_rig, double *u, double *v)
{
	return mc_camera_project(cam, mc_xform_apply(mc_xform_inverse(cam->rig_from_cam), p_rig), u, v);
}

bool mc_camera_unproject_rig(const mc_camera *cam, double u, double v, mc_vec3 *dir_rig)
{
	mc_vec3 ray;
	if (!mc_camera_unproject(cam, u, v, &ray))
		return false;
	*dir_rig = mc_v3_normalize(mc_m3_apply(cam->rig_from_cam.R, ray));
	return true;
}

/* ---- validation -------------------------------------------------------- */

static int check_finite(const double *a, int n, const char *field, mc_err *err)
{
	for (int i = 0; i < n; i++)
		if (!isfinite(a[i]))
			return mc_err_set(err, "%s[%d]: not a finite number", field, i);
	return 0;
}

static int validate_pinhole(const mc_camera *cam, mc_err *err)
{
	if (!(cam->max_theta < M_PI / 2))
		return mc_err_set(err, "max_theta: a pinhole camera sees less than 90 degrees off axis (got %g deg)",
				  cam->max_theta * 180 / M_PI);
	/* The radial map r -> r (1 + k1 r^2 + k2 r^4 + k3 r^6) must increase
	 * over the field, or pixels would have two rays. */
	double rmax = tan(cam->max_theta);
	for (int i = 0; i <= MONOTONIC_SAMPLES; i++) {
		double r = rmax * i / MONOTONIC_SAMPLES, r2 = r * r;
		double slope = 1 + r2 * (3 * cam->k[0] + r2 * (5 * cam->k[1] + r2 * 7 * cam->k[4]));
		if (!(slope > 0))
			return mc_err_set(err, "k: radial distortion folds back at %.1f deg off axis, inside max_theta",
					  atan(r) * 180 / M_PI);
	}
	return 0;
}

static int validate_equidistant(const mc_camera *cam, mc_err *err)
{
	for (int i = 0; i <= MONOTONIC_SAMPLES; i++) {
		double t = cam->max_theta * i / MONOTONIC_SAMPLES;
		if (!(kb_dtheta_d(cam->k, t) > 0))
			return mc_err_set(err, "k: distortion folds back at %.1f deg off axis, inside max_theta",
					  t * 180 / M_PI);
	}
	return 0;
}

static int validate_ocam(const mc_camera *cam, mc_err *err)
{
	if (cam->ocam_pol_len < 1 || cam->ocam_pol_len > MC_OCAM_POLY_MAX)
		return mc_err_set(err, "ocam_pol: needs 1 to %d coefficients, got %d", MC_OCAM_POLY_MAX,
				  cam->ocam_pol_len);
	if (cam->ocam_invpol_len < 0 || cam->ocam_invpol_len > MC_OCAM_POLY_MAX * 2)
		return mc_err_set(err, "ocam_invpol: at most %d coefficients, got %d", MC_OCAM_POLY_MAX * 2,
				  cam->ocam_invpol_len);
	if (check_finite(cam->ocam_pol, cam->ocam_pol_len, "ocam_pol", err) ||
	    check_finite(cam->ocam_invpol, cam->ocam_invpol_len, "ocam_invpol", err))
		return -1;
	double affine[5] = {cam->ocam_xc, cam->ocam_yc, cam->ocam_c, cam->ocam_d, cam->ocam_e};
	static const char *const names[5] = {"ocam_xc", "ocam_yc", "ocam_c", "ocam_d", "ocam_e"};
	for (int i = 0; i < 5; i++)
		if (!isfinite(affine[i]) || fabs(affine[i]) > MC_CAMERA_COORD_MAX)
			return mc_err_set(err, "%s: must be a finite number within +-%g, got %g", names[i],
					  MC_CAMERA_COORD_MAX, affine[i]);
	if (!(cam->ocam_pol[0] > 0))
		return mc_err_set(err, "ocam_pol[0]: must be positive (the centre pixel looks along +z), got %g",
				  cam->ocam_pol[0]);
	double det = cam->ocam_c - cam->ocam_d * cam->ocam_e;
	if (!(det > 1e-6))
		return mc_err_set(err, "ocam_c: affine matrix [c d; e 1] must have a positive determinant, got %g", det);
	/* The valid field must be a disc about the centre: theta(rho) increases
	 * until it passes max_theta and, once it has left the field, never comes
	 * back into it within the image. */
	double limit = ocam_rho_limit(cam);
	bool left = false;
	for (int i = 1; i <= MONOTONIC_SAMPLES; i++) {
		double rho = limit * i / MONOTONIC_SAMPLES;
		bool inside = ocam_theta(cam, rho) <= cam->max_theta && ocam_dtheta(cam, rho) > 0;
		if (!inside && !left && ocam_theta(cam, rho) < cam->max_theta)
			return mc_err_set(err, "ocam_pol: w(rho) folds back at rho = %.1f px (%.1f deg), inside max_theta",
					  rho, ocam_theta(cam, rho) * 180 / M_PI);
		if (!inside)
			left = true;
		else if (left)
			return mc_err_set(err, "ocam_pol: w(rho) re-enters the field at rho = %.1f px", rho);
	}
	return 0;
}

static int validate_pose(const mc_xform *x, mc_err *err)
{
	if (!mc_m3_isfinite(x->R) || !mc_v3_isfinite(x->t))
		return mc_err_set(err, "rig_from_cam: not finite");
	double dist = hypot(hypot(x->t.x, x->t.y), x->t.z); /* no overflow at 1e300 */
	if (dist > MC_CAMERA_OFFSET_MAX_M)
		return mc_err_set(err, "rig_from_cam: the camera is %g m from the rig origin (at most %g m)", dist,
				  MC_CAMERA_OFFSET_MAX_M);
	mc_mat3 RRt = mc_m3_mul(x->R, mc_m3_transpose(x->R));
	double dev = 0;
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			dev = fmax(dev, fabs(RRt.m[i][j] - (i == j)));
	const double(*m)[3] = x->R.m;
	double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
		     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
	/* Calibration files carry single-precision rotations: allow 1e-5. */
	if (dev > 1e-5 || det < 0)
		return mc_err_set(err, "rig_from_cam: rotation block is not a rotation (|R R^T - I| = %.3g, det = %.6g)",
				  dev, det);
	return 0;
}

int mc_camera_validate(const mc_camera *cam, mc_err *err)
{
	if ((int)cam->model < 0 || (int)cam->model > MC_CAM_OCAM)
		return mc_err_set(err, "model: unknown camera model %d", (int)cam->model);
	if (cam->width < 1 || cam->width > MC_CAMERA_SIZE_MAX)
		return mc_err_set(err, "width: must be 1..%d, got %d", MC_CAMERA_SIZE_MAX, cam->width);
	if (cam->height < 1 || cam->height > MC_CAMERA_SIZE_MAX)
		return mc_err_set(err, "height: must be 1..%d, got %d", MC_CAMERA_SIZE_MAX, cam->height);
	if (!(cam->max_theta > 0 && cam->max_theta < M_PI))
		return mc_err_set(err, "max_theta: must be in (0, 180) degrees, got %g", cam->max_theta * 180 / M_PI);
	if (cam->model != MC_CAM_OCAM) {
		double f[4] = {cam->fx, cam->fy, cam->cx, cam->cy};
		static const char *const names[4] = {"fx", "fy", "cx", "cy"};
		for (int i = 0; i < 4; i++)
			if (!isfinite(f[i]))
				return mc_err_set(err, "%s: not a finite number", names[i]);
		for (int i = 0; i < 2; i++)
			if (!(f[i] >= MC_CAMERA_FOCAL_MIN && f[i] <= MC_CAMERA_COORD_MAX))
				return mc_err_set(err, "%s: must be in [%g, %g] pixels, got %g", names[i], MC_CAMERA_FOCAL_MIN,
						  MC_CAMERA_COORD_MAX, f[i]);
		for (int i = 2; i < 4; i++)
			if (fabs(f[i]) > MC_CAMERA_COORD_MAX)
				return mc_err_set(err, "%s: must be within +-%g pixels, got %g", names[i], MC_CAMERA_COORD_MAX,
						  f[i]);
		if (check_finite(cam->k, 5, "k", err))
			return -1;
	}
	int r;
	switch (cam->model) {
	case MC_CAM_PINHOLE: r = validate_pinhole(cam, err); break;
	case MC_CAM_EQUIDISTANT: r = validate_equidistant(cam, err); break;
	case MC_CAM_OCAM: r = validate_ocam(cam, err); break;
	default: return mc_err_set(err, "model: unknown camera model %d", (int)cam->model);
	}
	if (r)
		return r;
	return validate_pose(&cam->rig_from_cam, err);
}

/* The widest image corner's angle with a 10% margin (below 89 degrees for
 * a pinhole, 179 for a fisheye), narrowed by 5% steps while the distortion
 * folds back inside it.  The corner's angle ignores the distortion, which
 * the margin and the narrowing absorb. */
int mc_camera_fit_max_theta(mc_camera *cam, mc_err *err)
{
	const double deg = M_PI / 180;
	double widest = 0;
	for (int corner = 0; corner < 4; corner++) {
		double u = (corner & 1) ? cam->width - 0.5 : -0.5, v = (corner & 2) ? cam->height - 0.5 : -0.5;
		double x = (u - cam->cx) / cam->fx, y = (v - cam->cy) / cam->fy;
		double r = sqrt(x * x + y * y);
		widest = fmax(widest, cam->model == MC_CAM_PINHOLE ? atan(r) : r);
	}
	double limit = cam->model == MC_CAM_PINHOLE ? 89 * deg : 179 * deg;
	cam->max_theta = fmin(1.1 * widest, limit);
	for (int tries = 0; tries < 40; tries++) {
		if (mc_camera_validate(cam, err) == 0)
			return 0;
		if (!strstr(err->msg, "folds back"))
			return -1;
		cam->max_theta *= 0.95;
	}
	return -1;
}
