/* mocap-driver-openni2: depth and colour streams from OpenNI2 devices
 * (PrimeSense / Asus Xtion / Orbbec and .oni recordings), behind the C ABI.
 * OpenNI2's C header does not compile as C, so this plugin uses its C++ API.
 *
 * One camera section = one stream (`stream = depth | color | ir`); an RGB-D
 * camera is two sections naming the same device.  Those share one
 * openni::Device here, because OpenNI2 drivers hand out one device object
 * per URI and closing it twice crashes them.
 *
 * Depth frames are MC_PIXFMT_DEPTH16 (uint16 millimetres, 0 = no reading).
 * Timestamps: OpenNI2 stamps frames with the device's microsecond clock; it
 * is mapped to CLOCK_MONOTONIC by the smallest arrival delay seen (the
 * least-delayed frame defines the offset), allowing 100 ppm of clock drift.
 * Config keys are listed in docs/DRIVERS.md. */
#include <OpenNI.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <string>

extern "C" {
#include "drv_common.h"
#include "mdrv.h"
}

#define DRV "openni2"

namespace {

using namespace openni;

/* OpenNI2's last error on one line (it comes with tabs and newlines). */
std::string oni_error()
{
	std::string out;
	bool space = false;
	for (const char *p = OpenNI::getExtendedError(); p && *p; p++) {
		bool ws = *p == ' ' || *p == '\t' || *p == '\n' || *p == '\r';
		if (ws) {
			space = !out.empty();
			continue;
		}
		if (space)
			out += ' ';
		space = false;
		out += *p;
	}
	return out.empty() ? "no details" : out;
}

/* ---- the OpenNI2 runtime ----
 * Started on first use and kept for the life of the process: starting it
 * loads every OpenNI2 driver module and scans USB, which is slow, and
 * shutting it down unloads those modules with memory they never free. */
std::mutex runtime_lock;
bool runtime_started;

int start_runtime(char *err, size_t errlen)
{
	std::lock_guard<std::mutex> g(runtime_lock);
	if (runtime_started)
		return MDRV_OK;
	if (OpenNI::initialize() != STATUS_OK)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": cannot start OpenNI2: %s", oni_error().c_str());
	runtime_started = true;
	return MDRV_OK;
}

/* ---- devices shared between streams ---- */

struct SharedDevice {
	Device device;
	int users = 0;
};

std::mutex devices_lock;
std::map<std::string, std::unique_ptr<SharedDevice>> devices;

/* Opens (or shares) the device at `uri`; nullptr with err. */
SharedDevice *acquire_device(const std::string &uri, char *err, size_t errlen)
{
	std::lock_guard<std::mutex> g(devices_lock);
	auto it = devices.find(uri);
	if (it == devices.end()) {
		auto d = std::make_unique<SharedDevice>();
		if (d->device.open(uri.c_str()) != STATUS_OK) {
			drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": cannot open device '%s': %s", uri.c_str(),
				 oni_error().c_str());
			return nullptr;
		}
		it = devices.emplace(uri, std::move(d)).first;
	}
	it->second->users++;
	return it->second.get();
}

void release_device(const std::string &uri)
{
	std::lock_guard<std::mutex> g(devices_lock);
	auto it = devices.find(uri);
	if (it != devices.end() && --it->second->users == 0) {
		it->second->device.close();
		devices.erase(it);
	}
}

/* ---- pixel formats ---- */

const char *oni_format_name(PixelFormat f)
{
	switch (f) {
	case PIXEL_FORMAT_DEPTH_1_MM: return "DEPTH_1_MM";
	case PIXEL_FORMAT_DEPTH_100_UM: return "DEPTH_100_UM";
	case PIXEL_FORMAT_SHIFT_9_2: return "SHIFT_9_2";
	case PIXEL_FORMAT_SHIFT_9_3: return "SHIFT_9_3";
	case PIXEL_FORMAT_RGB888: return "RGB888";
	case PIXEL_FORMAT_YUV422: return "YUV422";
	case PIXEL_FORMAT_GRAY8: return "GRAY8";
	case PIXEL_FORMAT_GRAY16: return "GRAY16";
	case PIXEL_FORMAT_JPEG: return "JPEG";
	case PIXEL_FORMAT_YUYV: return "YUYV";
	default: return "?";
	}
}

