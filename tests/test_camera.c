/* Tests of core/geom/mc_camera: the three camera models against independent
 * references, project/unproject as inverses over whole images, and
 * validation messages.
 *
 * References:
 * - pinhole and equidistant: tables computed by OpenCV itself
 *   (cv2.projectPoints, cv2.fisheye.projectPoints) with
 *   tests/data/ocam/make_fixtures.py, pasted below;
 * - the evaluation data's lens (../shared/data/ego/ * /calib.json: f 81.487,
 *   centre 127.5, 256x256, 180 degrees, and its ocam_poly): the published
 *   formulas r = f theta and ray = (u - cx, v - cy, w(rho)) evaluated in
 *   straight-line code here;
 * - ocam: OCamCalib's own cam2world/world2cam (ocam_functions.c) evaluated
 *   in the toolbox's conventions on tests/data/ocam/asym_calib_results.txt
 *   by the same script. */
#include "geom/mc_camera.h"
#include "geom/mc_rig.h"
#include "test_util.h"

#include <string.h>

#define DEG (M_PI / 180.0)

/* cv2.projectPoints (OpenCV 4.6.0): fx 512.3 fy 509.8 cx 321.4 cy 238.9, k1 k2 p1 p2 k3 = -0.281 0.093 0.0012 -0.0007 -0.011; X Y Z u v */
static const double pinhole_ref[][5] = {
	{0.71429827641765453, -0.0005774862141449883, 4.8700348401461104, 396.06595373119728, 238.8530840728902},
	{0.29525216040545643, -0.49852524512138724, 1.1978430155176178, 439.74460412137972, 40.055629132027349},
	{0.32053213286038079, 0.27369495985172732, 2.0368260122792607, 401.05633746209622, 306.62402654891628},
	{-0.53831756223714911, -0.067806415845355947, 0.78693923125308773, 10.38130373649318, 200.22747837239427},
	{-0.44146505956992665, -0.023091132957031, 2.9190117341744637, 244.39325312439266, 234.90622427535064},
	{0.13958211346877658, -0.52236455821508854, 2.4191068572404166, 350.51588437184381, 130.43386082567028},
	{0.33536085483542855, -0.48043059351257822, 1.7466632687495052, 416.63456474431251, 103.14614294276325},
	{0.14829939333760378, 0.2238394145646842, 0.54678165970700254, 451.65898844522991, 434.82764867722938},
	{0.26259513989684208, -0.13969129513224782, 3.0136896757665799, 365.90310406387351, 215.34556628381316},
	{1.985469405447561, 0.70901010325437464, 3.5772576277572212, 580.83652954716058, 331.3492988006268},
	{-0.2324518816374509, 0.79934522131933206, 3.299003341269009, 285.88767315598113, 360.3830990416692},
	{-0.60094358161934991, 0.1251158413747426, 3.5839550501549398, 236.16287015333046, 256.57544845377021},
	{-0.044992211620674474, -0.00047681276776810356, 0.99120052592877694, 298.15713179577631, 238.65615010897838},
	{1.4610323530384401, 0.71022525159169747, 4.095552858387598, 496.41750913467592, 323.68646467396292},
	{-0.90212598652166154, -0.17892430532569137, 2.6654525175492116, 153.48975665956104, 205.84108367567131},
	{-0.22591387695997756, 0.5174477352043606, 1.9657347655640316, 263.775197907684, 370.22651220613432},
	{-1.0010549487914082, -1.1482797763603791, 2.2403573640000305, 117.9008760989455, 7.0835550448773859},
	{0.81890452606720188, -0.81042280071487649, 1.9631223435350387, 516.22116226834464, 47.126619304298771},
	{-1.4930549456436835, 0.14680497952419727, 2.6356736045985909, 54.504518934523333, 265.20134103891428},
	{-0.097451324762304725, 0.2574614342273841, 0.9314394797921588, 269.00414120081246, 376.62275393826167},
	{0.058206122719576488, 0.017268932628664004, 2.3028113697522605, 334.34595004994998, 242.7226356394581},
	{-0.85663464309585624, -1.4046458479672579, 2.7636739043121987, 176.64056510703898, 3.1167499303951445},
	{-0.87310089273513503, 0.17370549585590694, 3.4355271199232198, 193.52073761276876, 264.25403609876059},
	{0.017702359019059654, -0.44184999156951532, 3.5576650639193921, 323.93179291388537, 175.88679602039505},
	{0.052953629686690304, -0.27390336811344901, 3.9366324421513887, 328.27841566868028, 203.48872626536786},
	{-1.1923343872416909, 1.110137836970531, 4.0214307122058353, 175.91479731068281, 373.74066925202271},
	{-0.87242486661212282, -0.31815926858409205, 1.4887566502179588, 49.746167666343524, 140.60433489112387},
	{-0.067920389018715305, -0.31409484361888734, 1.413422444715821, 297.12645762796961, 127.31278792329765},
	{-0.79353413652544535, -0.012229662569660725, 4.6942439322018217, 235.45751616835497, 237.59959187773393},
	{-0.43010325432666846, 0.17285866752023943, 1.8324603447111574, 203.18321759523619, 286.20948660764225},
	{-2.1130306019420564, 1.055218850160605, 3.4865473434162597, 44.551865981952403, 376.67848796383714},
};
/* cv2.fisheye.projectPoints (OpenCV 4.6.0): fx 331.7 fy 330.9 cx 641.3 cy 479.2, k1..k4 = 0.021 -0.0063 0.0012 -0.00018, 1280x960; X Y Z u v */
static const double fisheye_ref[][5] = {
	{2.0072439061376168, 0.76180201788764457, 0.59716423137335473, 1053.0889243200388, 635.10783029234403},
	{-2.0033011320549958, -0.89290952872569507, 1.6289342293781368, 354.93578160080068, 351.86984489186926},
	{-0.4674463408879323, -0.14470164707976016, 1.1269033819868872, 511.05807010658339, 438.97983679679191},
	{-0.62340727093949644, -1.5497156053782735, 1.7534729861945673, 546.10895806820872, 243.13721895146713},
	{-1.8963879815254419, -2.2234864142567643, 1.6296449539098987, 408.7747610732531, 207.2251907357969},
	{1.8756216079446861, 0.85028534541626832, 4.4736271573950068, 772.11442126682368, 538.35975770187997},
	{-2.1042809881693869, 3.1987743587247053, 2.0751029964599721, 442.08595535299179, 781.30027689695339},
	{-0.32930286880915194, 1.359394778921815, 1.1334273295695305, 570.89662382160066, 769.1311413210376},
	{-1.6898622115307198, -0.063356228968060521, 2.1770204324577138, 420.63063816499016, 470.9466291468853},
	{-0.26235249245939007, 0.90494082755054539, 2.996194073676127, 613.10666941873876, 576.21361037229974},
	{-0.19793846156514053, -0.017715509084673901, 1.883205629501074, 606.55646441856015, 476.09795028794485},
	{0.2676749356731869, -0.68681781928013486, 1.6236372115267774, 692.81845066864287, 347.32941378343315},
	{0.25226055116155077, -0.35599946059685328, 0.31876525580202097, 824.12494019821429, 221.81292450349167},
	{-2.4541963107179976, -1.3886846048421766, 0.18259620745125188, 195.86153048309842, 227.76059575409241},
	{-0.1605841292611459, 2.0203380053965767, 0.32166523999180957, 603.27997555741331, 956.38315008277596},
	{-1.9194692869698644, 0.46121401885023544, 0.37336415281774826, 184.65449891672796, 588.65908436752886},
	{1.2554666703379918, 1.3250386568870325, 1.9463721332453463, 814.89797886189558, 661.97606414377799},
	{-0.14115771066607388, 0.30417396472291375, 1.7831903336946178, 615.32703348107725, 535.03291255564},
	{4.0062962248922469, 0.45490760964063126, 1.4738097715805021, 1051.7054221285753, 525.68839252707039},
	{0.77078803029190657, 0.57809428868188684, 0.12175194191482636, 1033.9293317014681, 772.96344556250199},
	{-0.11214602263807244, -0.38518010883880927, 0.76367466307691478, 596.24354284906747, 324.82096879203516},
	{3.5847101316110912, -1.3735804235434541, 1.9390965436918541, 989.10826633206807, 346.24911134726278},
	{-0.92136261845814138, -2.7978718229395749, 0.40743671869876735, 489.05651491976482, 18.002187029664924},
	{0.042181010611885041, 0.15535383490927199, 3.6525736475363151, 645.12824918118042, 493.26554263440124},
	{0.7374264864865433, 0.60115352623243468, 4.146449702286386, 699.34854906977466, 526.40731840965213},
	{0.97565166305739992, 0.013001355468705558, 1.3365988369816832, 852.00047108267108, 482.00098411291015},
	{1.3014544852002192, 1.5305298389832047, 3.2111771673858618, 762.14638857148384, 620.97439034792376},
	{-2.8955402959630296, -1.0803469570057278, 1.6412085619712595, 298.94505384908751, 351.77297551353132},
	{1.1205310423630008, -1.5758230982389869, 1.1395951572457841, 844.17936803970406, 194.57519331414642},
	{-0.23103362306877642, 0.44527907036767811, 2.9312666682438424, 615.39175230194508, 529.01342801875865},
	{0.34916324669294735, 0.72817706787201497, 2.2030562876945856, 691.81584280098798, 584.29628712642136},
	{-4.0014263947356774, -0.46425316484319284, 0.81970238605582091, 179.53494884360811, 425.7543459470233},
	{-0.60819015005678512, 0.32836427724058886, 2.5915573801166203, 565.12055215007433, 520.2303893424637},
	{1.7091205157457039, 1.2641160503079636, 0.44789835535988709, 1013.120278036404, 753.54599533552891},
	{0.28363706596979488, -0.29540602148241352, 3.3305361164100775, 669.41613410560547, 449.98786754893604},
	{1.2397706698567028, -1.3599910062327238, 0.038584497176757195, 996.19468645973632, 90.830182177978941},
	{0.241824692149639, 0.51541129057864987, 1.8579246260287159, 683.26938665310615, 568.43540569431354},
	{0.93019790218689868, -2.9575313840172166, 0.76204530439036144, 776.5917120374769, 50.082234894260864},
	{0.064575537134687888, -0.31774554304402469, 3.8674517235680996, 646.82634274652901, 452.07307588903132},
	{-0.94429760663251072, -0.35820981424919363, 2.1493670468188677, 504.54639377866738, 427.44900851156819},
};
/* OCamCalib cam2world on asym_calib_results.txt (toolbox axes): row col x y z */
static const double ocam_cam2world_ref[][5] = {
	{174.98025165710609, 273.254268677038, -0.31237357740814375, -0.25254527303608459, -0.91577488129144924},
	{391.13828049579837, 379.47296588478611, 0.70331102125902289, 0.25864662269101679, -0.66215974805640454},
	{3.3891323703742131, 488.70818731163303, -0.80175949927280021, 0.57151565085418898, -0.17479006308867026},
	{283.57504025087155, 68.93490841724973, 0.1751233170221094, -0.94105062281162155, -0.28940550986640357},
	{84.943933767268007, 621.35746978846669, -0.45207403320052153, 0.89158220625768492, 0.026650290626797943},
	{49.339097097559929, 110.90866477073601, -0.64881343589161422, -0.73714106537631863, -0.18884960985499549},
	{307.54947887368229, 174.64049738865333, 0.32399835434353003, -0.67504062874249227, -0.66283121224760178},
	{122.82485945483262, 482.12030534801158, -0.4867431263848358, 0.6833672992359815, -0.54414176760476329},
	{133.32462378306772, 528.35715971052855, -0.40946479893160925, 0.81694286339332001, -0.4061316737052405},
	{445.64228774315745, 404.83152687477434, 0.84052823596302162, 0.33079278208667545, -0.42905526435209757},
	{119.96153850018104, 413.78759040724918, -0.54520805537610051, 0.42654830069882971, -0.72166801475744513},
	{143.61214996183358, 92.727319176020131, -0.35173268966292998, -0.87532962878536813, -0.3317863107377253},
	{124.21276196152877, 468.34212717148779, -0.49250846983468599, 0.63952018420969614, -0.59029597756506236},
	{162.96433925346585, 518.17933414110325, -0.30630271707651274, 0.81490841247056844, -0.49203955612963052},
	{88.186116781328849, 292.11616936789613, -0.68962736973307626, -0.14320664670700353, -0.70986332998259205},
	{326.85938745962102, 148.57400447507774, 0.38715910252817037, -0.74611526567227726, -0.5416824158677932},
	{92.213436365883538, 333.49538810837885, -0.6783703564764515, 0.050285899633721924, -0.73299726312725011},
	{421.90231279287929, 376.52343146557848, 0.79853903859519604, 0.23227195855379168, -0.55532435666828595},
	{453.91087773222205, 592.90331668133285, 0.62416440236770798, 0.77779377933007754, 0.073862274893186808},
	{406.44035862045234, 50.056042431417296, 0.52855923670476368, -0.8484294270235524, -0.028153874592390628},
	{461.06112218954206, 512.73869195944678, 0.7549220123773368, 0.64042463428738849, -0.14124108122645046},
	{403.76495889461489, 448.58081459003114, 0.69564983324930629, 0.52464582753136679, -0.49073217252809059},
	{92.095563638647576, 207.93014346493533, -0.63193433269347576, -0.50442378683621658, -0.58840091981323639},
	{413.48049591144229, 402.26215458756843, 0.76062692119202269, 0.34261613309989458, -0.55141714889693061},
	{11.801270742001442, 418.74569595842007, -0.86172012950367216, 0.3685164046474611, -0.34876077462048899},
	{333.28837149752621, 376.47231384185955, 0.47726424620217256, 0.26543740017068224, -0.83771225721467224},
	{172.24687957416273, 188.03403161450458, -0.29908382064144945, -0.63031215601326818, -0.71641849097606269},
};
/* OCamCalib world2cam (inverse polynomial) on the same file: x y z row col; its largest error against the exact inverse over the field is 8.51e-05 px */
#define OCAM_INVPOL_ERR_PX 0.00113
static const double ocam_world2cam_ref[][5] = {
	{-0.40317395833595676, -1.4959596266492128, -1.0225065228881489, 185.73127684889269, 135.59118777491705},
	{1.2810056003991819, -2.087321116365652, -4.2310051341421167, 288.91078132033095, 237.30045040498578},
	{0.4641335154912285, -1.1024759066349232, -1.286163553623378, 292.52207661729165, 189.54418577156667},
	{-0.085860607761563151, 0.38955124670623392, -0.46635493905457259, 207.13713272484324, 455.78176045168999},
	{-0.84486828514616008, 0.71941552554172328, -0.98939607649967187, 111.7164544300463, 428.84691967154845},
	{0.21918302638631348, -1.1697127813417134, -3.1091972161333228, 249.22571917951643, 254.31269604350592},
	{-1.5091491333838107, 2.8648756851831898, -1.9462177994470136, 141.76886694286935, 502.34925189511506},
	{1.0999398903895774, 3.2693598505441743, -2.1654046698745857, 300.0625605218097, 511.12238935169472},
	{1.8317915073610398, -0.6045519567485611, -4.4270772886919429, 310.94105429349224, 298.19170810395792},
	{-0.10275078544749242, -1.3347479641803621, -2.9665733135252168, 230.14735036955486, 242.19177910952698},
	{-2.4142551942773842, 2.2851181351075924, -2.0151660039230435, 89.422248208012775, 461.76393370889582},
	{2.0362266742840252, -0.010660224704874221, -2.9104964273083724, 353.64109241134429, 322.11080775430617},
	{-1.5188831650391588, 2.2390879847561944, -2.2910661895382725, 141.55135211865129, 462.51095668427661},
	{-0.21202689113962137, -0.042716874492242471, -2.8338901248848658, 222.16468211003445, 319.91010466012625},
	{0.31928839453951341, -0.31181561866430191, -3.8003987780974717, 252.37026905616364, 307.20869920493311},
	{-1.5019643082292613, 0.85900469561860793, -0.79495589184023141, 38.911143522948549, 435.61663514759482},
	{2.1895870237464803, -2.6342171293249619, -2.7661361715285406, 347.55958378531977, 189.1853487296502},
};

