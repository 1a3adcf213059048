/* test_gstreamer_probe: the gstreamer driver's probe() and modes() (mocapd
 * --probe), through the plugin ABI as the daemon loads it:
 *   - with the device providers installed here (no camera in this VM):
 *     probe() does not fail, and lists what it finds;
 *   - with a device provider registered by this test in the process (a
 *     "camera" whose element is videotestsrc pattern=ball, with the caps
 *     a UVC camera offers: YUYV at two rates, MJPEG, H.264, and NV12 in
 *     DMA buffers): probe() lists it with its description as id, its
 *     display name, bus path and serial; modes() gives YUY2 (delivered as
 *     RGB24) and MJPEG and leaves out H.264 and the DMA buffers; a device
 *     that is not there is NODEV; and the [camera] section mocapd --probe
 *     prints for it (pipeline = ID ! CAPS ! videoconvert ! appsink
 *     name=mocap) opens and delivers frames of that mode;
 *   - mocapd --probe itself exits 0 and asks each plugin, the gstreamer
 *     one too (before, every plugin after the first was taken for the
 *     first: "the driver calls itself 'files', not 'gstreamer'"). */
#include <limits.h>
#include <string.h>
#include <unistd.h>

#include "gst_test_util.h"

static drv_harness G;
static uint8_t buf[1 << 20];

/* ---- a device provider of one fake camera ---- */

typedef struct {
	GstDevice parent;
} FakeCam;
typedef struct {
	GstDeviceClass parent_class;
} FakeCamClass;
G_DEFINE_TYPE(FakeCam, fake_cam, GST_TYPE_DEVICE)

static GstElement *fake_cam_create_element(GstDevice *dev, const gchar *name)
{
	(void)dev;
	GstElement *e = gst_element_factory_make("videotestsrc", name);
	if (e)
		gst_util_set_object_arg(G_OBJECT(e), "pattern", "ball");
	return e;
}

static void fake_cam_class_init(FakeCamClass *k) { GST_DEVICE_CLASS(k)->create_element = fake_cam_create_element; }
static void fake_cam_init(FakeCam *c) { (void)c; }

typedef struct {
	GstDeviceProvider parent;
} FakeProvider;
typedef struct {
	GstDeviceProviderClass parent_class;
} FakeProviderClass;
G_DEFINE_TYPE(FakeProvider, fake_provider, GST_TYPE_DEVICE_PROVIDER)

#define FAKE_CAPS                                                                                                    \
	"video/x-raw, format=(string)YUY2, width=(int)320, height=(int)240, framerate=(fraction){ 15/1, 30/1 }; "    \
	"image/jpeg, width=(int)640, height=(int)480, framerate=(fraction)30/1; "                                   \
	"video/x-h264, width=(int)1920, height=(int)1080, framerate=(fraction)30/1; "                               \
	"video/x-raw(memory:DMABuf), format=(string)NV12, width=(int)1280, height=(int)720, "                        \
	"framerate=(fraction)30/1"

static GList *fake_provider_probe(GstDeviceProvider *p)
{
	(void)p;
	GstCaps *caps = gst_caps_from_string(FAKE_CAPS);
	GstStructure *props = gst_structure_new("props", "device.bus_path", G_TYPE_STRING, "pci-0000:00:14.0-usb-0:2:1.0",
						"device.serial", G_TYPE_STRING, "Fake_Cam_1234", NULL);
	GstDevice *dev = g_object_new(fake_cam_get_type(), "display-name", "Fake USB Camera", "device-class",
				      "Video/Source", "caps", caps, "properties", props, NULL);
	gst_caps_unref(caps);
	gst_structure_free(props);
	return g_list_append(NULL, dev);
}

static void fake_provider_class_init(FakeProviderClass *k)
{
	GstDeviceProviderClass *dp = GST_DEVICE_PROVIDER_CLASS(k);
	dp->probe = fake_provider_probe;
	gst_device_provider_class_set_static_metadata(dp, "Fake camera", "Video/Source", "a camera for the test",
						      "mocap");
}
static void fake_provider_init(FakeProvider *p) { (void)p; }

/* ---- the tests ---- */

static void test_installed_providers(void)
{
	mdrv_device_info devs[16];
	int n = drv_check_probe(&G, devs, 16, "video sources from the installed providers");
	for (int i = 0; i < n; i++)
		printf("  %s  \"%s\"\n", devs[i].id, devs[i].name);
}

static const mdrv_device_info *find_fake(const mdrv_device_info *devs, int n)
{
	for (int i = 0; i < n; i++)
		if (!strcmp(devs[i].name, "Fake USB Camera"))
			return &devs[i];
	return NULL;
}

