/* Tests of the One-Euro filter (core/base/mc_one_euro) and of the skeleton
 * filter over it (core/track/mc_skeleton_filter), at 30 fps with the
 * daemon's defaults (1 Hz, beta 8, 1 Hz): the first sample passes through,
 * jitter on a still point shrinks by a stated factor, a ramp is followed
 * with the stated lag, the velocity estimate is the ramp's speed, and the
 * skeleton filter starts again after a gap, a lost pose or a new skeleton.
 * The figures printed are those docs/CONFIG.md ("[output]") quotes. */
#include "base/mc_one_euro.h"
#include "track/mc_skeleton_filter.h"
#include "test_util.h"

#define RATE 30.0
#define DT (1.0 / RATE)

/* Standard normal numbers (Box-Muller) from the tests' generator. */
static double gauss(unsigned long long *rng)
{
	double u = mc_test_rand(rng), v = mc_test_rand(rng);
	return sqrt(-2.0 * log(u > 1e-300 ? u : 1e-300)) * cos(2.0 * M_PI * v);
}

static mc_one_euro_params defaults(void)
{
	mc_one_euro_params p;
	mc_one_euro_params_default(&p);
	return p;
}

static void test_first_sample(void)
{
	mc_one_euro_params p = defaults();
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	mc_vec3 x = mc_v3(0.3, -1.2, 2.5);
	CHECK(mc_one_euro3_step(&f, &p, x, DT) == 1.0);
	CHECK(f.value.x == x.x && f.value.y == x.y && f.value.z == x.z);
	CHECK(mc_v3_norm(f.velocity) == 0);
	/* the second sample is blended: between the two inputs */
	mc_one_euro3_step(&f, &p, mc_v3(0.4, -1.2, 2.5), DT);
	CHECK(f.value.x > 0.3 && f.value.x < 0.4);
}

/* A still point with 1 cm of Gaussian noise per axis: the output's spread
 * is at most 1/2.3 of the input's (2.46x measured). */
static void test_jitter(void)
{
	mc_one_euro_params p = defaults();
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	unsigned long long rng = 7;
	const double sigma = 0.01;
	double in2 = 0, out2 = 0;
	int n = 0;
	for (int i = 0; i < 900; i++) {
		mc_vec3 x = mc_v3(sigma * gauss(&rng), sigma * gauss(&rng), sigma * gauss(&rng));
		mc_one_euro3_step(&f, &p, x, DT);
		if (i >= 60) { /* past the start */
			in2 += mc_v3_norm2(x);
			out2 += mc_v3_norm2(f.value);
			n++;
		}
	}
	double ratio = sqrt(in2 / n) / sqrt(out2 / n);
	printf("jitter: still point, 1 cm noise at 30 fps: spread %.2f mm in, %.2f mm out (%.1fx less)\n",
	       1e3 * sqrt(in2 / n / 3), 1e3 * sqrt(out2 / n / 3), ratio);
	CHECK_MSG(ratio >= 2.3, "jitter reduced only %.2fx", ratio);
}

/* A ramp at `speed` m/s from rest: returns the steady lag in ms (after
 * 3 s) and the largest lag over the first second (*onset_ms). */
static double ramp_lag_ms(const mc_one_euro_params *p, double speed, double *onset_ms)
{
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	*onset_ms = 0;
	double lag = 0;
	for (int i = 0; i <= 3 * (int)RATE; i++) {
		double x = speed * i * DT;
		mc_one_euro3_step(&f, p, mc_v3(x, 0, 0), DT);
		lag = (x - f.value.x) / speed * 1e3;
		if (i <= (int)RATE)
			*onset_ms = fmax(*onset_ms, lag);
	}
	CHECK_NEAR(f.velocity.x, speed, 0.01 * speed); /* the velocity estimate is the ramp's speed */
	return lag;
}