/* The mocapd format for an OpenNI2 one, NONE if not taken. */
mc_pixfmt to_mocap(PixelFormat f, unsigned *bpp)
{
	switch (f) {
	case PIXEL_FORMAT_DEPTH_1_MM: *bpp = 2; return MC_PIXFMT_DEPTH16;
	case PIXEL_FORMAT_RGB888: *bpp = 3; return MC_PIXFMT_RGB24;
	case PIXEL_FORMAT_YUYV: *bpp = 2; return MC_PIXFMT_YUYV;
	case PIXEL_FORMAT_GRAY8: *bpp = 1; return MC_PIXFMT_GRAY8;
	default: *bpp = 0; return MC_PIXFMT_NONE;
	}
}

/* ---- one stream ---- */

struct Settings {
	std::string uri;
	SensorType sensor = SENSOR_DEPTH;
	const char *sensor_name = "depth";
	unsigned width = 0, height = 0;
	double fps = 0;
	bool mirror = false, mirror_set = false;
	bool registration = false;
	bool loop = false;
	double speed = 1.0;
	bool speed_set = false;
};

class Disconnects;

struct Camera {
	mdrv_host host{};
	Settings cfg;
	SharedDevice *shared = nullptr;
	VideoStream stream;
	bool created = false, running = false;
	mdrv_format fmt{};
	bool playback = false;
	int n_frames = 0; /* frames in a recording, 0 = live */
	bool ended = false;
	bool have_offset = false;
	int64_t offset_ns = 0; /* monotonic - device clock */
	uint64_t last_arrival_ns = 0;
	uint64_t last_device_us = 0;
	std::unique_ptr<Disconnects> listener;
	volatile bool gone = false;

	~Camera();
};

/* Marks the camera gone when OpenNI2 reports its device disconnected. */
class Disconnects : public OpenNI::DeviceDisconnectedListener
{
public:
	explicit Disconnects(Camera *c) : cam(c) {}
	void onDeviceDisconnected(const DeviceInfo *info) override
	{
		if (info && cam->cfg.uri == info->getUri())
			cam->gone = true;
	}

private:
	Camera *cam;
};

Camera::~Camera()
{
	if (listener)
		OpenNI::removeDeviceDisconnectedListener(listener.get());
	if (running) {
		stream.stop();
		/* OpenNI2's DummyDevice (and maybe others) lets its stream
		 * thread run on briefly after stop(); destroying the stream
		 * under it crashes, so give it time to see the stop */
		usleep(100000);
	}
	if (created)
		stream.destroy();
	if (shared)
		release_device(cfg.uri);
}

int read_settings(const mdrv_host *host, Settings &s, char *err, size_t errlen)
{
	const char *uri = drv_cfg_str(host, "device");
	if (uri)
		s.uri = uri;
	static const char *const sensors[] = {"depth", "color", "colour", "ir"};
	static const SensorType types[] = {SENSOR_DEPTH, SENSOR_COLOR, SENSOR_COLOR, SENSOR_IR};
	int which = 0, st;
	bool mirror = false;
	if ((st = drv_cfg_choice(host, DRV, "stream", sensors, 4, &which, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "width", 1, 16384, &s.width, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "height", 1, 16384, &s.height, err, errlen)) ||
	    (st = drv_cfg_double(host, DRV, "fps", 1, 1000, &s.fps, err, errlen)) ||
	    (st = drv_cfg_bool(host, DRV, "mirror", &mirror, err, errlen)) ||
	    (st = drv_cfg_bool(host, DRV, "registration", &s.registration, err, errlen)) ||
	    (st = drv_cfg_bool(host, DRV, "loop", &s.loop, err, errlen)) ||
	    (st = drv_cfg_double(host, DRV, "speed", 0, 100, &s.speed, err, errlen)))
		return st;
	s.sensor = types[which];
	s.sensor_name = sensors[which];
	s.mirror = mirror;
	s.mirror_set = drv_cfg_str(host, "mirror") != nullptr;
	s.speed_set = drv_cfg_str(host, "speed") != nullptr;
	if ((s.width == 0) != (s.height == 0))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": config keys 'width' and 'height' go together");
	return MDRV_OK;
}

