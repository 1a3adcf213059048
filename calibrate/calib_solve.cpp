/* calib_solve: intrinsics (OpenCV first estimate, then a bundle adjustment
 * through the project's camera models) and rig extrinsics. */
#include "calib_solve.hpp"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace {

/* ---- parameter blocks ------------------------------------------------------ */

/* Intrinsics: fx fy cx cy and the distortion coefficients the model
 * estimates, as indices into mc_camera.k (pinhole k1 k2 [p1 p2] [k3];
 * equidistant k1..k4). */
std::vector<int> distortion_terms(const calib_cam &c)
{
	if (c.model != MC_CAM_PINHOLE)
		return {0, 1, 2, 3};
	std::vector<int> terms = {0, 1};
	if (c.pinhole_tangential)
		terms.push_back(2), terms.push_back(3);
	if (c.pinhole_k3)
		terms.push_back(4);
	return terms;
}

void put_intrinsics(const std::vector<int> &terms, const mc_camera &cam, double *p)
{
	p[0] = cam.fx, p[1] = cam.fy, p[2] = cam.cx, p[3] = cam.cy;
	for (size_t i = 0; i < terms.size(); i++)
		p[4 + i] = cam.k[terms[i]];
}

void get_intrinsics(const std::vector<int> &terms, const double *p, mc_camera *cam)
{
	cam->fx = p[0], cam->fy = p[1], cam->cx = p[2], cam->cy = p[3];
	for (size_t i = 0; i < terms.size(); i++)
		cam->k[terms[i]] = p[4 + i];
}

/* A pose as a rotation vector and a translation. */
void put_pose(const mc_xform &x, double *p)
{
	mc_vec3 r = mc_m3_to_rotvec(x.R);
	p[0] = r.x, p[1] = r.y, p[2] = r.z, p[3] = x.t.x, p[4] = x.t.y, p[5] = x.t.z;
}

mc_xform get_pose(const double *p)
{
	mc_xform x;
	x.R = mc_m3_from_rotvec(mc_v3(p[0], p[1], p[2]));
	x.t = mc_v3(p[3], p[4], p[5]);
	return x;
}

mc_xform pose_from_cv(const cv::Mat &rvec, const cv::Mat &tvec)
{
	cv::Mat r, t;
	rvec.convertTo(r, CV_64F);
	tvec.convertTo(t, CV_64F);
	mc_xform x;
	x.R = mc_m3_from_rotvec(mc_v3(r.at<double>(0), r.at<double>(1), r.at<double>(2)));
	x.t = mc_v3(t.at<double>(0), t.at<double>(1), t.at<double>(2));
	return x;
}

/* ---- the adjustment -------------------------------------------------------- */

/* One used view in the problem: its camera, its view set, its rows. */
struct observation {
	int cam, set;
	calib_view *view;
	int row;
};

/* Cameras (intrinsics, pose in the rig; camera 0's pose is the gauge and
 * stays fixed) and view sets (the board's pose in the rig), with the
 * observations that tie them. */
struct problem {
	std::vector<calib_cam *> cams;
	std::vector<mc_xform> rig_from_cam;  /* start values; [0] fixed */
	std::vector<mc_xform> rig_from_board; /* start values per set */
	std::vector<observation> obs;
	std::vector<int> intr_off, extr_off, set_off; /* parameter offsets; -1: fixed */
	std::vector<std::vector<int>> terms;          /* each camera's distortion_terms */
	std::vector<std::vector<int>> obs_of_cam, obs_of_set;
	std::vector<const std::vector<int> *> moved_by; /* per parameter: the observations it moves */
	int nparams = 0, rows = 0;

	void layout()
	{
		obs_of_cam.assign(cams.size(), {});
		obs_of_set.assign(rig_from_board.size(), {});
		rows = 0;
		for (size_t i = 0; i < obs.size(); i++) {
			obs[i].row = rows;
			rows += 2 * (int)obs[i].view->corners.ids.size();
			obs_of_cam[obs[i].cam].push_back((int)i);
			obs_of_set[obs[i].set].push_back((int)i);
		}
		nparams = 0;
		for (size_t c = 0; c < cams.size(); c++) {
			terms.push_back(distortion_terms(*cams[c]));
			int n = 4 + (int)terms[c].size() + (c == 0 ? 0 : 6);
			intr_off.push_back(nparams);
			extr_off.push_back(c == 0 ? -1 : nparams + n - 6);
			moved_by.insert(moved_by.end(), n, &obs_of_cam[c]);
			nparams += n;
		}
		for (size_t s = 0; s < rig_from_board.size(); s++) {
			set_off.push_back(nparams);
			moved_by.insert(moved_by.end(), 6, &obs_of_set[s]);
			nparams += 6;
		}
	}