static void test_ramp_lag(void)
{
	mc_one_euro_params p = defaults();
	const double speeds[] = {0.1, 0.5, 1.0, 2.0};
	for (int i = 0; i < 4; i++) {
		double onset, lag = ramp_lag_ms(&p, speeds[i], &onset);
		double expect = 1e3 * mc_one_euro_lag_s(&p, speeds[i]);
		printf("lag: ramp at %.1f m/s, 30 fps: %.1f ms steady (tau %.1f ms), "
		       "at most %.1f ms in the first second\n",
		       speeds[i], lag, expect, onset);
		CHECK_NEAR(lag, expect, 0.02 * expect + 0.5);
		CHECK(onset >= lag - 0.5);
	}
	/* bounded: at 1 m/s within 20 ms, and within 40 ms from the start */
	double onset, lag = ramp_lag_ms(&p, 1.0, &onset);
	CHECK_MSG(lag <= 20 && onset <= 40, "lag %.1f ms, onset %.1f ms", lag, onset);
	/* the lag does not depend on the frame rate (60 fps, 1 m/s) */
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	for (int i = 0; i <= 180; i++)
		mc_one_euro3_step(&f, &p, mc_v3(i / 60.0, 0, 0), 1 / 60.0);
	CHECK_NEAR((3.0 - f.value.x) * 1e3, 1e3 * mc_one_euro_lag_s(&p, 1.0), 1.0);
}

/* Prediction from two consecutive outputs (what mocap_predict does with
 * two filtered poses of the pose block) on a noisy ramp: the velocity of
 * the outputs' difference is unbiased and far less noisy than the raw
 * difference's. */
static void test_velocity(void)
{
	mc_one_euro_params p = defaults();
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	unsigned long long rng = 11;
	const double speed = 0.5, sigma = 0.005;
	double raw_prev = 0, out_prev = 0, raw_err2 = 0, out_err2 = 0, out_sum = 0, dxhat_err2 = 0;
	int n = 0;
	for (int i = 0; i < 600; i++) {
		double x = speed * i * DT + sigma * gauss(&rng);
		mc_one_euro3_step(&f, &p, mc_v3(x, 0, 0), DT);
		if (i >= 90) {
			double v_raw = (x - raw_prev) / DT, v_out = (f.value.x - out_prev) / DT;
			raw_err2 += (v_raw - speed) * (v_raw - speed);
			out_err2 += (v_out - speed) * (v_out - speed);
			dxhat_err2 += (f.velocity.x - speed) * (f.velocity.x - speed);
			out_sum += v_out;
			n++;
		}
		raw_prev = x, out_prev = f.value.x;
	}
	double raw_rms = sqrt(raw_err2 / n), out_rms = sqrt(out_err2 / n), dxhat_rms = sqrt(dxhat_err2 / n);
	printf("velocity: ramp 0.5 m/s + 5 mm noise: error rms %.3f m/s from raw pairs, %.3f from filtered pairs, "
	       "%.3f from dx_hat\n", raw_rms, out_rms, dxhat_rms);
	CHECK_NEAR(out_sum / n, speed, 0.02);
	CHECK_MSG(out_rms * 1.8 <= raw_rms, "filtered pairs %.3f against raw %.3f m/s", out_rms, raw_rms);
}

/* A joint swinging 0.2 m at 1 Hz (up to 1.26 m/s, a hand waving) with
 * 5 mm of noise, filtered with p at 30 fps.  Returns the filtered
 * position's rms error against the truth (mm); *accel_ratio: its mean
 * frame-to-frame acceleration over the truth's; *pred: what the pose
 * block's prediction (the newest pose extrapolated from the two newest,
 * mocap_predict) 50 ms ahead gives from these poses, as [0] rms error
 * (mm) and [1] acceleration over the truth's, and [2] the rms error with
 * the horizon lengthened by the lag at the joint's speed (what
 * docs/PROTOCOL.md suggests to clients), and [3] the rms error when the
 * filter's own velocity (dx_hat) drives it instead of the two poses (what
 * the block would offer if it carried the filter's velocity); raw: no
 * filter. */