/* ---- cameras under test ------------------------------------------------ */

static mc_camera base_camera(mc_camera_model model, int w, int h, double max_theta_deg)
{
	mc_camera c;
	memset(&c, 0, sizeof(c));
	snprintf(c.name, sizeof(c.name), "%s", mc_camera_model_name(model));
	c.model = model;
	c.width = w, c.height = h;
	c.max_theta = max_theta_deg * DEG;
	c.rig_from_cam = mc_xform_identity();
	return c;
}

/* The lens of pinhole_ref. */
static mc_camera cv_pinhole(void)
{
	mc_camera c = base_camera(MC_CAM_PINHOLE, 640, 480, 50);
	c.fx = 512.3, c.fy = 509.8, c.cx = 321.4, c.cy = 238.9;
	double k[5] = {-0.281, 0.093, 0.0012, -0.0007, -0.011};
	memcpy(c.k, k, sizeof(k));
	return c;
}

/* The lens of fisheye_ref; its field reaches 95 degrees off axis. */
static mc_camera cv_fisheye(void)
{
	mc_camera c = base_camera(MC_CAM_EQUIDISTANT, 1280, 960, 95);
	c.fx = 331.7, c.fy = 330.9, c.cx = 641.3, c.cy = 479.2;
	double k[4] = {0.021, -0.0063, 0.0012, -0.00018};
	memcpy(c.k, k, sizeof(k));
	return c;
}