	void start(double *p) const
	{
		for (size_t c = 0; c < cams.size(); c++) {
			put_intrinsics(terms[c], cams[c]->cam, p + intr_off[c]);
			if (extr_off[c] >= 0)
				put_pose(rig_from_cam[c], p + extr_off[c]);
		}
		for (size_t s = 0; s < rig_from_board.size(); s++)
			put_pose(rig_from_board[s], p + set_off[s]);
	}

	mc_camera camera(int c, const double *p) const
	{
		mc_camera cam = cams[c]->cam;
		get_intrinsics(terms[c], p + intr_off[c], &cam);
		cam.rig_from_cam = extr_off[c] >= 0 ? get_pose(p + extr_off[c]) : rig_from_cam[0];
		return cam;
	}

	mc_xform cam_from_board(const observation &o, const mc_camera &cam, const double *p) const
	{
		return mc_xform_compose(mc_xform_inverse(cam.rig_from_cam), get_pose(p + set_off[o.set]));
	}

	/* The observation's residuals (projected minus detected, pixels); a
	 * corner that does not project (behind a pinhole) counts zero. */
	void residuals(const observation &o, const double *p, double *r) const
	{
		mc_camera cam = camera(o.cam, p);
		mc_xform x = cam_from_board(o, cam, p);
		const calib_corners &cc = o.view->corners;
		for (size_t i = 0; i < cc.ids.size(); i++) {
			mc_vec3 q = mc_xform_apply(x, mc_v3(cc.obj[i].x, cc.obj[i].y, cc.obj[i].z));
			double u, v;
			if (mc_camera_project_unbounded(&cam, q, &u, &v))
				r[2 * i] = u - cc.px[i].x, r[2 * i + 1] = v - cc.px[i].y;
			else
				r[2 * i] = r[2 * i + 1] = 0;
		}
	}
};

/* Residuals and a forward-difference Jacobian that recomputes only the
 * observations each parameter moves (a camera's, or a view set's). */
class adjustment : public cv::LMSolver::Callback {
public:
	explicit adjustment(const problem &pb) : pb_(pb) {}

	bool compute(cv::InputArray param, cv::OutputArray err, cv::OutputArray jac) const override
	{
		cv::Mat p = param.getMat();
		std::vector<double> x(p.ptr<double>(), p.ptr<double>() + pb_.nparams);
		err.create(pb_.rows, 1, CV_64F);
		cv::Mat e = err.getMat();
		for (const observation &o : pb_.obs)
			pb_.residuals(o, x.data(), e.ptr<double>() + o.row);
		if (!jac.needed())
			return true;
		jac.create(pb_.rows, pb_.nparams, CV_64F);
		cv::Mat J = jac.getMat();
		J.setTo(0);
		std::vector<double> r(pb_.rows);
		for (int j = 0; j < pb_.nparams; j++) {
			double keep = x[j], h = 1e-7 * std::max(1.0, std::fabs(keep));
			x[j] = keep + h;
			for (int oi : *pb_.moved_by[j]) {
				const observation &o = pb_.obs[oi];
				int n = 2 * (int)o.view->corners.ids.size();
				pb_.residuals(o, x.data(), r.data() + o.row);
				for (int k = 0; k < n; k++)
					J.at<double>(o.row + k, j) = (r[o.row + k] - e.at<double>(o.row + k)) / h;
			}
			x[j] = keep;
		}
		return true;
	}

private:
	const problem &pb_;
};

/* Runs the adjustment and writes the results back: intrinsics, poses,
 * per-view errors and board poses, per-camera RMS. */