static double swing(const mc_one_euro_params *p, bool raw, double *accel_ratio, double pred[4])
{
	mc_one_euro3 f;
	mc_one_euro3_reset(&f);
	unsigned long long rng = 3;
	const double ahead = 0.05, amp = 0.2, w = 2 * M_PI;
	double out[3] = {0}, pr[3] = {0}, truth[3] = {0}, err = 0, acc = 0, acc_truth = 0, e_pred = 0, acc_pred = 0,
	       e_comp = 0, e_dxhat = 0;
	int n = 0;
	for (int i = 0; i < 900; i++) {
		double t = i * DT, x = amp * sin(w * t) + 0.005 * gauss(&rng);
		mc_one_euro3_step(&f, p, mc_v3(x, 0, 0), DT);
		double y = raw ? x : f.value.x, v = (y - out[2]) / DT;
		double ahead_truth = amp * sin(w * (t + ahead)), lag = raw ? 0 : mc_one_euro_lag_s(p, fabs(v));
		out[0] = out[1], out[1] = out[2], out[2] = y;
		pr[0] = pr[1], pr[1] = pr[2], pr[2] = y + v * ahead;
		truth[0] = truth[1], truth[1] = truth[2], truth[2] = amp * sin(w * t);
		if (i >= 60) {
			err += pow(y - truth[2], 2);
			acc += fabs(out[2] - 2 * out[1] + out[0]);
			acc_pred += fabs(pr[2] - 2 * pr[1] + pr[0]);
			acc_truth += fabs(truth[2] - 2 * truth[1] + truth[0]);
			e_pred += pow(pr[2] - ahead_truth, 2);
			e_comp += pow(y + v * (ahead + lag) - ahead_truth, 2);
			e_dxhat += pow(y + f.velocity.x * ahead - ahead_truth, 2);
			n++;
		}
	}
	*accel_ratio = acc / acc_truth;
	pred[0] = sqrt(e_pred / n) * 1e3, pred[1] = acc_pred / acc_truth, pred[2] = sqrt(e_comp / n) * 1e3;
	pred[3] = sqrt(e_dxhat / n) * 1e3;
	return sqrt(err / n) * 1e3;
}

/* The prediction from filtered poses against raw ones: far smoother,
 * further from the truth (the filter's lag), less so with the lag added
 * to the horizon.  And better from the two poses than from the filter's
 * own velocity, which lags the swing's changes of direction: why the block
 * carries no velocity. */
static void test_prediction(void)
{
	mc_one_euro_params p = defaults();
	double acc_raw, acc_out, pred_raw[4], pred_out[4];
	double err_raw = swing(&p, true, &acc_raw, pred_raw), err_out = swing(&p, false, &acc_out, pred_out);
	printf("swing 0.2 m at 1 Hz + 5 mm noise: pose error %.1f mm raw, %.1f filtered; "
	       "acceleration %.2fx the truth's "
	       "raw, %.2fx filtered\n", err_raw, err_out, acc_raw, acc_out);
	printf("prediction 50 ms ahead: error %.1f mm from raw poses, %.1f from filtered, %.1f from filtered with the "
	       "lag added to the horizon, %.1f from the filter's own velocity; "
	       "acceleration %.2fx the truth's from raw, "
	       "%.2fx from filtered\n",
	       pred_raw[0], pred_out[0], pred_out[2], pred_out[3], pred_raw[1], pred_out[1]);
	CHECK_MSG(pred_out[0] < pred_out[3], "from two poses %.1f mm, from dx_hat %.1f mm", pred_out[0], pred_out[3]);
	CHECK_MSG(pred_out[1] * 1.8 <= pred_raw[1], "prediction acceleration %.2f filtered, %.2f raw", pred_out[1],
		  pred_raw[1]);
	CHECK_MSG(pred_out[2] < pred_out[0], "lag added: %.1f mm, without: %.1f mm", pred_out[2], pred_out[0]);
}

/* The trade-off around the defaults, printed for docs/CONFIG.md: a higher
 * beta or min cutoff follows the swing more closely and smooths a still
 * point less. */
static void test_tuning(void)
{
	const mc_one_euro_params sets[] = {{1, 0, 1},  {1, 2, 1},   {1, 4, 1}, {1, 8, 1},
					   {1, 16, 1}, {0.5, 8, 1}, {2, 8, 1}};
	double last_err = 1e9;
	for (int i = 0; i < 7; i++) {
		double acc, pred[4], err = swing(&sets[i], false, &acc, pred);
		mc_one_euro3 f;
		mc_one_euro3_reset(&f);
		unsigned long long rng = 9;
		double in2 = 0, out2 = 0;
		for (int k = 0; k < 900; k++) {
			double x = 0.005 * gauss(&rng);
			mc_one_euro3_step(&f, &sets[i], mc_v3(x, 0, 0), DT);
			in2 += k >= 60 ? x * x : 0;
			out2 += k >= 60 ? f.value.x * f.value.x : 0;
		}
		printf("tuning: min cutoff %.1f Hz, beta %2.0f: lag %3.0f ms at 1 m/s; swing error %5.1f mm, "
		       "acceleration "
		       "%.2fx the truth's; still point jitter %.1fx less\n",
		       sets[i].min_cutoff_hz, sets[i].beta, 1e3 * mc_one_euro_lag_s(&sets[i], 1.0), err, acc,
		       sqrt(in2 / out2));
		if (i < 5) /* beta rising: closer to the swing */
			CHECK(err < last_err);
		last_err = err;
	}
}