/* Without a `device` key: the only device there is. */
int default_uri(Settings &s, char *err, size_t errlen)
{
	if (!s.uri.empty())
		return MDRV_OK;
	Array<DeviceInfo> list;
	OpenNI::enumerateDevices(&list);
	if (list.getSize() == 0)
		return drv_errf(err, errlen, MDRV_ERR_NODEV,
				DRV ": no OpenNI2 device found (is it plugged in, and readable by this user?); set "
				    "'device' to a device URI or an .oni recording");
	if (list.getSize() > 1)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": %d OpenNI2 devices found; set 'device' to one of their URIs (mocapd probe)",
				list.getSize());
	s.uri = list[0].getUri();
	return MDRV_OK;
}

/* Picks the sensor's video mode that matches the config, preferring the
 * current one and formats mocapd takes. */
int choose_mode(Camera &c, const SensorInfo &info, VideoMode &out, char *err, size_t errlen)
{
	const Array<VideoMode> &modes = info.getSupportedVideoModes();
	VideoMode current = c.stream.getVideoMode();
	auto matches = [&](const VideoMode &m) {
		unsigned bpp;
		return to_mocap(m.getPixelFormat(), &bpp) != MC_PIXFMT_NONE &&
		       (!c.cfg.width || ((unsigned)m.getResolutionX() == c.cfg.width &&
					 (unsigned)m.getResolutionY() == c.cfg.height)) &&
		       (c.cfg.fps <= 0 || std::abs(m.getFps() - c.cfg.fps) < 0.5);
	};
	if (matches(current)) {
		out = current;
		return MDRV_OK;
	}
	for (int i = 0; i < modes.getSize(); i++) {
		if (matches(modes[i])) {
			out = modes[i];
			return MDRV_OK;
		}
	}
	std::string list;
	for (int i = 0; i < modes.getSize(); i++) {
		char m[64];
		snprintf(m, sizeof m, "%s%dx%d@%d %s", i ? ", " : "", modes[i].getResolutionX(),
			 modes[i].getResolutionY(), modes[i].getFps(), oni_format_name(modes[i].getPixelFormat()));
		list += m;
	}
	return drv_errf(err, errlen, MDRV_ERR_FORMAT,
			DRV ": '%s' %s: no mode matches%s%s (modes: %s; mocapd takes DEPTH_1_MM, RGB888, YUYV, "
			    "GRAY8)",
			c.cfg.uri.c_str(), c.cfg.sensor_name, c.cfg.width ? " the configured size" : "",
			c.cfg.fps > 0 ? " and fps" : "", list.empty() ? "none" : list.c_str());
}

int setup_playback(Camera &c, char *err, size_t errlen)
{
	PlaybackControl *pc = c.shared->device.getPlaybackControl();
	c.playback = pc != nullptr;
	if (!c.playback) {
		if (c.cfg.speed_set || c.cfg.loop)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG,
					DRV ": config keys 'speed' and 'loop' apply to .oni recordings only");
		return MDRV_OK;
	}
	pc->setRepeatEnabled(c.cfg.loop);
	pc->setSpeed(c.cfg.speed > 0 ? (float)c.cfg.speed : 0.0f); /* 0: as fast as it reads */
	c.n_frames = pc->getNumberOfFrames(c.stream);
	return MDRV_OK;
}