void adjust(problem &pb)
{
	pb.layout();
	cv::Mat p(pb.nparams, 1, CV_64F);
	pb.start(p.ptr<double>());
	cv::Ptr<cv::LMSolver> lm = cv::LMSolver::create(cv::makePtr<adjustment>(pb), 200, 1e-12);
	lm->run(p);
	const double *x = p.ptr<double>();
	std::vector<double> sq(pb.cams.size(), 0);
	std::vector<int> n(pb.cams.size(), 0);
	for (size_t c = 0; c < pb.cams.size(); c++) {
		mc_camera cam = pb.camera((int)c, x);
		pb.cams[c]->cam = cam;
		pb.rig_from_cam[c] = cam.rig_from_cam;
	}
	for (size_t s = 0; s < pb.rig_from_board.size(); s++)
		pb.rig_from_board[s] = get_pose(x + pb.set_off[s]);
	for (const observation &o : pb.obs) {
		size_t nc = o.view->corners.ids.size();
		std::vector<double> r(2 * nc);
		pb.residuals(o, x, r.data());
		double view_sq = 0, worst = 0;
		for (size_t i = 0; i < nc; i++) {
			double e2 = r[2 * i] * r[2 * i] + r[2 * i + 1] * r[2 * i + 1];
			view_sq += e2;
			worst = std::max(worst, std::sqrt(e2));
		}
		o.view->rms = std::sqrt(view_sq / nc);
		o.view->max_err = worst;
		o.view->cam_from_board = pb.cam_from_board(o, pb.cams[o.cam]->cam, x);
		sq[o.cam] += view_sq;
		n[o.cam] += (int)nc;
	}
	for (size_t c = 0; c < pb.cams.size(); c++)
		pb.cams[c]->rms = n[c] ? std::sqrt(sq[c] / n[c]) : 0;
}

/* Rejects views whose error stands out: above reject_px and three times
 * the median. Returns how many were rejected. */
int reject_outliers(calib_cam *c, const calib_options *opt)
{
	std::vector<double> rms;
	for (const calib_view &v : c->views)
		if (v.used)
			rms.push_back(v.rms);
	if (rms.size() < 3)
		return 0;
	std::nth_element(rms.begin(), rms.begin() + rms.size() / 2, rms.end());
	double median = rms[rms.size() / 2], limit = std::max(opt->reject_px, 3 * median);
	int rejected = 0;
	for (calib_view &v : c->views)
		if (v.used && v.rms > limit) {
			char why[160];
			std::snprintf(why, sizeof why,
				      "reprojection error %.2f px, above %.2f px (3 x the median %.2f): blurred or moved board",
				      v.rms, limit, median);
			v.used = false;
			v.why = why;
			rejected++;
		}
	return rejected;
}

/* Drops single corners whose error stands out from the camera's RMS (a
 * refinement that slid to a marker's edge on a steeply tilted board).
 * Returns how many were dropped. */
int drop_outlier_corners(calib_cam *c, const calib_options *opt)
{
	double limit = std::max(0.5, opt->corner_sigmas * c->rms);
	int dropped = 0;
	std::vector<cv::Point2f> re;
	for (calib_view &v : c->views) {
		if (!v.used)
			continue;
		calib_reproject(*c, v, re);
		calib_corners &cc = v.corners;
		size_t keep = 0;
		for (size_t i = 0; i < cc.ids.size(); i++) {
			if (cv::norm(re[i] - cc.px[i]) > limit) {
				v.dropped++, dropped++;
				continue;
			}
			cc.ids[keep] = cc.ids[i], cc.px[keep] = cc.px[i], cc.obj[keep] = cc.obj[i];
			keep++;
		}
		cc.ids.resize(keep), cc.px.resize(keep), cc.obj.resize(keep);
		if ((int)keep < opt->min_corners) {
			v.used = false;
			v.why = std::to_string(keep) + " corners left after dropping " + std::to_string(v.dropped) +
				" with large errors";
		}
	}
	return dropped;
}

/* ---- per camera ------------------------------------------------------------ */

/* Marks views without enough corners; returns how many remain. */
int select_views(calib_cam *c, const calib_options *opt)
{
	int used = 0;
	for (calib_view &v : c->views) {
		v.used = false;
		if (v.corners.markers == 0)
			v.why = "no board found";
		else if ((int)v.corners.ids.size() < opt->min_corners)
			v.why = std::to_string(v.corners.ids.size()) + " corners found, at least " +
				std::to_string(opt->min_corners) + " needed";
		else
			v.used = true, used++;
	}
	return used;
}

/* The used corners must reach over the image: at least 5 of 16 cells. */
int check_coverage(const calib_cam *c, mc_err *err)
{
	int covered = calib_coverage_cells(*c);
	if (covered < 5)
		return mc_err_set(err,
				  "camera %s: the board was seen in only %d of 16 parts of the image: the distortion "
				  "cannot be measured from there; hold the board near the edges and corners of the image too",
				  c->name.c_str(), covered);
	return 0;
}