static void still_skeleton(mc_skeleton *sk, uint64_t t_ns)
{
	memset(sk, 0, sizeof(*sk));
	sk->timestamp_ns = t_ns;
	sk->state = MC_TRACK_OK;
	sk->njoints = 3;
	for (int j = 0; j < 3; j++) {
		sk->joints[j].parent = j - 1;
		sk->joints[j].position = mc_v3(0, 0, 0.3 * j);
		sk->joints[j].orientation = mc_quat_identity();
	}
}

/* Moves every joint by dx along x: the skeleton a filter gets next. */
static mc_skeleton moved(const mc_skeleton *sk, double dx, uint64_t t_ns)
{
	mc_skeleton n = *sk;
	n.timestamp_ns = t_ns;
	for (int j = 0; j < n.njoints; j++)
		n.joints[j].position.x += dx;
	return n;
}

static void test_skeleton_restarts(void)
{
	mc_one_euro_params p = defaults();
	mc_skeleton_filter *f = malloc(sizeof(*f));
	mc_skeleton *sk = malloc(sizeof(*sk)), *s2 = malloc(sizeof(*s2));
	CHECK(f && sk && s2);
	if (!f || !sk || !s2)
		goto out;
	mc_skeleton_filter_init(f, &p, 0.2);
	uint64_t t = 1000000000ull, frame = (uint64_t)(DT * 1e9);
	still_skeleton(sk, t);
	CHECK(!mc_skeleton_filter_apply(f, sk)); /* the first passes through */
	*s2 = moved(sk, 0.1, t + frame);
	CHECK(mc_skeleton_filter_apply(f, s2)); /* the next is blended */
	CHECK(s2->joints[1].position.x > 0 && s2->joints[1].position.x < 0.1);
	/* after a 300 ms gap (more than 200) it passes through */
	*s2 = moved(sk, 0.2, t + 10 * frame);
	CHECK(!mc_skeleton_filter_apply(f, s2));
	CHECK(s2->joints[1].position.x == 0.2);
	/* a lost pose passes through, and the next starts again */
	*s2 = moved(sk, 0.3, t + 11 * frame);
	s2->state = MC_TRACK_LOST;
	CHECK(!mc_skeleton_filter_apply(f, s2) && s2->joints[1].position.x == 0.3);
	*s2 = moved(sk, 0.4, t + 12 * frame);
	CHECK(!mc_skeleton_filter_apply(f, s2) && s2->joints[1].position.x == 0.4);
	/* an uncertain pose is still smoothed */
	*s2 = moved(sk, 0.5, t + 13 * frame);
	s2->state = MC_TRACK_UNCERTAIN;
	CHECK(mc_skeleton_filter_apply(f, s2) && s2->joints[1].position.x < 0.5);
	/* another skeleton (joint count), and time going back, start again */
	*s2 = moved(sk, 0.6, t + 14 * frame);
	s2->njoints = 2;
	CHECK(!mc_skeleton_filter_apply(f, s2));
	*s2 = moved(sk, 0.7, t + 13 * frame);
	s2->njoints = 2;
	CHECK(!mc_skeleton_filter_apply(f, s2));
out:
	free(f);
	free(sk);
	free(s2);
}

/* A chain whose root turns at 2 rad/s about z, with noise on the
 * orientations: the orientations stay unit quaternions, their jitter
 * shrinks, and the root's rotation follows its moving child rather than
 * its still position (the lag of a child, not of min_cutoff). */