int open_stream(Camera &c, char *err, size_t errlen)
{
	const char *uri = c.cfg.uri.c_str();
	Device &dev = c.shared->device;
	if (!dev.hasSensor(c.cfg.sensor))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": device '%s' has no %s sensor", uri,
				c.cfg.sensor_name);
	if (c.stream.create(dev, c.cfg.sensor) != STATUS_OK)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": '%s': cannot create the %s stream: %s", uri,
				c.cfg.sensor_name, oni_error().c_str());
	c.created = true;
	VideoMode mode;
	int st = choose_mode(c, *dev.getSensorInfo(c.cfg.sensor), mode, err, errlen);
	if (st)
		return st;
	VideoMode cur = c.stream.getVideoMode();
	bool same = cur.getPixelFormat() == mode.getPixelFormat() && cur.getResolutionX() == mode.getResolutionX() &&
		    cur.getResolutionY() == mode.getResolutionY() && cur.getFps() == mode.getFps();
	if (!same && c.stream.setVideoMode(mode) != STATUS_OK)
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, DRV ": '%s' %s: cannot set %dx%d@%d: %s", uri,
				c.cfg.sensor_name, mode.getResolutionX(), mode.getResolutionY(), mode.getFps(),
				oni_error().c_str());
	if (c.cfg.mirror_set && c.stream.setMirroringEnabled(c.cfg.mirror) != STATUS_OK)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": '%s' %s: config key 'mirror': not supported: %s",
				uri, c.cfg.sensor_name, oni_error().c_str());
	if (c.cfg.registration &&
	    dev.setImageRegistrationMode(IMAGE_REGISTRATION_DEPTH_TO_COLOR) != STATUS_OK)
		return drv_errf(err, errlen, MDRV_ERR_CONFIG,
				DRV ": '%s': config key 'registration': the device cannot align depth to colour", uri);
	if ((st = setup_playback(c, err, errlen)))
		return st;
	unsigned bpp;
	c.fmt.pixfmt = to_mocap(mode.getPixelFormat(), &bpp);
	c.fmt.width = (uint32_t)mode.getResolutionX();
	c.fmt.height = (uint32_t)mode.getResolutionY();
	c.fmt.stride = c.fmt.width * bpp;
	c.fmt.fps = mode.getFps();
	c.fmt.max_bytes = (size_t)c.fmt.stride * c.fmt.height;
	return MDRV_OK;
}

/* Device microseconds -> CLOCK_MONOTONIC nanoseconds (see the top). */
uint64_t map_timestamp(Camera &c, uint64_t device_us)
{
	uint64_t arrival = mc_now_ns();
	int64_t delay_offset = (int64_t)arrival - (int64_t)(device_us * 1000);
	/* a clock that went back (stream restarted, recording looped) starts
	 * a new mapping */
	if (!c.have_offset || device_us < c.last_device_us) {
		c.offset_ns = delay_offset;
		c.have_offset = true;
	} else {
		int64_t drift = (int64_t)((arrival - c.last_arrival_ns) / 10000); /* 100 ppm */
		c.offset_ns = std::min(c.offset_ns + drift, delay_offset);
	}
	c.last_arrival_ns = arrival;
	c.last_device_us = device_us;
	int64_t t = (int64_t)(device_us * 1000) + c.offset_ns;
	return t > 0 ? (uint64_t)t : arrival;
}