/* The used views' corners, as OpenCV wants them. */
template <typename P3, typename P2>
void cv_points(const calib_cam *c, std::vector<std::vector<P3>> &obj, std::vector<std::vector<P2>> &img)
{
	for (const calib_view &v : c->views)
		if (v.used) {
			std::vector<P3> o;
			std::vector<P2> i;
			for (size_t k = 0; k < v.corners.ids.size(); k++) {
				o.push_back(P3(v.corners.obj[k].x, v.corners.obj[k].y, v.corners.obj[k].z));
				i.push_back(P2(v.corners.px[k].x, v.corners.px[k].y));
			}
			obj.push_back(o);
			img.push_back(i);
		}
}

void start_camera(calib_cam *c)
{
	c->cam = mc_camera{};
	std::snprintf(c->cam.name, sizeof c->cam.name, "%s", c->name.c_str());
	c->cam.model = c->model;
	c->cam.width = c->width, c->cam.height = c->height;
	c->cam.rig_from_cam = mc_xform_identity();
}

/* cv::calibrateCamera: k1 k2, and p1 p2 and k3 when asked. */
void opencv_pinhole(calib_cam *c, std::vector<mc_xform> &poses)
{
	std::vector<std::vector<cv::Point3f>> obj;
	std::vector<std::vector<cv::Point2f>> img;
	cv_points(c, obj, img);
	cv::Mat K, D;
	std::vector<cv::Mat> rv, tv;
	int flags = (c->pinhole_k3 ? 0 : cv::CALIB_FIX_K3) | (c->pinhole_tangential ? 0 : cv::CALIB_ZERO_TANGENT_DIST);
	cv::calibrateCamera(obj, img, cv::Size(c->width, c->height), K, D, rv, tv, flags);
	c->cam.fx = K.at<double>(0, 0), c->cam.fy = K.at<double>(1, 1);
	c->cam.cx = K.at<double>(0, 2), c->cam.cy = K.at<double>(1, 2);
	for (int i = 0; i < 5 && i < (int)D.total(); i++)
		c->cam.k[i] = D.at<double>(i);
	for (size_t i = 0; i < rv.size(); i++)
		poses.push_back(pose_from_cv(rv[i], tv[i]));
}

/* A start without OpenCV's fisheye solver: the ideal equidistant lens
 * filling the image with the given (or a 180-degree) field, and each view's
 * pose from its corners' rays in front of the camera. */
void equidistant_guess(calib_cam *c, std::vector<mc_xform> &poses)
{
	double half = (c->fov_deg > 0 ? c->fov_deg : 180) / 2 * M_PI / 180;
	c->cam.fx = c->cam.fy = std::min(c->width, c->height) / 2.0 / half;
	c->cam.cx = (c->width - 1) / 2.0, c->cam.cy = (c->height - 1) / 2.0;
	for (double &k : c->cam.k)
		k = 0;
	c->cam.max_theta = M_PI;
	poses.clear();
	for (calib_view &v : c->views) {
		if (!v.used)
			continue;
		std::vector<cv::Point3f> o;
		std::vector<cv::Point2f> n;
		for (size_t k = 0; k < v.corners.ids.size(); k++) {
			mc_vec3 ray;
			if (mc_camera_unproject(&c->cam, v.corners.px[k].x, v.corners.px[k].y, &ray) && ray.z > 0.2) {
				o.push_back(v.corners.obj[k]);
				n.push_back(cv::Point2f((float)(ray.x / ray.z), (float)(ray.y / ray.z)));
			}
		}
		cv::Mat rvec, tvec;
		if (o.size() < 4 || !cv::solvePnP(o, n, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec))
			poses.push_back(mc_xform{mc_m3_identity(), mc_v3(0, 0, 1)});
		else
			poses.push_back(pose_from_cv(rvec, tvec));
	}
}

/* cv::fisheye::calibrate (no skew); falls back to equidistant_guess when it
 * fails, as it may for lenses near 180 degrees. */
