/* vmc_map and vmc_config without a network: the bones of mocapd's body
 * models (rooted at the head, fixed or free) and of a pelvis-rooted
 * skeleton, put through Unity forward kinematics written here (quaternions,
 * not the library's matrices), land on the joints; the T-pose and the up
 * axes mean what docs/VMC.md says; low-confidence bones hold or ease; bad
 * bone and config files are refused with file, line and key. */
#include "body/mc_model.h"
#include "test_util.h"
#include "vmc_config.h"
#include "vmc_map.h"

#include <stdio.h>
#include <string.h>

static void def_from_model(const mc_model *model, mocap_skeleton_def *sk)
{
	memset(sk, 0, sizeof(*sk));
	sk->id = 7;
	sk->njoints = model->njoints;
	sk->rig_is_world = model->root_free;
	for (int j = 0; j < model->njoints; j++) {
		snprintf(sk->joints[j].name, sizeof(sk->joints[j].name), "%s", model->joints[j].name);
		sk->joints[j].parent = model->joints[j].parent;
		sk->joints[j].rest_offset[0] = model->joints[j].offset.x;
		sk->joints[j].rest_offset[1] = model->joints[j].offset.y;
		sk->joints[j].rest_offset[2] = model->joints[j].offset.z;
	}
}

static void frame_from_fk(const mc_model *model, const double *pose, mocap_skeleton_frame *f)
{
	mc_fk fk;
	mc_model_fk(model, pose, &fk);
	memset(f, 0, sizeof(*f));
	f->skeleton_id = 7;
	f->njoints = model->njoints;
	f->space = MOCAP_SPACE_RIG;
	for (int j = 0; j < model->njoints; j++) {
		mc_quat q = mc_quat_from_m3(fk.rig_from_joint[j].R);
		f->joints[j].position[0] = fk.rig_from_joint[j].t.x;
		f->joints[j].position[1] = fk.rig_from_joint[j].t.y;
		f->joints[j].position[2] = fk.rig_from_joint[j].t.z;
		f->joints[j].orientation[0] = q.w;
		f->joints[j].orientation[1] = q.x;
		f->joints[j].orientation[2] = q.y;
		f->joints[j].orientation[3] = q.z;
		f->joints[j].confidence = 1;
	}
}

static void random_pose(const mc_model *model, uint64_t *rng, double *pose)
{
	double lo[MC_MAX_DOF], hi[MC_MAX_DOF];
	mc_model_dof_limits(model, lo, hi);
	for (int k = 0; k < model->ndof; k++) {
		if (isfinite(lo[k]))
			pose[k] = lo[k] + (hi[k] - lo[k]) * mc_rng_uniform(rng);
		else
			pose[k] = k < 3 ? 2 * mc_rng_uniform(rng) - 1 : 2.5 * mc_rng_uniform(rng) - 1.25;
	}
}

/* Unity forward kinematics from the Hips with quaternions; returns the
 * largest miss against the frame's joints seen through unity_from_space. */
static double fk_miss(const vmc_map *m, const vmc_bone_pose *p, const mocap_skeleton_frame *f, mc_mat3 g,
		      double floor_height)
{
	mc_quat world[VMC_NBONES];
	mc_vec3 pos[VMC_NBONES];
	double worst = 0;
	for (int i = 0; i < m->nbones; i++) {
		int par = m->bone[i].parent;
		world[i] = par < 0 ? p[i].rot : mc_quat_mul(world[par], p[i].rot);
		pos[i] = par < 0 ? p[i].pos : mc_v3_add(pos[par], mc_quat_rotate(world[par], p[i].pos));
		const double *q = f->joints[m->bone[i].pos_joint].position;
		mc_vec3 want = mc_m3_apply(g, mc_v3(q[0], q[1], q[2]));
		want.y -= floor_height;
		double e = mc_v3_norm(mc_v3_sub(pos[i], want));
		worst = e > worst ? e : worst;
	}
	return worst;
}

static const vmc_bone *bone(const vmc_map *m, int id)
{
	for (int i = 0; i < m->nbones; i++)
		if (m->bone[i].id == id)
			return &m->bone[i];
	return NULL;
}

static int joint(const mocap_skeleton_def *sk, const char *name)
{
	for (int j = 0; j < sk->njoints; j++)
		if (strcmp(sk->joints[j].name, name) == 0)
			return j;
	return -1;
}