/* The evaluation data's lens (calib.json). */
#define EGO_F 81.48733086305042
#define EGO_C 127.5
#define EGO_A0 81.52990483414433
#define EGO_A2 -0.004317285269898635
#define EGO_A3 6.361321148859789e-06
#define EGO_A4 -8.948906882522099e-08
#define EGO_FIT_ERR_PX 0.11412134498511077

static mc_camera ego_equidistant(void)
{
	mc_camera c = base_camera(MC_CAM_EQUIDISTANT, 256, 256, 90);
	c.fx = c.fy = EGO_F, c.cx = c.cy = EGO_C;
	return c;
}

static mc_camera ego_ocam(void)
{
	mc_camera c = base_camera(MC_CAM_OCAM, 256, 256, 90);
	double pol[5] = {EGO_A0, 0, EGO_A2, EGO_A3, EGO_A4};
	memcpy(c.ocam_pol, pol, sizeof(pol));
	c.ocam_pol_len = 5;
	c.ocam_xc = c.ocam_yc = EGO_C;
	c.ocam_c = 1;
	return c;
}

static double angle_between(mc_vec3 a, mc_vec3 b)
{
	return atan2(mc_v3_norm(mc_v3_cross(a, b)), mc_v3_dot(a, b));
}

/* ---- project/unproject are inverses over the whole valid image -------- */