void opencv_fisheye(calib_cam *c, std::vector<mc_xform> &poses, bool verbose)
{
	std::vector<std::vector<cv::Point3d>> obj;
	std::vector<std::vector<cv::Point2d>> img;
	cv_points(c, obj, img);
	cv::Matx33d K;
	cv::Vec4d D;
	std::vector<cv::Mat> rv, tv;
	try {
		cv::fisheye::calibrate(obj, img, cv::Size(c->width, c->height), K, D, rv, tv,
				       cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW,
				       cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-10));
	} catch (const cv::Exception &e) {
		if (verbose)
			std::fprintf(stderr, "mocap-calibrate: %s: cv::fisheye::calibrate failed (%s); starting from an ideal lens\n",
				     c->name.c_str(), e.what());
		equidistant_guess(c, poses);
		return;
	}
	c->cam.fx = K(0, 0), c->cam.fy = K(1, 1), c->cam.cx = K(0, 2), c->cam.cy = K(1, 2);
	for (int i = 0; i < 4; i++)
		c->cam.k[i] = D[i];
	for (size_t i = 0; i < rv.size(); i++)
		poses.push_back(pose_from_cv(rv[i], tv[i]));
}

/* The field of view: the given one, or the image corners' (narrowed where
 * the distortion folds back). */
int set_field_of_view(calib_cam *c, mc_err *err)
{
	if (c->fov_deg > 0) {
		c->cam.max_theta = c->fov_deg / 2 * M_PI / 180;
		if (mc_camera_validate(&c->cam, err) == 0)
			return 0;
	} else if (mc_camera_fit_max_theta(&c->cam, err) == 0) {
		return 0;
	}
	return mc_err_prefix(err, "camera %s: the calibrated lens is not usable", c->name.c_str());
}

/* A one-camera problem over the camera's used views. */
problem single_camera_problem(calib_cam *c, const std::vector<mc_xform> &poses)
{
	problem pb;
	pb.cams.push_back(c);
	pb.rig_from_cam.push_back(mc_xform_identity());
	size_t k = 0;
	for (calib_view &v : c->views)
		if (v.used) {
			pb.obs.push_back(observation{0, (int)pb.rig_from_board.size(), &v, 0});
			pb.rig_from_board.push_back(poses[k++]);
		}
	return pb;
}

int count_used(const calib_cam *c)
{
	int n = 0;
	for (const calib_view &v : c->views)
		n += v.used;
	return n;
}

} // namespace

int calib_grid_cell(cv::Point2f q, int width, int height, int n)
{
	return std::clamp((int)(n * q.y / height), 0, n - 1) * n + std::clamp((int)(n * q.x / width), 0, n - 1);
}

int calib_coverage_cells(const calib_cam &c)
{
	bool cell[16] = {};
	for (const calib_view &v : c.views)
		if (v.used)
			for (const cv::Point2f &q : v.corners.px)
				cell[calib_grid_cell(q, c.width, c.height, 4)] = true;
	return (int)std::count(cell, cell + 16, true);
}

int calib_intrinsics(calib_cam *c, const calib_options *opt, mc_err *err)
{
	int used = select_views(c, opt);
	if (used < opt->min_views)
		return mc_err_set(err,
				  "camera %s: the board was found in %d of %zu images, at least %d needed: show the "
				  "whole board or most of it, at several places and angles, in good light",
				  c->name.c_str(), used, c->views.size(), opt->min_views);
	if (check_coverage(c, err) < 0)
		return -1;
	start_camera(c);
	std::vector<mc_xform> poses;
	try {
		if (c->model == MC_CAM_PINHOLE)
			opencv_pinhole(c, poses);
		else
			opencv_fisheye(c, poses, opt->verbose);
	} catch (const cv::Exception &e) {
		return mc_err_set(err, "camera %s: OpenCV's calibration failed: %s", c->name.c_str(), e.what());
	}
	for (int round = 0; round < 4; round++) {
		problem pb = single_camera_problem(c, poses);
		adjust(pb);
		if (reject_outliers(c, opt) + drop_outlier_corners(c, opt) == 0)
			break;
		if (count_used(c) < opt->min_views)
			return mc_err_set(err, "camera %s: only %d views left after rejecting those with large errors",
					  c->name.c_str(), count_used(c));
		poses.clear();
		for (calib_view &v : c->views)
			if (v.used)
				poses.push_back(v.cam_from_board);
	}
	c->used_views = count_used(c);
	return set_field_of_view(c, err);
}