static void test_skeleton_rotation(void)
{
	mc_one_euro_params p = defaults();
	mc_skeleton_filter *f = malloc(sizeof(*f));
	mc_skeleton *sk = malloc(sizeof(*sk));
	CHECK(f && sk);
	if (!f || !sk)
		goto out;
	mc_skeleton_filter_init(f, &p, 0.2);
	unsigned long long rng = 5;
	double in_err = 0, out_err = 0, lag_angle = 0;
	for (int i = 0; i < 300; i++) {
		double angle = 2.0 * i * DT;
		still_skeleton(sk, 1000000000ull + (uint64_t)(i * DT * 1e9));
		mc_quat truth = mc_quat_from_rotvec(mc_v3(0, 0, angle));
		mc_vec3 noise = mc_v3(0.02 * gauss(&rng), 0.02 * gauss(&rng), 0.02 * gauss(&rng));
		sk->joints[0].orientation = mc_quat_mul(mc_quat_from_rotvec(noise), truth);
		sk->joints[1].position = mc_quat_rotate(truth, mc_v3(0.5, 0, 0)); /* the child moves at 1 m/s */
		mc_skeleton_filter_apply(f, sk);
		mc_quat q = sk->joints[0].orientation;
		CHECK_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-9);
		if (i >= 60) {
			mc_quat d = mc_quat_mul(q, (mc_quat){truth.w, -truth.x, -truth.y, -truth.z});
			mc_vec3 err = mc_quat_to_rotvec(d);
			lag_angle += -err.z; /* behind the truth about z */
			out_err += err.x * err.x + err.y * err.y;
			in_err += noise.x * noise.x + noise.y * noise.y;
		}
	}
	double lag_ms = lag_angle / 240 / 2.0 * 1e3, ratio = sqrt(in_err / out_err);
	printf("rotation: root turning at 2 rad/s, child at 1 m/s: lag %.1f ms (child tau %.1f ms), "
	       "off-axis jitter %.1fx less\n", lag_ms, 1e3 * mc_one_euro_lag_s(&p, 1.0), ratio);
	CHECK_MSG(lag_ms < 1e3 * mc_one_euro_lag_s(&p, 1.0) + 10, "rotation lag %.1f ms", lag_ms);
	CHECK_MSG(ratio >= 1.3, "rotation jitter reduced only %.2fx", ratio);
out:
	free(f);
	free(sk);
}

/* An arm swinging about a still shoulder at 3.3 rad/s (elbow 0.3 m out at
 * 1 m/s, wrist 0.6 m out at 2 m/s): each joint is low-passed on its own,
 * so a filtered joint on a circle cuts inside it (the upper arm shortens
 * by 1.8 mm, more than tau alone gives, because the speed estimate of a
 * turning velocity reads 0.86 of the speed) and neighbours lag by
 * different times (the forearm lengthens by 0.5 mm): under 2.5 mm. */
static void test_bone_lengths(void)
{
	mc_one_euro_params p = defaults();
	mc_skeleton_filter *f = malloc(sizeof(*f));
	mc_skeleton *sk = malloc(sizeof(*sk));
	CHECK(f && sk);
	if (!f || !sk)
		goto out;
	mc_skeleton_filter_init(f, &p, 0.2);
	double worst = 0;
	for (int i = 0; i < 150; i++) {
		still_skeleton(sk, 1000000000ull + (uint64_t)(i * DT * 1e9));
		mc_quat turn = mc_quat_from_rotvec(mc_v3(0, 0, 10.0 / 3.0 * i * DT));
		sk->joints[1].position = mc_quat_rotate(turn, mc_v3(0.3, 0, 0));
		sk->joints[2].position = mc_quat_rotate(turn, mc_v3(0.6, 0, 0));
		mc_skeleton_filter_apply(f, sk);
		if (i < 30)
			continue; /* past the start of the motion */
		for (int j = 1; j < 3; j++) {
			double bone = mc_v3_norm(mc_v3_sub(sk->joints[j].position, sk->joints[j - 1].position));
			worst = fmax(worst, fabs(bone - 0.3));
		}
	}
	printf("bones: arm swinging at 1 and 2 m/s: bone lengths change by at most %.2f mm\n", worst * 1e3);
	CHECK_MSG(worst < 0.0025, "a bone changed by %.2f mm", worst * 1e3);
out:
	free(f);
	free(sk);
}

int main(void)
{
	test_first_sample();
	test_jitter();
	test_ramp_lag();
	test_velocity();
	test_prediction();
	test_tuning();
	test_skeleton_restarts();
	test_skeleton_rotation();
	test_bone_lengths();
	return mc_test_finish("test_one_euro");
}