/* Every `step`-th pixel (and the last row and column): unproject, project
 * back, and compare. Returns the number of valid pixels seen. */
static int next_coord(int x, int step, int size)
{
	if (x == size - 1)
		return size; /* done */
	return x + step < size ? x + step : size - 1;
}

static long check_pixels_roundtrip(const mc_camera *cam, int step)
{
	double worst = 0;
	long valid = 0, lost = 0;
	for (int v = 0; v < cam->height; v = next_coord(v, step, cam->height)) {
		for (int u = 0; u < cam->width; u = next_coord(u, step, cam->width)) {
			double pu = u, pv = v;
			mc_vec3 ray;
			if (!mc_camera_unproject(cam, pu, pv, &ray))
				continue;
			valid++;
			CHECK_NEAR(mc_v3_norm(ray), 1, 1e-12);
			double u2, v2;
			/* A ray from a valid pixel always projects back. */
			if (!mc_camera_project(cam, mc_v3_scale(ray, 2.5), &u2, &v2)) {
				lost++;
				continue;
			}
			worst = fmax(worst, hypot(u2 - pu, v2 - pv));
		}
	}
	CHECK_MSG(worst < 1e-6, "%s: pixel -> ray -> pixel error %.3g px", cam->name, worst);
	CHECK_MSG(lost == 0, "%s: %ld valid pixels did not project back", cam->name, lost);
	printf("%s %dx%d: %ld valid pixels (step %d), round-trip error %.2g px\n", cam->name, cam->width,
	       cam->height, valid, step, worst);
	return valid;
}

/* Random rays up to max_theta: project, unproject, compare directions. */
static void check_rays_roundtrip(const mc_camera *cam)
{
	unsigned long long rng = 7;
	double worst = 0;
	int inside = 0;
	for (int i = 0; i < 20000; i++) {
		double t = cam->max_theta * sqrt(mc_test_rand(&rng)), a = 2 * M_PI * mc_test_rand(&rng);
		mc_vec3 ray = mc_v3(sin(t) * cos(a), sin(t) * sin(a), cos(t)), back;
		double u, v;
		if (!mc_camera_project(cam, mc_v3_scale(ray, 0.5 + 3 * mc_test_rand(&rng)), &u, &v))
			continue;
		inside++;
		CHECK(mc_camera_unproject(cam, u, v, &back));
		worst = fmax(worst, angle_between(ray, back));
	}
	CHECK_MSG(worst < 1e-9, "%s: ray -> pixel -> ray error %.3g rad", cam->name, worst);
	CHECK(inside > 1000);
}