/* The model's skeleton definition and its map with the default table, T-pose. */
static void build_map(const mc_model *model, mocap_skeleton_def *sk, vmc_map *m)
{
	vmc_bone_table t;
	mc_err err = {""};
	def_from_model(model, sk);
	vmc_bone_table_default(&t);
	CHECK_MSG(vmc_map_build(m, sk, &t, VMC_REST_TPOSE, &err) == 0, "%s", err.msg);
}

/* Random poses of a model: FK of the bones lands on the joints. */
static void check_model_poses(mc_model *model, const char *what)
{
	mocap_skeleton_def sk;
	def_from_model(model, &sk);
	vmc_bone_table t;
	vmc_bone_table_default(&t);
	uint64_t rng = 42;
	static mocap_skeleton_frame f;
	double pose[MC_MAX_DOF];
	for (int rest = 0; rest < 2; rest++) {
		vmc_map m;
		mc_err err = {""};
		CHECK_MSG(vmc_map_build(&m, &sk, &t, (vmc_rest)rest, &err) == 0, "%s: %s", what, err.msg);
		CHECK_MSG(m.nbones == 18, "%s: %d bones", what, m.nbones);
		double worst = 0;
		for (int n = 0; n < 200; n++) {
			random_pose(model, &rng, pose);
			frame_from_fk(model, pose, &f);
			for (int up = VMC_UP_Y; up <= VMC_UP_HEAD; up++) {
				vmc_bone_pose p[VMC_NBONES];
				vmc_map_pose(&m, &f, (vmc_up)up, -1.5, p);
				double e = fk_miss(&m, p, &f, vmc_unity_from_space(&m, &f, (vmc_up)up), -1.5);
				worst = e > worst ? e : worst;
				double lib = vmc_map_residual(&m, &f, (vmc_up)up, -1.5, p);
				CHECK_NEAR(lib, e, 1e-9);
				for (int i = 0; i < m.nbones; i++)
					CHECK_NEAR(p[i].rot.w * p[i].rot.w + p[i].rot.x * p[i].rot.x + p[i].rot.y * p[i].rot.y +
							   p[i].rot.z * p[i].rot.z, 1, 1e-9);
			}
		}
		printf("%s, rest %s: largest forward-kinematics miss %.3g m over 200 poses x 3 up axes\n", what,
		       rest ? "model" : "tpose", worst);
		CHECK_MSG(worst < 1e-6, "%s: miss %g m", what, worst);
	}
}