namespace {

/* The view sets: image names seen by any camera, numbered. */
std::map<std::string, int> view_sets(std::vector<calib_cam> &cams)
{
	std::map<std::string, int> sets;
	for (calib_cam &c : cams)
		for (calib_view &v : c.views)
			if (v.used && !sets.count(v.name)) {
				int n = (int)sets.size();
				sets[v.name] = n;
			}
	return sets;
}

calib_view *find_view(calib_cam &c, const std::string &name)
{
	for (calib_view &v : c.views)
		if (v.used && v.name == name)
			return &v;
	return nullptr;
}

/* The angle of the rotation between two poses, radians. */
double turn_between(const mc_xform &a, const mc_xform &b)
{
	return mc_v3_norm(mc_m3_to_rotvec(mc_m3_mul(mc_m3_transpose(a.R), b.R)));
}

/* How far apart two poses are: metres plus radians (a board's pose
 * seen from two cameras agrees to millimetres and tenths of a degree). */
double pose_distance(const mc_xform &a, const mc_xform &b)
{
	return mc_v3_norm(mc_v3_sub(a.t, b.t)) + turn_between(a, b);
}

/* Camera c's pose in the rig as a view set shows it, through camera k's
 * view of the same board: rig_from_k * k_from_board * board_from_c. */
mc_xform placed_by(const mc_xform &rig_from_k, const calib_view &vk, const calib_view &vc)
{
	return mc_xform_compose(rig_from_k, mc_xform_compose(vk.cam_from_board, mc_xform_inverse(vc.cam_from_board)));
}

/* The candidate closest to all the others (the medoid): a view set whose
 * images were not taken at one instant gives a candidate far from the
 * rest, which does not pull the choice as an average would. */
mc_xform medoid(const std::vector<mc_xform> &candidates)
{
	size_t best = 0;
	double best_sum = INFINITY;
	for (size_t i = 0; i < candidates.size(); i++) {
		std::vector<double> d;
		for (const mc_xform &o : candidates)
			d.push_back(pose_distance(candidates[i], o));
		std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
		if (d[d.size() / 2] < best_sum)
			best_sum = d[d.size() / 2], best = i;
	}
	return candidates[best];
}

/* A view set whose images were not taken at one instant places camera c
 * away from where the other sets put it: its view of c is not used.  The
 * threshold (3 cm plus radians) is far above what a synchronised set
 * disagrees by (about a millimetre and a tenth of a degree). */
void reject_unsynchronised(std::vector<calib_cam> &cams, size_t c, const std::vector<bool> &placed,
			   const std::vector<mc_xform> &rig_from_cam)
{
	for (calib_view &vc : cams[c].views)
		for (size_t k = 0; k < cams.size() && vc.used; k++) {
			calib_view *vk = k != c && placed[k] ? find_view(cams[k], vc.name) : nullptr;
			if (!vk)
				continue;
			mc_xform here = placed_by(rig_from_cam[k], *vk, vc);
			double off = pose_distance(here, rig_from_cam[c]);
			if (off > 0.03) {
				char why[200];
				std::snprintf(why, sizeof why,
					      "with camera %s's view of this set it puts the camera %.0f mm / %.1f deg away from "
					      "the other sets: the images were not taken at one instant (board moving?)",
					      cams[k].name.c_str(), 1000 * mc_v3_norm(mc_v3_sub(here.t, rig_from_cam[c].t)),
					      turn_between(here, rig_from_cam[c]) * 180 / M_PI);
				vc.used = false;
				vc.why = why;
			}
		}
}

/* Places every camera relative to camera 0 through the view sets that a
 * placed camera shares with it (breadth first), from the medoid of the
 * poses the shared sets give. */
int place_cameras(std::vector<calib_cam> &cams, std::vector<mc_xform> &rig_from_cam, mc_err *err)
{
	std::vector<bool> placed(cams.size(), false);
	placed[0] = true;
	rig_from_cam.assign(cams.size(), mc_xform_identity());
	for (bool progress = true; progress;) {
		progress = false;
		for (size_t c = 1; c < cams.size(); c++) {
			std::vector<mc_xform> candidates;
			for (size_t k = 0; k < cams.size() && !placed[c]; k++) {
				if (!placed[k] || k == c)
					continue;
				for (calib_view &vc : cams[c].views) {
					calib_view *vk = vc.used ? find_view(cams[k], vc.name) : nullptr;
					if (vk)
						candidates.push_back(placed_by(rig_from_cam[k], *vk, vc));
				}
			}
			if (!placed[c] && !candidates.empty()) {
				rig_from_cam[c] = medoid(candidates);
				placed[c] = progress = true;
				reject_unsynchronised(cams, c, placed, rig_from_cam);
			}
		}
	}
	for (size_t c = 1; c < cams.size(); c++)
		if (!placed[c])
			return mc_err_set(err,
					  "camera %s shares no view with the other cameras: show the board to it and to "
					  "another camera at the same time (the two images must have the same file name)",
					  cams[c].name.c_str());
	return 0;
}

/* The world frame of a board lying face up on the floor: x along the
 * board's columns, y against its rows, z up out of the board. */
mc_xform floor_from_board()
{
	mc_xform x = mc_xform_identity();
	x.R.m[1][1] = -1, x.R.m[2][2] = -1;
	return x;
}

int apply_floor(std::vector<calib_cam> &cams, const std::map<std::string, int> &sets,
		const std::vector<mc_xform> &rig_from_board, const std::string &floor, mc_err *err)
{
	auto it = sets.find(floor);
	if (it == sets.end())
		return mc_err_set(err, "--floor %s: no camera found the board in an image of that name", floor.c_str());
	mc_xform world_from_rig =
		mc_xform_compose(floor_from_board(), mc_xform_inverse(rig_from_board[it->second]));
	for (calib_cam &c : cams)
		c.cam.rig_from_cam = mc_xform_compose(world_from_rig, c.cam.rig_from_cam);
	return 0;
}

/* The joint problem over every used view: the cameras placed from the
 * shared sets, each set's board pose from the first camera that sees it. */
problem joint_problem(std::vector<calib_cam> &cams, std::map<std::string, int> &sets,
		      const std::vector<mc_xform> &rig_from_cam)
{
	problem pb;
	pb.rig_from_cam = rig_from_cam;
	pb.rig_from_board.assign(sets.size(), mc_xform_identity());
	std::vector<bool> seen(sets.size(), false);
	for (size_t c = 0; c < cams.size(); c++) {
		pb.cams.push_back(&cams[c]);
		for (calib_view &v : cams[c].views) {
			if (!v.used)
				continue;
			int s = sets[v.name];
			pb.obs.push_back(observation{(int)c, s, &v, 0});
			if (!seen[s])
				pb.rig_from_board[s] = mc_xform_compose(rig_from_cam[c], v.cam_from_board);
			seen[s] = true;
		}
	}
	return pb;
}

} // namespace