/* Rays exactly `deg` degrees off axis, all around: those landing in the
 * image must come back at that angle. Returns how many landed. */
static int check_ring(const mc_camera *cam, double deg)
{
	int landed = 0;
	double worst = 0;
	for (int i = 0; i < 360; i++) {
		double a = (i + 0.5) * DEG, t = deg * DEG;
		mc_vec3 ray = mc_v3(sin(t) * cos(a), sin(t) * sin(a), cos(t)), back;
		double u, v;
		if (!mc_camera_project(cam, ray, &u, &v))
			continue;
		landed++;
		CHECK(mc_camera_unproject(cam, u, v, &back));
		worst = fmax(worst, angle_between(ray, back));
	}
	CHECK_MSG(worst < 1e-9, "%s at %g deg: error %.3g rad", cam->name, deg, worst);
	return landed;
}

static void test_roundtrips(void)
{
	mc_camera pin = cv_pinhole(), fish = cv_fisheye(), ego = ego_equidistant(), oc = ego_ocam();
	/* The pinhole sees its whole image (its corners are ~44 degrees off axis). */
	CHECK(check_pixels_roundtrip(&pin, 1) == 640L * 480);
	check_pixels_roundtrip(&fish, 2);
	/* A 180-degree circle spanning the width covers about pi/4 of the image. */
	long n = check_pixels_roundtrip(&ego, 1);
	CHECK_MSG(fabs(n / (256.0 * 256.0) - M_PI / 4) < 0.01, "equidistant valid fraction %g", n / 65536.0);
	n = check_pixels_roundtrip(&oc, 1);
	CHECK_MSG(fabs(n / (256.0 * 256.0) - M_PI / 4) < 0.02, "ocam valid fraction %g", n / 65536.0);
	check_rays_roundtrip(&pin);
	check_rays_roundtrip(&fish);
	check_rays_roundtrip(&ego);
	check_rays_roundtrip(&oc);
	/* 90 degrees off axis lands on the edge of the 180-degree circle, inside
	 * the image except where the circle touches the border. */
	CHECK(check_ring(&ego, 90) > 200);
	CHECK(check_ring(&oc, 90) > 200);
	/* Behind the image plane: the 95-degree fisheye still sees it. */
	CHECK(check_ring(&fish, 93) > 150);
	/* Beyond max_theta nothing projects. */
	CHECK(check_ring(&ego, 90.2) == 0);
	CHECK(check_ring(&oc, 90.2) == 0);
	CHECK(check_ring(&fish, 95.5) == 0);
	double u, v;
	CHECK(!mc_camera_project(&pin, mc_v3(0.1, 0.1, -1), &u, &v));
	CHECK(!mc_camera_project(&pin, mc_v3(0, 0, 0), &u, &v));
	CHECK(!mc_camera_project(&ego, mc_v3(0, 0, -1), &u, &v));
	CHECK(!mc_camera_project(&ego, mc_v3(NAN, 0, 1), &u, &v));
	/* outside the image */
	mc_vec3 ray;
	CHECK(!mc_camera_unproject(&pin, -0.6, 10, &ray));
	CHECK(!mc_camera_unproject(&pin, 10, 479.5, &ray));
	CHECK(mc_camera_unproject(&pin, -0.5, 10, &ray));
	/* the corner of a fisheye image is outside its circle */
	CHECK(!mc_camera_unproject(&ego, 0, 0, &ray));
	CHECK(!mc_camera_unproject(&oc, 255, 0, &ray));
	CHECK(mc_camera_unproject(&ego, 127.5, 127.5, &ray) && fabs(ray.z - 1) < 1e-15);
}

/* ---- against independent references ------------------------------------ */

static void check_table(const mc_camera *cam, const double (*ref)[5], int n, double tol_px)
{
	double worst_px = 0, worst_rad = 0;
	for (int i = 0; i < n; i++) {
		mc_vec3 p = mc_v3(ref[i][0], ref[i][1], ref[i][2]), ray;
		double u, v;
		CHECK_MSG(mc_camera_project(cam, p, &u, &v), "%s: reference point %d not projected", cam->name, i);
		worst_px = fmax(worst_px, hypot(u - ref[i][3], v - ref[i][4]));
		CHECK(mc_camera_unproject(cam, ref[i][3], ref[i][4], &ray));
		worst_rad = fmax(worst_rad, angle_between(ray, p));
	}
	CHECK_MSG(worst_px < tol_px, "%s: %.3g px from the reference", cam->name, worst_px);
	CHECK_MSG(worst_rad < 1e-8, "%s: %.3g rad from the reference", cam->name, worst_rad);
	printf("%s: %d reference points, worst %.2g px, %.2g rad\n", cam->name, n, worst_px, worst_rad);
}