int next_frame(Camera &c, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	if (c.gone)
		return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": device '%s' was unplugged", c.cfg.uri.c_str());
	if (c.ended)
		return drv_errf(err, errlen, MDRV_ERR_END, DRV ": end of recording '%s'", c.cfg.uri.c_str());
	VideoStream *streams[1] = {&c.stream};
	int ready = -1;
	Status s = OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms > 0 ? timeout_ms : 0);
	if (s == STATUS_TIME_OUT)
		return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, DRV ": no frame within %d ms", timeout_ms);
	if (s != STATUS_OK)
		return drv_errf(err, errlen, c.gone ? MDRV_ERR_NODEV : MDRV_ERR_IO, DRV ": waiting for a frame: %s",
				oni_error().c_str());
	VideoFrameRef f;
	if (c.stream.readFrame(&f) != STATUS_OK || !f.isValid())
		return drv_errf(err, errlen, c.gone ? MDRV_ERR_NODEV : MDRV_ERR_IO, DRV ": reading a frame: %s",
				oni_error().c_str());
	size_t size = (size_t)f.getDataSize();
	if (size > slot->capacity)
		return drv_errf(err, errlen, MDRV_ERR_NOSPACE, DRV ": frame of %zu bytes, slot holds %zu", size,
				slot->capacity);
	unsigned bpp;
	mc_pixfmt pf = to_mocap(f.getVideoMode().getPixelFormat(), &bpp);
	memcpy(slot->data, f.getData(), size);
	slot->bytesused = size;
	slot->format = c.fmt;
	slot->format.pixfmt = pf;
	slot->format.width = (uint32_t)f.getWidth();
	slot->format.height = (uint32_t)f.getHeight();
	slot->format.stride = (uint32_t)f.getStrideInBytes();
	slot->flags = size < (size_t)slot->format.stride * slot->format.height ? MDRV_FRAME_SHORT : 0;
	slot->timestamp_ns = map_timestamp(c, f.getTimestamp());
	slot->sequence = (uint64_t)f.getFrameIndex();
	if (c.playback && !c.cfg.loop && c.n_frames > 0 && f.getFrameIndex() >= c.n_frames)
		c.ended = true;
	return MDRV_OK;
}

/* ---- the C ABI ---- */