static void check_modes(const mdrv_device_info *d)
{
	mdrv_mode modes[16];
	char err[512] = "";
	int n = G.drv->modes(&G.host, d->id, modes, 16, err, sizeof err);
	CHECK_MSG(n == 2, "modes: 2 (YUY2, MJPEG; not H.264 nor DMA buffers), got %d: %s", n, err);
	if (n != 2)
		return;
	CHECK(!strcmp(modes[0].pixel_format, "YUY2") && modes[0].pixfmt == MC_PIXFMT_RGB24);
	CHECK(modes[0].width == 320 && modes[0].height == 240 && modes[0].nfps == 2);
	CHECK(modes[0].fps[0] == 30 && modes[0].fps[1] == 15);
	CHECK(!strcmp(modes[1].pixel_format, "MJPEG") && modes[1].pixfmt == MC_PIXFMT_MJPEG);
	CHECK(modes[1].width == 640 && modes[1].height == 480 && modes[1].nfps == 1 && modes[1].fps[0] == 30);
	CHECK(!strcmp(modes[0].format_key, "pipeline"));
	n = G.drv->modes(&G.host, "v4l2src device=/dev/nothing", modes, 16, err, sizeof err);
	CHECK_MSG(n == MDRV_ERR_NODEV && strstr(err, "/dev/nothing"), "a device that is not there: %d %s", n, err);
}

/* The section mocapd --probe prints for the YUY2 mode, as a camera. */
static void check_section_opens(const mdrv_device_info *d)
{
	char pipeline[512], err[1024] = "";
	snprintf(pipeline, sizeof pipeline,
		 "%s ! video/x-raw,format=YUY2,width=320,height=240,framerate=30/1 ! videoconvert ! appsink name=mocap",
		 d->id);
	printf("  pipeline = %s\n", pipeline);
	drv_harness_clear(&G);
	drv_harness_set(&G, "pipeline", pipeline);
	void *dev = drv_harness_open_start(&G, err, sizeof err);
	CHECK_MSG(dev != NULL, "the pasted section opens: %s", err);
	if (!dev)
		return;
	for (int k = 0; k < 3; k++) {
		mdrv_frame f;
		int rc = drv_harness_frame(&G, dev, &f, buf, sizeof buf, 5000, err, sizeof err);
		CHECK_MSG(rc == MDRV_OK, "frame %d: %s", k, err);
		CHECK(rc != MDRV_OK || (f.format.width == 320 && f.format.height == 240 &&
					f.format.pixfmt == MC_PIXFMT_RGB24));
	}
	G.drv->stop(dev);
	G.drv->close(dev);
}

static void test_fake_camera(void)
{
	CHECK(gst_device_provider_register(NULL, "mocapfakecamprovider", GST_RANK_PRIMARY, fake_provider_get_type()));
	mdrv_device_info devs[16];
	int n = drv_check_probe(&G, devs, 16, "video sources with the fake camera");
	const mdrv_device_info *d = find_fake(devs, n);
	CHECK_MSG(d != NULL, "the fake camera is listed");
	if (!d)
		return;
	printf("  %s  \"%s\"  bus_info %s  serial %s\n", d->id, d->name, d->bus_info, d->serial);
	CHECK_MSG(!strcmp(d->id, "videotestsrc pattern=ball"), "id is the element's description: '%s'", d->id);
	CHECK(!strcmp(d->bus_info, "pci-0000:00:14.0-usb-0:2:1.0"));
	CHECK(!strcmp(d->serial, "Fake_Cam_1234"));
	check_modes(d);
	check_section_opens(d);
}

/* mocapd --probe, next to this program: <build>/bin/mocapd. */
static void test_mocapd_probe(void)
{
	char exe[PATH_MAX], cmd[PATH_MAX * 2 + 64];
	ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
	CHECK(len > 0);
	if (len <= 0)
		return;
	exe[len] = 0;
	*strrchr(exe, '/') = 0; /* <build>/tests/drivers */
	const char *plugins = getenv("MOCAP_DRIVER_DIR");
	snprintf(cmd, sizeof cmd, "%s/../../bin/mocapd --probe --plugin-dir %s%s 2>&1", exe, plugins ? "" : exe,
		 plugins ? plugins : "/../../drivers");
	FILE *p = popen(cmd, "r");
	CHECK(p != NULL);
	if (!p)
		return;
	char line[1024];
	bool listed = false, mistaken = false;
	while (fgets(line, sizeof line, p)) {
		listed |= strncmp(line, "gstreamer: ", 11) == 0 && strstr(line, " device");
		mistaken |= strstr(line, "calls itself") != NULL;
		fputs(line, stdout);
	}
	int status = pclose(p);
	CHECK_MSG(status == 0, "mocapd --probe exits 0 (%d)", status);
	CHECK_MSG(listed, "mocapd --probe lists the gstreamer driver's devices");
	CHECK_MSG(!mistaken, "mocapd --probe loads each plugin, not the first again");
}

int main(void)
{
	static const char *const need[] = {"videotestsrc", "videoconvert", "appsink"};
	gst_test_require(need, sizeof need / sizeof need[0]);
	drv_check_load(&G, "gstreamer");
	G.quiet = 1;
	CHECK(G.drv->modes != NULL);
	test_installed_providers();
	test_fake_camera();
	test_mocapd_probe();
	printf("%d failure(s)\n", mc_test_failures);
	return mc_test_failures ? 1 : 0;
}