static void test_opencv_references(void)
{
	mc_camera pin = cv_pinhole(), fish = cv_fisheye();
	check_table(&pin, pinhole_ref, (int)(sizeof(pinhole_ref) / sizeof(pinhole_ref[0])), 1e-6);
	check_table(&fish, fisheye_ref, (int)(sizeof(fisheye_ref) / sizeof(fisheye_ref[0])), 1e-6);
	CHECK(sizeof(pinhole_ref) / sizeof(pinhole_ref[0]) >= 20);
	CHECK(sizeof(fisheye_ref) / sizeof(fisheye_ref[0]) >= 20);
}

/* The evaluation data's lens by its published formulas. */
static void test_ego_formulas(void)
{
	mc_camera eq = ego_equidistant(), oc = ego_ocam();
	for (int ti = 0; ti <= 18; ti++) {
		for (int ai = 0; ai < 12; ai++) {
			double theta = ti * 5 * DEG, phi = ai * 30 * DEG + 0.1;
			mc_vec3 p = mc_v3(2 * sin(theta) * cos(phi), 2 * sin(theta) * sin(phi), 2 * cos(theta));
			/* r_pixels = f * theta from (cx, cy), along the azimuth */
			double ue = EGO_C + EGO_F * theta * cos(phi), ve = EGO_C + EGO_F * theta * sin(phi), u, v;
			bool in = ue >= -0.5 && ue < 255.5 && ve >= -0.5 && ve < 255.5;
			CHECK(mc_camera_project(&eq, p, &u, &v) == in);
			if (in) {
				CHECK_NEAR(u, ue, 1e-9);
				CHECK_NEAR(v, ve, 1e-9);
			}
		}
	}
	/* ocam: ray = (u - cx, v - cy, a0 + a2 rho^2 + a3 rho^3 + a4 rho^4) */
	for (int v = 0; v < 256; v += 5) {
		for (int u = 0; u < 256; u += 5) {
			double x = u - EGO_C, y = v - EGO_C, rho = sqrt(x * x + y * y);
			double w = EGO_A0 + EGO_A2 * rho * rho + EGO_A3 * rho * rho * rho + EGO_A4 * rho * rho * rho * rho;
			mc_vec3 expect = mc_v3_normalize(mc_v3(x, y, w)), ray;
			bool in = atan2(rho, w) <= M_PI / 2;
			CHECK(mc_camera_unproject(&oc, u, v, &ray) == in);
			if (in)
				CHECK(angle_between(ray, expect) < 1e-12);
		}
	}
	/* The two descriptions of the lens agree within the stated fit error. */
	double worst = 0;
	for (int v = 0; v < 256; v++) {
		for (int u = 0; u < 256; u++) {
			mc_vec3 ray;
			double u2, v2;
			if (!mc_camera_unproject(&oc, u, v, &ray) || !mc_camera_project(&eq, ray, &u2, &v2))
				continue;
			worst = fmax(worst, hypot(u2 - u, v2 - v));
		}
	}
	printf("ego lens: ocam vs equidistant %.3g px (calib.json fit error %.3g px)\n", worst, EGO_FIT_ERR_PX);
	CHECK(worst <= EGO_FIT_ERR_PX * 1.05);
}

/* ---- OCamCalib --------------------------------------------------------- */

/* The toolbox's axes, in OpenCV terms, are (down, right, backward). */
static mc_vec3 toolbox_to_opencv(double x, double y, double z)
{
	return mc_v3(y, x, -z);
}

static void test_ocamcalib_asym(void)
{
	mc_camera cam;
	mc_err err = {0};
	if (mc_rig_import_ocamcalib("tests/data/ocam/asym_calib_results.txt", 95 * DEG, &cam, &err)) {
		CHECK_MSG(0, "import: %s", err.msg);
		return;
	}
	CHECK(cam.width == 640 && cam.height == 480);
	CHECK(cam.ocam_pol_len == 5 && cam.ocam_invpol_len == 13);
	/* cam2world: pixel (row, col) -> the toolbox's unit vector */
	double worst = 0;
	int n = (int)(sizeof(ocam_cam2world_ref) / sizeof(ocam_cam2world_ref[0]));
	for (int i = 0; i < n; i++) {
		const double *r = ocam_cam2world_ref[i];
		mc_vec3 expect = toolbox_to_opencv(r[2], r[3], r[4]), ray;
		CHECK(mc_camera_unproject(&cam, r[1], r[0], &ray));
		worst = fmax(worst, angle_between(ray, expect));
		/* and back: our projection is the exact inverse of cam2world */
		double u, v;
		CHECK(mc_camera_project(&cam, expect, &u, &v));
		CHECK(hypot(u - r[1], v - r[0]) < 1e-6);
	}
	CHECK_MSG(worst < 1e-9, "cam2world: %.3g rad", worst);
	/* world2cam uses the fitted inverse polynomial: agree within its error */
	double worst_px = 0;
	n = (int)(sizeof(ocam_world2cam_ref) / sizeof(ocam_world2cam_ref[0]));
	for (int i = 0; i < n; i++) {
		const double *r = ocam_world2cam_ref[i];
		double u, v;
		CHECK(mc_camera_project(&cam, toolbox_to_opencv(r[0], r[1], r[2]), &u, &v));
		worst_px = fmax(worst_px, hypot(u - r[4], v - r[3]));
	}
	CHECK_MSG(worst_px < OCAM_INVPOL_ERR_PX, "world2cam: %.3g px", worst_px);
	printf("OCamCalib asym lens: cam2world %.2g rad, world2cam %.2g px\n", worst, worst_px);
	check_pixels_roundtrip(&cam, 2);
	check_rays_roundtrip(&cam);
	/* Without the inverse polynomial projection finds the same pixels. */
	mc_camera noinv = cam;
	noinv.ocam_invpol_len = 0;
	for (int i = 0; i < n; i++) {
		const double *r = ocam_world2cam_ref[i];
		double u1, v1, u2, v2;
		mc_vec3 p = toolbox_to_opencv(r[0], r[1], r[2]);
		CHECK(mc_camera_project(&cam, p, &u1, &v1) && mc_camera_project(&noinv, p, &u2, &v2));
		CHECK(hypot(u1 - u2, v1 - v2) < 1e-7);
	}
}