int openni2_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	try {
		int st = start_runtime(err, errlen);
		if (st)
			return st;
		Array<DeviceInfo> list;
		OpenNI::enumerateDevices(&list);
		int n = std::min(list.getSize(), max);
		for (int i = 0; i < n; i++) {
			memset(&out[i], 0, sizeof out[i]);
			drv_strlcpy(out[i].id, list[i].getUri(), sizeof out[i].id);
			std::string name = std::string(list[i].getVendor()) + " " + list[i].getName();
			drv_strlcpy(out[i].name, name.c_str(), sizeof out[i].name);
			char ids[16];
			snprintf(ids, sizeof ids, "%04x:%04x", list[i].getUsbVendorId() & 0xffff,
				 list[i].getUsbProductId() & 0xffff);
			std::string bus = std::string("usb ") + ids + " " + list[i].getUri();
			drv_strlcpy(out[i].bus_info, bus.c_str(), sizeof out[i].bus_info);
		}
		return n;
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

/* Appends the modes of one sensor in the formats the driver delivers,
 * one entry per size with its rates; returns the new count. */
int add_sensor_modes(Device &dev, SensorType type, const char *stream, mdrv_mode *out, int n, int max)
{
	const SensorInfo *info = dev.getSensorInfo(type);
	if (!info)
		return n;
	const Array<VideoMode> &modes = info->getSupportedVideoModes();
	for (int i = 0; i < modes.getSize(); i++) {
		unsigned bpp;
		mc_pixfmt fmt = to_mocap(modes[i].getPixelFormat(), &bpp);
		if (fmt == MC_PIXFMT_NONE)
			continue;
		uint32_t w = (uint32_t)modes[i].getResolutionX(), h = (uint32_t)modes[i].getResolutionY();
		mdrv_mode *m = nullptr;
		for (int k = 0; k < n && !m; k++)
			if (!strcmp(out[k].pixel_format, stream) && out[k].width == w && out[k].height == h)
				m = &out[k];
		if (!m) {
			if (n >= max)
				continue;
			m = &out[n++];
			memset(m, 0, sizeof *m);
			drv_strlcpy(m->format_key, "stream", sizeof m->format_key);
			drv_strlcpy(m->pixel_format, stream, sizeof m->pixel_format);
			m->pixfmt = fmt;
			m->width = w;
			m->height = h;
		}
		double fps = modes[i].getFps();
		uint32_t k = 0;
		while (k < m->nfps && m->fps[k] != fps)
			k++;
		if (k < m->nfps || m->nfps >= MDRV_MODE_RATES)
			continue; /* listed once (several pixel formats at one rate) */
		for (k = m->nfps++; k > 0 && m->fps[k - 1] < fps; k--)
			m->fps[k] = m->fps[k - 1]; /* highest first */
		m->fps[k] = fps;
	}
	return n;
}

int openni2_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	try {
		int st = start_runtime(err, errlen);
		if (st)
			return st;
		SharedDevice *d = acquire_device(id, err, errlen);
		if (!d)
			return MDRV_ERR_NODEV;
		int n = add_sensor_modes(d->device, SENSOR_DEPTH, "depth", out, 0, max);
		n = add_sensor_modes(d->device, SENSOR_COLOR, "color", out, n, max);
		n = add_sensor_modes(d->device, SENSOR_IR, "ir", out, n, max);
		release_device(id);
		return n;
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

void *openni2_open(const mdrv_host *host, char *err, size_t errlen)
{
	try {
		auto c = std::make_unique<Camera>();
		c->host = *host;
		if (read_settings(host, c->cfg, err, errlen))
			return drv_open_failed(host, MDRV_ERR_CONFIG); /* the keys do not change by waiting */
		if (start_runtime(err, errlen) || default_uri(c->cfg, err, errlen))
			return nullptr;
		c->shared = acquire_device(c->cfg.uri, err, errlen);
		if (!c->shared || open_stream(*c, err, errlen))
			return nullptr;
		c->listener = std::make_unique<Disconnects>(c.get());
		OpenNI::addDeviceDisconnectedListener(c->listener.get());
		drv_logf(host, MDRV_LOG_INFO, DRV ": opened '%s' %s: %s %ux%u, %g fps%s", c->cfg.uri.c_str(),
			 c->cfg.sensor_name, mc_pixfmt_name(c->fmt.pixfmt), c->fmt.width, c->fmt.height,
			 c->fmt.fps, c->playback ? " (recording)" : "");
		return c.release();
	} catch (const std::exception &e) {
		drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
		return nullptr;
	}
}

int openni2_get_format(void *dev, mdrv_format *fmt, char *, size_t)
{
	*fmt = static_cast<Camera *>(dev)->fmt;
	return MDRV_OK;
}

int openni2_start(void *dev, char *err, size_t errlen)
{
	Camera &c = *static_cast<Camera *>(dev);
	if (c.running)
		return MDRV_OK;
	if (c.stream.start() != STATUS_OK)
		return drv_errf(err, errlen, c.gone ? MDRV_ERR_NODEV : MDRV_ERR_IO, DRV ": '%s': cannot start: %s",
				c.cfg.uri.c_str(), oni_error().c_str());
	c.running = true;
	c.have_offset = false; /* the device clock may restart with the stream */
	return MDRV_OK;
}

int openni2_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	Camera &c = *static_cast<Camera *>(dev);
	if (!c.running)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": next_frame before start");
	try {
		return next_frame(c, slot, timeout_ms, err, errlen);
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

void openni2_stop(void *dev)
{
	Camera &c = *static_cast<Camera *>(dev);
	if (!c.running)
		return;
	c.stream.stop();
	usleep(100000); /* see ~Camera */
	c.running = false;
}

void openni2_close(void *dev)
{
	try {
		delete static_cast<Camera *>(dev);
	} catch (...) {
	}
}

/* The keys, read as open() reads them; the OpenNI runtime is not started. */
int openni2_check(const mdrv_host *host, char *err, size_t errlen)
{
	try {
		Settings s;
		return read_settings(host, s, err, errlen);
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

} /* namespace */

MDRV_DEFINE_DRIVER_MODES(openni2, "openni2",
		   "OpenNI2 depth cameras (depth as DEPTH16 millimetres, colour, IR) and .oni recordings")