int calib_extrinsics(std::vector<calib_cam> &cams, const calib_options *opt, mc_err *err)
{
	std::map<std::string, int> sets;
	std::vector<mc_xform> rig_from_cam, rig_from_board;
	if (place_cameras(cams, rig_from_cam, err) < 0)
		return -1;
	/* Views that disagree with the others once the cameras are tied
	 * together (a set whose images were not taken at one instant) are
	 * rejected like any other, and the adjustment runs again.  The sets
	 * are numbered from the views still used, so that a set none of
	 * whose views is left has no pose in the problem (nor a floor). */
	for (int round = 0; round < 4; round++) {
		sets = view_sets(cams);
		problem pb = joint_problem(cams, sets, rig_from_cam);
		if (cams.size() > 1)
			adjust(pb);
		rig_from_cam = pb.rig_from_cam;
		rig_from_board = pb.rig_from_board;
		int rejected = 0;
		for (calib_cam &c : cams)
			rejected += cams.size() > 1 ? reject_outliers(&c, opt) : 0;
		if (rejected == 0)
			break;
	}
	for (calib_cam &c : cams) {
		c.cam.rig_from_cam = rig_from_cam[&c - &cams[0]];
		c.used_views = count_used(&c);
	}
	if (!opt->floor_view.empty() && apply_floor(cams, sets, rig_from_board, opt->floor_view, err) < 0)
		return -1;
	for (calib_cam &c : cams)
		if (set_field_of_view(&c, err) < 0)
			return -1;
	return 0;
}

bool calib_reproject(const calib_cam &c, const calib_view &v, std::vector<cv::Point2f> &px)
{
	px.clear();
	bool all = true;
	for (const cv::Point3f &o : v.corners.obj) {
		double u = -1, w = -1;
		bool ok = mc_camera_project_unbounded(&c.cam, mc_xform_apply(v.cam_from_board, mc_v3(o.x, o.y, o.z)), &u, &w);
		all = all && ok;
		px.push_back(cv::Point2f((float)u, (float)w));
	}
	return all;
}