/* The evaluation lens written by OCamCalib's exporter unprojects the same
 * rays as calib.json's own ocam description, within the file's rounding. */
static void test_ocamcalib_ego(void)
{
	mc_camera cam, oc = ego_ocam(), eq = ego_equidistant();
	mc_err err = {0};
	if (mc_rig_import_ocamcalib("tests/data/ocam/ego_calib_results.txt", M_PI / 2, &cam, &err)) {
		CHECK_MSG(0, "import: %s", err.msg);
		return;
	}
	CHECK(cam.width == 256 && cam.height == 256);
	double worst_rad = 0, worst_px = 0;
	long both = 0, differ = 0;
	for (int v = 0; v < 256; v++) {
		for (int u = 0; u < 256; u++) {
			mc_vec3 r1, r2;
			bool ok1 = mc_camera_unproject(&cam, u, v, &r1), ok2 = mc_camera_unproject(&oc, u, v, &r2);
			if (ok1 != ok2) {
				differ++;
				continue;
			}
			if (!ok1)
				continue;
			both++;
			worst_rad = fmax(worst_rad, angle_between(r1, r2));
			double u2, v2;
			if (mc_camera_project(&eq, r1, &u2, &v2))
				worst_px = fmax(worst_px, hypot(u2 - u, v2 - v));
		}
	}
	printf("OCamCalib ego lens: %ld pixels, %.2g rad from calib.json's ocam, %.3g px from the equidistant "
	       "truth, %ld differ in validity\n",
	       both, worst_rad, worst_px, differ);
	/* 7 significant digits in the file: a few 1e-7 radians */
	CHECK(worst_rad < 2e-6);
	CHECK(worst_px <= EGO_FIT_ERR_PX * 1.05);
	/* only pixels within rounding of the 90-degree edge may disagree */
	CHECK(differ < 8);
}

/* ---- validation ---------------------------------------------------------- */

static void expect_invalid(const mc_camera *cam, const char *field)
{
	mc_err err = {0};
	CHECK_MSG(mc_camera_validate(cam, &err) == -1, "accepted a bad %s", field);
	CHECK_MSG(strncmp(err.msg, field, strlen(field)) == 0, "message '%s' should name %s", err.msg, field);
}

static void test_validate(void)
{
	mc_err err = {0};
	mc_camera good[4] = {cv_pinhole(), cv_fisheye(), ego_equidistant(), ego_ocam()};
	for (int i = 0; i < 4; i++)
		CHECK_MSG(mc_camera_validate(&good[i], &err) == 0, "%s", err.msg);
	mc_camera c = cv_pinhole();
	c.fx = -1;
	expect_invalid(&c, "fx");
	c = cv_pinhole(), c.fy = 0;
	expect_invalid(&c, "fy");
	c = cv_pinhole(), c.cx = NAN;
	expect_invalid(&c, "cx");
	c = cv_pinhole(), c.k[2] = INFINITY;
	expect_invalid(&c, "k[2]");
	c = cv_pinhole(), c.width = 0;
	expect_invalid(&c, "width");
	c = cv_pinhole(), c.height = -5;
	expect_invalid(&c, "height");
	c = cv_pinhole(), c.max_theta = 95 * DEG;
	expect_invalid(&c, "max_theta");
	c = cv_pinhole(), c.max_theta = 0;
	expect_invalid(&c, "max_theta");
	c = cv_pinhole(), c.max_theta = 80 * DEG; /* this distortion folds back before 80 degrees */
	expect_invalid(&c, "k");
	c = ego_equidistant(), c.k[0] = -0.5;  /* theta_d stops increasing at 47 degrees */
	expect_invalid(&c, "k");
	c = ego_equidistant(), c.max_theta = 180 * DEG;
	expect_invalid(&c, "max_theta");
	c = ego_ocam(), c.ocam_pol[0] = -EGO_A0;
	expect_invalid(&c, "ocam_pol[0]");
	c = ego_ocam(), c.ocam_pol_len = 0;
	expect_invalid(&c, "ocam_pol");
	c = ego_ocam(), c.ocam_pol_len = MC_OCAM_POLY_MAX + 1;
	expect_invalid(&c, "ocam_pol");
	c = ego_ocam(), c.ocam_pol[3] = NAN;
	expect_invalid(&c, "ocam_pol[3]");
	c = ego_ocam(), c.ocam_c = 0;
	expect_invalid(&c, "ocam_c");
	c = ego_ocam(), c.ocam_yc = INFINITY;
	expect_invalid(&c, "ocam_yc");
	c = ego_ocam(), c.ocam_pol[2] = 0.02; /* w grows with rho: the field shrinks back */
	expect_invalid(&c, "ocam_pol");
	c = ego_ocam(), c.ocam_pol[4] = 2e-7; /* theta(rho) peaks at 59 degrees */
	expect_invalid(&c, "ocam_pol");
	/* The same lens is fine when it claims no more than it sees. */
	c.max_theta = 55 * DEG;
	CHECK_MSG(mc_camera_validate(&c, &err) == 0, "%s", err.msg);
	/* The shared lens keeps widening beyond 90 degrees in the corners. */
	c = ego_ocam(), c.max_theta = 100 * DEG;
	CHECK_MSG(mc_camera_validate(&c, &err) == 0, "%s", err.msg);
	c = ego_ocam(), c.rig_from_cam.R.m[0][1] = 0.1;
	expect_invalid(&c, "rig_from_cam");
	c = ego_ocam(), c.rig_from_cam.R.m[0][0] = -1; /* a reflection */
	expect_invalid(&c, "rig_from_cam");
	c = ego_ocam(), c.rig_from_cam.t.y = NAN;
	expect_invalid(&c, "rig_from_cam");
	c = ego_ocam(), c.model = (mc_camera_model)7;
	expect_invalid(&c, "model");

	mc_camera_model m;
	CHECK(mc_camera_model_parse("ocam", &m) == 0 && m == MC_CAM_OCAM);
	CHECK(mc_camera_model_parse("equidistant", &m) == 0 && m == MC_CAM_EQUIDISTANT);
	CHECK(mc_camera_model_parse("fisheye", &m) == -1);
	CHECK(strcmp(mc_camera_model_name(MC_CAM_PINHOLE), "pinhole") == 0);
}