/* mocapd's default model: rooted at the head, arms hanging at rest. */
static void check_default_model(const char *path)
{
	mc_model model;
	mc_err err = {""};
	if (mc_model_load(path, &model, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	mocap_skeleton_def sk;
	vmc_map m;
	build_map(&model, &sk, &m);
	/* The spine bones turn with the joint above: the tree runs down from the head. */
	CHECK(bone(&m, VMC_HIPS)->rot_joint == joint(&sk, "pelvis"));
	CHECK(bone(&m, VMC_SPINE)->rot_joint == joint(&sk, "neck"));
	CHECK(bone(&m, VMC_NECK)->rot_joint == joint(&sk, "head"));
	CHECK(bone(&m, VMC_HEAD)->rot_joint == joint(&sk, "head"));
	CHECK(bone(&m, VMC_LEFT_UPPER_ARM)->rot_joint == joint(&sk, "left_shoulder"));
	CHECK(bone(&m, VMC_LEFT_UPPER_ARM)->parent == 1); /* no Chest or shoulders: under the Spine */
	/* T-pose: the forearm points to the body's left (Unity -x), 0.30 m. */
	mc_vec3 lo = bone(&m, VMC_LEFT_LOWER_ARM)->local_pos, ro = bone(&m, VMC_RIGHT_LOWER_ARM)->local_pos;
	CHECK_NEAR(lo.x, -0.30, 1e-9);
	CHECK_NEAR(lo.y, 0, 1e-9);
	CHECK_NEAR(ro.x, 0.30, 1e-9);
	/* The shin straight down, the neck up from the spine. */
	CHECK_NEAR(bone(&m, VMC_LEFT_LOWER_LEG)->local_pos.y, -0.50, 1e-9);
	CHECK_NEAR(bone(&m, VMC_NECK)->local_pos.y, 0.28, 1e-9);
	/* The rest pose's upper-arm rotation brings the T-pose arm down. */
	mc_vec3 down = mc_quat_rotate(bone(&m, VMC_LEFT_UPPER_ARM)->rest_local, lo);
	CHECK_NEAR(down.x, 0, 1e-9);
	CHECK_NEAR(down.y, -0.30, 1e-9);

	/* Upright in a z-up world facing +y: the Hips' Unity rotation is the
	 * identity, the head is above them and the feet on the floor. */
	mc_model freed = model;
	CHECK(mc_model_make_root_free(&freed, &err) == 0);
	double pose[MC_MAX_DOF];
	mc_model_rest_pose(&freed, pose);
	pose[2] = 1.0;
	pose[3] = -M_PI / 2; /* body y (down) onto world -z, body z (forward) onto world +y */
	static mocap_skeleton_frame f;
	frame_from_fk(&freed, pose, &f);
	vmc_bone_pose p[VMC_NBONES];
	vmc_map_pose(&m, &f, VMC_UP_Z, 0, p);
	CHECK_NEAR(fabs(p[0].rot.w), 1, 1e-9);
	mc_vec3 head = mc_m3_apply(vmc_unity_from_space(&m, &f, VMC_UP_Z), mc_v3(f.joints[0].position[0],
										   f.joints[0].position[1],
										   f.joints[0].position[2]));
	CHECK_MSG(head.y > p[0].pos.y + 0.3, "head %.2f hips %.2f", head.y, p[0].pos.y);
	/* The head held upright in the rig frame: the Head bone's world rotation is the identity. */
	vmc_map_pose(&m, &f, VMC_UP_HEAD, 0, p);
	mc_quat hw = mc_quat_identity();
	for (int i = 0, b = 0; i < m.nbones; i++)
		if (m.bone[i].id == VMC_HEAD)
			for (b = i; b >= 0; b = m.bone[b].parent)
				hw = mc_quat_mul(p[b].rot, hw);
	CHECK_NEAR(fabs(hw.w), 1, 1e-9);

	check_model_poses(&model, "default model (head root, fixed)");
	check_model_poses(&freed, "default model (head root, free)");
}

/* mocap-testpub's skeleton: rooted at the pelvis, y down, x to the left,
 * no head joint (17 bones), every joint with three dofs. */
static void check_pelvis_root(void)
{
#define L "\"min_deg\": -90, \"max_deg\": 90"
	static const char json[] =
		"{\"name\": \"pelvis-root\", \"root\": \"free\", \"joints\": ["
		"{\"name\": \"pelvis\"},"
		"{\"name\": \"spine\", \"parent\": \"pelvis\", \"offset\": [0, -0.25, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"y\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"neck\", \"parent\": \"spine\", \"offset\": [0, -0.30, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"head_top\", \"parent\": \"neck\", \"offset\": [0, -0.25, 0]},"
		"{\"name\": \"left_shoulder\", \"parent\": \"spine\", \"offset\": [0.18, -0.30, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"y\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"left_elbow\", \"parent\": \"left_shoulder\", \"offset\": [0.28, 0, 0], \"dofs\": [{\"axis\": \"z\", " L "}, {\"axis\": \"y\", " L "}]},"
		"{\"name\": \"left_wrist\", \"parent\": \"left_elbow\", \"offset\": [0.25, 0, 0], \"dofs\": [{\"axis\": \"x\", " L "}]},"
		"{\"name\": \"right_shoulder\", \"parent\": \"spine\", \"offset\": [-0.18, -0.30, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"y\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"right_elbow\", \"parent\": \"right_shoulder\", \"offset\": [-0.28, 0, 0], \"dofs\": [{\"axis\": \"z\", " L "}]},"
		"{\"name\": \"right_wrist\", \"parent\": \"right_elbow\", \"offset\": [-0.25, 0, 0]},"
		"{\"name\": \"left_hip\", \"parent\": \"pelvis\", \"offset\": [0.10, 0.05, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"y\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"left_knee\", \"parent\": \"left_hip\", \"offset\": [0, 0.42, 0], \"dofs\": [{\"axis\": \"x\", " L "}]},"
		"{\"name\": \"left_ankle\", \"parent\": \"left_knee\", \"offset\": [0, 0.42, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"left_toe\", \"parent\": \"left_ankle\", \"offset\": [0, 0.05, 0.12]},"
		"{\"name\": \"right_hip\", \"parent\": \"pelvis\", \"offset\": [-0.10, 0.05, 0], \"dofs\": [{\"axis\": \"x\", " L "}, {\"axis\": \"y\", " L "}, {\"axis\": \"z\", " L "}]},"
		"{\"name\": \"right_knee\", \"parent\": \"right_hip\", \"offset\": [0, 0.42, 0], \"dofs\": [{\"axis\": \"x\", " L "}]},"
		"{\"name\": \"right_ankle\", \"parent\": \"right_knee\", \"offset\": [0, 0.42, 0], \"dofs\": [{\"axis\": \"x\", " L "}]},"
		"{\"name\": \"right_toe\", \"parent\": \"right_ankle\", \"offset\": [0, 0.05, 0.12]}"
		"], \"gaussians\": [{\"joint\": \"pelvis\", \"offset\": [0, 0, 0], \"radius\": 0.1, \"color\": [1, 0, 0]}]}";
	mc_model model;
	mc_err err = {""};
	if (mc_model_parse(json, "pelvis-root", &model, &err) < 0) {
		CHECK_MSG(false, "%s", err.msg);
		return;
	}
	mocap_skeleton_def sk;
	vmc_map m;
	build_map(&model, &sk, &m);
	CHECK(m.nbones == 17 && !bone(&m, VMC_HEAD));
	CHECK(bone(&m, VMC_SPINE)->rot_joint == joint(&sk, "spine"));
	CHECK(bone(&m, VMC_NECK)->rot_joint == joint(&sk, "neck"));
	/* Arms already out: the T-pose changes nothing, left is Unity -x. */
	CHECK_NEAR(bone(&m, VMC_LEFT_LOWER_ARM)->local_pos.x, -0.28, 1e-9);
	CHECK_NEAR(bone(&m, VMC_LEFT_UPPER_ARM)->rest_local.w, 1, 1e-9);

	/* The neck and the shoulders hang from the spine joint: the Spine
	 * bone turns with it and carries all three rigidly. */
	uint64_t rng = 7;
	double pose[MC_MAX_DOF], worst = 0;
	static mocap_skeleton_frame f;
	for (int n = 0; n < 50; n++) {
		random_pose(&model, &rng, pose);
		frame_from_fk(&model, pose, &f);
		vmc_bone_pose p[VMC_NBONES];
		vmc_map_pose(&m, &f, VMC_UP_Y, 0, p);
		double e = fk_miss(&m, p, &f, vmc_unity_from_space(&m, &f, VMC_UP_Y), 0);
		worst = e > worst ? e : worst;
	}
	printf("pelvis root: largest forward-kinematics miss %.3g m over 50 poses\n", worst);
	CHECK(worst < 1e-6);
}

static void check_hold(const char *path)
{
	mc_model model;
	mc_err err = {""};
	if (mc_model_load(path, &model, &err) < 0)
		return;
	mocap_skeleton_def sk;
	vmc_map m;
	build_map(&model, &sk, &m);
	static mocap_skeleton_frame f;
	double pose[MC_MAX_DOF];
	uint64_t rng = 3;
	random_pose(&model, &rng, pose);
	frame_from_fk(&model, pose, &f);
	vmc_bone_pose good[VMC_NBONES], p[VMC_NBONES];
	vmc_map_pose(&m, &f, VMC_UP_HEAD, 0, good);
	for (int mode = 0; mode < 2; mode++) {
		vmc_hold h = {0};
		memcpy(p, good, sizeof(p));
		vmc_hold_apply(&h, &m, p, 0.3f, (vmc_low)mode, 0.5, 1000000000ull);
		CHECK(memcmp(p, good, sizeof(p)) == 0); /* confident: as is */
		/* The left elbow loses confidence: LeftUpperArm (its child's
		 * joint) and LeftLowerArm hold or ease; the others follow. */
		random_pose(&model, &rng, pose);
		frame_from_fk(&model, pose, &f);
		f.joints[joint(&sk, "left_elbow")].confidence = 0.1f;
		int ua = -1, la = -1, rua = -1;
		for (int i = 0; i < m.nbones; i++) {
			ua = m.bone[i].id == VMC_LEFT_UPPER_ARM ? i : ua;
			la = m.bone[i].id == VMC_LEFT_LOWER_ARM ? i : la;
			rua = m.bone[i].id == VMC_RIGHT_UPPER_ARM ? i : rua;
		}
		for (int step = 1; step <= 40; step++) {
			vmc_map_pose(&m, &f, VMC_UP_HEAD, 0, p);
			CHECK(p[ua].confidence < 0.2f && p[la].confidence < 0.2f && p[rua].confidence > 0.9f);
			vmc_hold_apply(&h, &m, p, 0.3f, (vmc_low)mode, 0.5, 1000000000ull + step * 100000000ull);
		}
		double d_hold = 1 - fabs(p[ua].rot.w * good[ua].rot.w + p[ua].rot.x * good[ua].rot.x +
					 p[ua].rot.y * good[ua].rot.y + p[ua].rot.z * good[ua].rot.z);
		const mc_quat r = m.bone[ua].rest_local;
		double d_rest = 1 - fabs(p[ua].rot.w * r.w + p[ua].rot.x * r.x + p[ua].rot.y * r.y + p[ua].rot.z * r.z);
		if (mode == VMC_LOW_HOLD)
			CHECK_MSG(d_hold < 1e-12, "held rotation moved (%g)", d_hold);
		else /* 4 s at a 0.5 s time constant: at rest within e^-8 */
			CHECK_MSG(d_rest < 1e-6, "not eased to rest (%g)", d_rest);
	}
}

static void write_file(const char *path, const char *text)
{
	FILE *fp = fopen(path, "w");
	if (fp) {
		fputs(text, fp);
		fclose(fp);
	}
}

typedef struct {
	const char *text, *want;
} bad_file;

static int load_bones(const char *path, mc_err *err)
{
	vmc_bone_table t;
	vmc_bone_table_default(&t);
	return vmc_bone_table_load(&t, path, err);
}

static int load_settings(const char *path, mc_err *err)
{
	vmc_settings s;
	vmc_settings_default(&s);
	return vmc_settings_load(&s, path, err);
}

/* Each text, written to path, is refused with a message holding `want`. */
static void check_refused(const char *path, const bad_file *cases, size_t n, int (*load)(const char *, mc_err *))
{
	for (size_t i = 0; i < n; i++) {
		mc_err err = {""};
		write_file(path, cases[i].text);
		CHECK_MSG(load(path, &err) < 0 && strstr(err.msg, cases[i].want), "got '%s'", err.msg);
	}
}

static void check_files(const char *dir)
{
	char path[256];
	snprintf(path, sizeof(path), "%s/bones.ini", dir);
	vmc_bone_table t;
	mc_err err = {""};
	/* Overrides: a rotation joint named, a bone dropped. */
	write_file(path, "# comment\n[bones]\nSpine = spine neck\nLeftToes =\n");
	vmc_bone_table_default(&t);
	CHECK_MSG(vmc_bone_table_load(&t, path, &err) == 0, "%s", err.msg);
	CHECK(strcmp(t.pos[VMC_SPINE], "spine") == 0 && strcmp(t.rot[VMC_SPINE], "neck") == 0);
	CHECK(t.pos[VMC_LEFT_TOES][0] == 0 && strcmp(t.pos[VMC_RIGHT_TOES], "right_toe") == 0);
	static const bad_file bad[] = {
		{"[bones]\nLeftArm = left_shoulder\n", "bones.ini: [bones] LeftArm: not a Unity humanoid bone"},
		{"[bone]\nHips = pelvis\n", "bones.ini: [bone] Hips: unknown section"},
		{"[bones]\nHips = pelvis spine extra\n", "bones.ini: [bones] Hips: expected `joint [rotation_joint]`"},
		{"[bones]\nHips pelvis\n", "bones.ini: line 2: not `Bone = joint"},
	};
	check_refused(path, bad, sizeof(bad) / sizeof(bad[0]), load_bones);
	/* A joint the skeleton lacks, named explicitly: refused at build. */
	mocap_skeleton_def sk = {.id = 1, .njoints = 1};
	snprintf(sk.joints[0].name, sizeof(sk.joints[0].name), "pelvis");
	sk.joints[0].parent = -1;
	vmc_bone_table_default(&t);
	vmc_map m;
	CHECK(vmc_map_build(&m, &sk, &t, VMC_REST_TPOSE, &err) < 0 && strstr(err.msg, "no Spine, Neck or Head"));
	snprintf(t.pos[VMC_HIPS], sizeof(t.pos[VMC_HIPS]), "hips");
	CHECK(vmc_map_build(&m, &sk, &t, VMC_REST_TPOSE, &err) < 0 &&
	      strstr(err.msg, "bones: Hips: the skeleton has no joint 'hips'"));

	/* The config file. */
	snprintf(path, sizeof(path), "%s/vmc.conf", dir);
	write_file(path, "[vmc]\nhost = 192.0.2.7\nport = 39540\nrate = 60\nspace = rig\nup = z\nfloor_height = 0.1\n"
			 "rest = model\nmin_confidence = 0.5\nlow_confidence = rest\nease_s = 1\n");
	vmc_settings s;
	vmc_settings_default(&s);
	CHECK_MSG(vmc_settings_load(&s, path, &err) == 0, "%s", err.msg);
	CHECK(strcmp(s.host, "192.0.2.7") == 0 && s.port == 39540 && s.rate == 60 && s.space == MOCAP_SPACE_RIG);
	CHECK(s.up == VMC_UP_Z && !s.floor_auto && s.floor_height == 0.1 && s.rest == VMC_REST_MODEL);
	CHECK(s.min_confidence == 0.5f && s.low == VMC_LOW_REST && s.ease_s == 1);
	static const bad_file badconf[] = {
		{"[vmc]\nport = 70000\n", "vmc.conf: line 2: [vmc]: port: '70000': expected a UDP port"},
		{"[vmc]\n\nspeed = 3\n", "vmc.conf: line 3: [vmc]: speed: unknown key"},
		{"[daemon]\nrate = 3\n", "vmc.conf: line 2: [daemon] rate: unknown section"},
		{"[vmc]\nup = x\n", "up: 'x': expected auto, y, z or head"},
	};
	check_refused(path, badconf, sizeof(badconf) / sizeof(badconf[0]), load_settings);
	/* target: host and port in one */
	vmc_settings_default(&s);
	CHECK(vmc_settings_set(&s, "target", "vr-pc.local:39540", &err) == 0 && strcmp(s.host, "vr-pc.local") == 0 &&
	      s.port == 39540);
	CHECK(vmc_settings_set(&s, "target", "[fe80::1]:9000", &err) == 0 && strcmp(s.host, "fe80::1") == 0 &&
	      s.port == 9000);
	static const char *const bad_targets[] = {"vr-pc", ":39539", "host:0", "host:port", "[::1]39539", "[]:1"};
	for (size_t i = 0; i < sizeof(bad_targets) / sizeof(bad_targets[0]); i++)
		CHECK_MSG(vmc_settings_set(&s, "target", bad_targets[i], &err) < 0 &&
				  strstr(err.msg, "expected HOST:PORT (or [IPV6]:PORT)"),
			  "target '%s' accepted", bad_targets[i]);
	CHECK(strcmp(s.host, "fe80::1") == 0 && s.port == 9000); /* unchanged by the refusals */
	/* auto: outside-in z up, a VR world y up, a head rig's own frame head up 1.6 m. */
	vmc_settings_default(&s);
	mocap_skeleton_frame *f = calloc(1, sizeof(*f));
	sk.rig_is_world = 1;
	CHECK(vmc_settings_up(&s, f, &sk) == VMC_UP_Z && vmc_settings_floor(&s, VMC_UP_Z) == 0);
	sk.rig_is_world = 0;
	f->space = MOCAP_SPACE_WORLD;
	CHECK(vmc_settings_up(&s, f, &sk) == VMC_UP_Y);
	f->space = MOCAP_SPACE_RIG;
	CHECK(vmc_settings_up(&s, f, &sk) == VMC_UP_HEAD && vmc_settings_floor(&s, VMC_UP_HEAD) == -1.6);
	free(f);
}

int main(void)
{
	const char *model = "config/models/default.json";
	if (access(model, R_OK) != 0)
		TEST_SKIP("run from the repository root (%s not found)", model);
	char dir[] = "/tmp/test-vmc-XXXXXX";
	if (!mkdtemp(dir))
		TEST_SKIP("cannot create a scratch directory");
	check_default_model(model);
	check_pelvis_root();
	check_hold(model);
	check_files(dir);
	char cmd[64];
	snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
	if (system(cmd) != 0)
		fprintf(stderr, "could not remove %s\n", dir);
	return mc_test_failures ? 1 : 0;
}