/* The unbounded projection (calibration): the same formula past the field
 * of view and the image, where the bounded one refuses. */
static void test_unbounded(void)
{
	mc_camera eq = ego_equidistant();
	eq.max_theta = 80 * DEG;
	double u, v, ub, vb;
	for (int ti = 0; ti <= 34; ti++) {
		double theta = ti * 5 * DEG, phi = 0.7;
		mc_vec3 p = mc_v3(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
		CHECK(mc_camera_project_unbounded(&eq, p, &u, &v));
		CHECK_NEAR(u, EGO_C + EGO_F * theta * cos(phi), 1e-9);
		CHECK_NEAR(v, EGO_C + EGO_F * theta * sin(phi), 1e-9);
		bool bounded = mc_camera_project(&eq, p, &ub, &vb);
		CHECK(bounded == (theta <= 80 * DEG + 1e-12));
	}
	mc_camera pin = eq;
	pin.model = MC_CAM_PINHOLE;
	pin.max_theta = 30 * DEG;
	CHECK(mc_camera_project_unbounded(&pin, mc_v3(3, 0, 1), &u, &v) && fabs(u - (EGO_C + 3 * EGO_F)) < 1e-9);
	CHECK(!mc_camera_project(&pin, mc_v3(3, 0, 1), &u, &v));
	CHECK(!mc_camera_project_unbounded(&pin, mc_v3(1, 0, -1), &u, &v)); /* behind a pinhole */
}

/* A rig-frame point projects where the camera sees it, and its pixel's
 * rig-frame ray passes through it: the camera turned and moved on the rig. */
static void test_rig_frame(void)
{
	mc_camera eq = ego_equidistant();
	eq.rig_from_cam = (mc_xform){mc_m3_rot_axis(1, 20 * DEG), mc_v3(0.1, -0.05, 0.02)};
	mc_vec3 p_rig = mc_v3(0.4, 0.3, 1.2);
	double u, v, uc, vc;
	CHECK(mc_camera_project_rig(&eq, p_rig, &u, &v));
	CHECK(mc_camera_project(&eq, mc_xform_apply(mc_xform_inverse(eq.rig_from_cam), p_rig), &uc, &vc));
	CHECK_NEAR(u, uc, 1e-12);
	CHECK_NEAR(v, vc, 1e-12);
	mc_vec3 dir;
	CHECK(mc_camera_unproject_rig(&eq, u, v, &dir));
	mc_vec3 to_p = mc_v3_sub(p_rig, eq.rig_from_cam.t);
	CHECK_NEAR(mc_v3_norm(mc_v3_reject(to_p, dir)), 0, 1e-9);
	CHECK(mc_v3_dot(to_p, dir) > 0);
	/* behind the camera: not seen */
	CHECK(!mc_camera_project_rig(&eq, mc_v3_sub(eq.rig_from_cam.t, mc_m3_apply(eq.rig_from_cam.R, mc_v3(0, 0, 1))),
				     &u, &v));
}

/* The field of view fitted to a calibration without one. */
static void test_fit_max_theta(void)
{
	mc_err err = {{0}};
	mc_camera eq = ego_equidistant();
	CHECK(mc_camera_fit_max_theta(&eq, &err) == 0);
	/* the image corner is sqrt(2) * 128 px from the centre: 1.1 x that angle, below 179 degrees */
	CHECK_NEAR(eq.max_theta, fmin(1.1 * sqrt(2) * 128 / EGO_F, 179 * DEG), 0.01);
}

int main(void)
{
	test_unbounded();
	test_rig_frame();
	test_fit_max_theta();
	test_roundtrips();
	test_opencv_references();
	test_ego_formulas();
	test_ocamcalib_asym();
	test_ocamcalib_ego();
	test_validate();
	return mc_test_finish("test_camera");
}
