/* mocap-driver-libcamera: cameras through libcamera's C++ API, behind the C
 * plugin ABI.  C++ stays in this file; no exception crosses the ABI.
 *
 * libcamera allows one CameraManager per process, so the plugin keeps one,
 * shared by every camera it opens and stopped when the last one closes.
 * Completed requests arrive on libcamera's own thread; next_frame() waits
 * for them on a condition variable, copies the frame out of the
 * memory-mapped buffer and queues the request again.
 *
 * Timestamps are FrameMetadata::timestamp, which libcamera copies from the
 * V4L2 buffer: CLOCK_MONOTONIC.  A camera that is unplugged emits
 * Camera::disconnected; next_frame() then returns MDRV_ERR_NODEV.
 * Config keys are listed in docs/DRIVERS.md. */
#include <libcamera/libcamera.h>
#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <ostream>
#include <streambuf>
#include <string>
#include <vector>

extern "C" {
#include "drv_common.h"
#include "mdrv.h"
}

using namespace libcamera;

#define DRV "libcamera"

namespace {

/* ---- libcamera's log ----
 * libcamera prints INFO lines with colour codes on stderr.  Its log goes
 * through this stream instead, which keeps warnings and errors, as plain
 * lines prefixed "libcamera: ", and drops the rest. */
class LogFilter : public std::streambuf
{
	std::string line;

	int overflow(int c) override
	{
		if (c == '\n') {
			bool keep = line.find(" WARN ") != std::string::npos ||
				    line.find(" ERROR ") != std::string::npos ||
				    line.find(" FATAL ") != std::string::npos;
			if (keep) {
				/* drop "[time] [thread] " in front */
				size_t at = line.find("] ", line.find("] ") + 2);
				fprintf(stderr, "libcamera: %s\n",
					line.c_str() + (at == std::string::npos ? 0 : at + 2));
			}
			line.clear();
		} else if (c != EOF) {
			line += (char)c;
		}
		return c;
	}
};

void route_log()
{
	/* allocated once and never freed: libcamera may log while the
	 * process exits, after this plugin's static objects are gone */
	static std::ostream *stream = new std::ostream(new LogFilter);
	if (!getenv("LIBCAMERA_LOG_LEVELS") && !getenv("LIBCAMERA_LOG_FILE"))
		logSetStream(stream, false);
}

/* ---- the process-wide CameraManager ---- */

std::mutex manager_lock;
std::unique_ptr<CameraManager> manager;
int manager_users;

/* Starts the shared manager (or takes another reference); nullptr with err. */
CameraManager *acquire_manager(char *err, size_t errlen)
{
	std::lock_guard<std::mutex> g(manager_lock);
	if (!manager) {
		route_log();
		auto m = std::make_unique<CameraManager>();
		int r = m->start();
		if (r < 0) {
			drv_errf(err, errlen, MDRV_ERR_IO, DRV ": cannot start the camera manager: %s", strerror(-r));
			return nullptr;
		}
		manager = std::move(m);
	}
	manager_users++;
	return manager.get();
}

void release_manager()
{
	std::lock_guard<std::mutex> g(manager_lock);
	if (--manager_users == 0) {
		manager->stop();
		manager.reset();
	}
}

/* ---- formats ---- */

struct FormatMap {
	const char *name;
	PixelFormat pixel_format;
	mc_pixfmt fmt;
	unsigned bytes_per_pixel; /* 0 = compressed */
};

const FormatMap format_map[] = {
	{"YUYV", formats::YUYV, MC_PIXFMT_YUYV, 2},
	{"MJPEG", formats::MJPEG, MC_PIXFMT_MJPEG, 0},
	{"GREY", formats::R8, MC_PIXFMT_GRAY8, 1},
	/* DRM's BGR888 is R, G, B bytes in memory: mocapd's RGB24 */
	{"RGB24", formats::BGR888, MC_PIXFMT_RGB24, 3},
};

const FormatMap *find_format(const PixelFormat &pf)
{
	for (const auto &f : format_map)
		if (f.pixel_format == pf)
			return &f;
	return nullptr;
}

std::string list_cameras(CameraManager *cm)
{
	std::string s;
	for (const auto &cam : cm->cameras())
		s += (s.empty() ? "" : ", ") + cam->id();
	return s.empty() ? "none" : s;
}

/* ---- one open camera ---- */

struct Settings {
	std::string id;
	int format = -1; /* index into format_map, -1 = the camera's default */
	unsigned width = 0, height = 0, buffers = 4;
	double fps = 0;
	drv_auto_value exposure{}, gain{}, white_balance{};
};

struct MappedBuffer {
	void *addr = MAP_FAILED;
	size_t length = 0;
	size_t offset = 0; /* of the first plane within the mapping */
};

class Device
{
public:
	mdrv_host host{};
	Settings cfg;
	CameraManager *cm = nullptr;
	std::shared_ptr<Camera> camera;
	bool acquired = false;
	std::unique_ptr<CameraConfiguration> config;
	Stream *stream = nullptr;
	std::unique_ptr<FrameBufferAllocator> allocator;
	std::vector<std::unique_ptr<Request>> requests;
	std::map<const FrameBuffer *, MappedBuffer> maps;
	mdrv_format fmt{};
	bool running = false;

	std::mutex lock; /* guards done and disconnected */
	std::condition_variable cv;
	std::deque<Request *> done;
	bool disconnected = false;

	~Device() { teardown(); }

	void on_request_completed(Request *r)
	{
		std::lock_guard<std::mutex> g(lock);
		done.push_back(r);
		cv.notify_one();
	}

	void on_disconnected()
	{
		std::lock_guard<std::mutex> g(lock);
		disconnected = true;
		cv.notify_one();
	}

	void unmap_all()
	{
		for (auto &m : maps)
			if (m.second.addr != MAP_FAILED)
				munmap(m.second.addr, m.second.length);
		maps.clear();
	}

	void stop_stream()
	{
		if (running && !disconnected)
			camera->stop();
		running = false;
		requests.clear();
		unmap_all();
		if (allocator && stream)
			allocator->free(stream);
		std::lock_guard<std::mutex> g(lock);
		done.clear();
	}

	void teardown()
	{
		stop_stream();
		allocator.reset();
		if (camera) {
			camera->requestCompleted.disconnect(this);
			camera->disconnected.disconnect(this);
			if (acquired)
				camera->release();
			camera.reset();
		}
		if (cm)
			release_manager();
		cm = nullptr;
	}
};

int read_settings(const mdrv_host *host, Settings &s, char *err, size_t errlen)
{
	const char *const names[] = {"YUYV", "MJPEG", "GREY", "RGB24"};
	int st;
	const char *dev = drv_cfg_str(host, "device");
	if (dev)
		s.id = dev;
	if ((st = drv_cfg_choice(host, DRV, "pixel_format", names, 4, &s.format, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "width", 1, 16384, &s.width, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "height", 1, 16384, &s.height, err, errlen)) ||
	    (st = drv_cfg_double(host, DRV, "fps", 0.01, 10000, &s.fps, err, errlen)) ||
	    (st = drv_cfg_uint(host, DRV, "buffers", 2, 32, &s.buffers, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, DRV, "exposure", 1e-6, 100, &s.exposure, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, DRV, "gain", 1, 1000, &s.gain, err, errlen)) ||
	    (st = drv_cfg_auto_double(host, DRV, "white_balance", 1000, 20000, &s.white_balance, err, errlen)))
		return st;
	if ((s.width == 0) != (s.height == 0))
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": config keys 'width' and 'height' go together");
	return MDRV_OK;
}

int select_camera(Device &d, char *err, size_t errlen)
{
	auto cams = d.cm->cameras();
	if (d.cfg.id.empty()) {
		if (cams.size() != 1)
			return drv_errf(err, errlen, cams.empty() ? MDRV_ERR_NODEV : MDRV_ERR_CONFIG,
					DRV ": %s; set 'device' to one of: %s",
					cams.empty() ? "no camera found" : "several cameras found",
					list_cameras(d.cm).c_str());
		d.camera = cams[0];
	} else {
		d.camera = d.cm->get(d.cfg.id);
		if (!d.camera)
			return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": no camera '%s' (found: %s)",
					d.cfg.id.c_str(), list_cameras(d.cm).c_str());
	}
	if (d.camera->acquire() < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": camera '%s' is in use by another program",
				d.camera->id().c_str());
	d.acquired = true;
	return MDRV_OK;
}

int configure(Device &d, char *err, size_t errlen)
{
	const char *id = d.camera->id().c_str();
	d.config = d.camera->generateConfiguration({StreamRole::VideoRecording});
	if (!d.config || d.config->empty())
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, DRV ": camera '%s' offers no video stream", id);
	StreamConfiguration &sc = d.config->at(0);
	if (d.cfg.format >= 0)
		sc.pixelFormat = format_map[d.cfg.format].pixel_format;
	if (d.cfg.width)
		sc.size = Size(d.cfg.width, d.cfg.height);
	sc.bufferCount = d.cfg.buffers;
	CameraConfiguration::Status status = d.config->validate();
	if (status == CameraConfiguration::Invalid)
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, DRV ": camera '%s' rejects %s", id,
				sc.toString().c_str());
	const FormatMap *fm = find_format(sc.pixelFormat);
	bool wrong_format = !fm || (d.cfg.format >= 0 && fm != &format_map[d.cfg.format]);
	bool wrong_size = d.cfg.width && (sc.size.width != d.cfg.width || sc.size.height != d.cfg.height);
	if (wrong_format || wrong_size) {
		std::string offered;
		for (const PixelFormat &pf : sc.formats().pixelformats()) {
			offered += (offered.empty() ? "" : "; ") + pf.toString();
			for (const Size &sz : sc.formats().sizes(pf))
				offered += " " + sz.toString();
		}
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, DRV ": camera '%s' gives %s instead; it offers %s", id,
				sc.toString().c_str(), offered.c_str());
	}
	if (d.camera->configure(d.config.get()) < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": camera '%s': configure failed", id);
	d.stream = sc.stream();
	d.fmt.pixfmt = fm->fmt;
	d.fmt.width = sc.size.width;
	d.fmt.height = sc.size.height;
	d.fmt.stride = fm->bytes_per_pixel ? sc.stride : 0;
	d.fmt.max_bytes = sc.frameSize ? sc.frameSize : (size_t)sc.stride * sc.size.height;
	d.fmt.fps = d.cfg.fps;
	return MDRV_OK;
}

/* The controls the config asks for, applied when streaming starts. */
int start_controls(Device &d, ControlList &c, char *err, size_t errlen)
{
	const ControlInfoMap &info = d.camera->controls();
	auto need = [&](const ControlId &id, const char *key) -> int {
		if (info.find(&id) != info.end())
			return MDRV_OK;
		return drv_errf(err, errlen, MDRV_ERR_CONFIG, DRV ": camera '%s': config key '%s': not supported",
				d.camera->id().c_str(), key);
	};
	int st;
	if (d.cfg.exposure.present) {
		if ((st = need(controls::AeEnable, "exposure")))
			return st;
		c.set(controls::AeEnable, d.cfg.exposure.is_auto);
		if (!d.cfg.exposure.is_auto) {
			if ((st = need(controls::ExposureTime, "exposure")))
				return st;
			c.set(controls::ExposureTime, (int32_t)std::lround(d.cfg.exposure.value * 1e6));
		}
	}
	if (d.cfg.gain.present && !d.cfg.gain.is_auto) {
		if ((st = need(controls::AnalogueGain, "gain")))
			return st;
		c.set(controls::AnalogueGain, (float)d.cfg.gain.value);
	}
	if (d.cfg.white_balance.present) {
		if (!d.cfg.white_balance.is_auto)
			return drv_errf(err, errlen, MDRV_ERR_CONFIG,
					DRV ": config key 'white_balance': only 'auto' is supported by this driver");
		if ((st = need(controls::AwbEnable, "white_balance")))
			return st;
		c.set(controls::AwbEnable, true);
	}
	if (d.cfg.fps > 0) {
		if ((st = need(controls::FrameDurationLimits, "fps")))
			return st;
		int64_t us = std::llround(1e6 / d.cfg.fps);
		int64_t limits[2] = {us, us};
		c.set(controls::FrameDurationLimits, Span<const int64_t, 2>(limits));
	}
	return MDRV_OK;
}

/* Maps every buffer's planes (one dmabuf, possibly at an offset). */
int map_buffers(Device &d, char *err, size_t errlen)
{
	for (const auto &buf : d.allocator->buffers(d.stream)) {
		const FrameBuffer::Plane &p0 = buf->planes()[0];
		size_t end = 0;
		for (const auto &p : buf->planes())
			if (p.fd.get() == p0.fd.get())
				end = std::max(end, (size_t)p.offset + p.length);
		MappedBuffer m;
		m.length = end;
		m.offset = p0.offset;
		m.addr = mmap(nullptr, end, PROT_READ, MAP_SHARED, p0.fd.get(), 0);
		if (m.addr == MAP_FAILED)
			return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": mapping a frame buffer: %s", strerror(errno));
		d.maps[buf.get()] = m;
	}
	return MDRV_OK;
}

int start(Device &d, char *err, size_t errlen)
{
	if (d.running)
		return MDRV_OK;
	d.allocator = std::make_unique<FrameBufferAllocator>(d.camera);
	if (d.allocator->allocate(d.stream) < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": cannot allocate frame buffers");
	int st = map_buffers(d, err, errlen);
	if (st)
		return st;
	for (const auto &buf : d.allocator->buffers(d.stream)) {
		std::unique_ptr<Request> r = d.camera->createRequest();
		if (!r || r->addBuffer(d.stream, buf.get()) < 0)
			return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": cannot create a capture request");
		d.requests.push_back(std::move(r));
	}
	ControlList ctrls(controls::controls);
	if ((st = start_controls(d, ctrls, err, errlen)))
		return st;
	if (d.camera->start(&ctrls) < 0)
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": camera '%s' does not start", d.camera->id().c_str());
	d.running = true;
	for (auto &r : d.requests)
		d.camera->queueRequest(r.get());
	return MDRV_OK;
}

int next_frame(Device &d, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	Request *r = nullptr;
	{
		std::unique_lock<std::mutex> g(d.lock);
		d.cv.wait_for(g, std::chrono::milliseconds(timeout_ms > 0 ? timeout_ms : 0),
			      [&] { return !d.done.empty() || d.disconnected; });
		if (d.disconnected)
			return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": camera '%s' was unplugged",
					d.camera->id().c_str());
		if (d.done.empty())
			return drv_errf(err, errlen, MDRV_ERR_TIMEOUT, DRV ": no frame within %d ms", timeout_ms);
		r = d.done.front();
		d.done.pop_front();
	}
	int status = MDRV_OK;
	if (r->status() == Request::RequestCancelled) {
		status = drv_errf(err, errlen, MDRV_ERR_IO, DRV ": capture request cancelled");
	} else {
		FrameBuffer *buf = r->buffers().begin()->second;
		const FrameMetadata &md = buf->metadata();
		const MappedBuffer &m = d.maps[buf];
		size_t used = 0;
		for (const auto &p : md.planes())
			used += p.bytesused;
		used = std::min(used, m.length - m.offset);
		if (used > slot->capacity) {
			status = drv_errf(err, errlen, MDRV_ERR_NOSPACE, DRV ": frame of %zu bytes, slot holds %zu",
					  used, slot->capacity);
		} else {
			memcpy(slot->data, (const uint8_t *)m.addr + m.offset, used);
			slot->bytesused = used;
			slot->format = d.fmt;
			slot->flags = md.status == FrameMetadata::FrameSuccess ? 0 : MDRV_FRAME_CORRUPT;
			if (d.fmt.stride && used < (size_t)d.fmt.stride * d.fmt.height)
				slot->flags |= MDRV_FRAME_SHORT;
			slot->timestamp_ns = md.timestamp ? md.timestamp : mc_now_ns();
			slot->sequence = md.sequence;
		}
	}
	r->reuse(Request::ReuseBuffers);
	if (d.running)
		d.camera->queueRequest(r);
	return status;
}

/* ---- the C ABI ---- */

int libcamera_probe(const mdrv_host *host, mdrv_device_info *out, int max, char *err, size_t errlen)
{
	(void)host;
	try {
		CameraManager *cm = acquire_manager(err, errlen);
		if (!cm)
			return MDRV_ERR_IO;
		int n = 0;
		for (const auto &cam : cm->cameras()) {
			if (n >= max)
				break;
			mdrv_device_info &o = out[n++];
			memset(&o, 0, sizeof o);
			drv_strlcpy(o.id, cam->id().c_str(), sizeof o.id);
			const auto model = cam->properties().get(properties::Model);
			drv_strlcpy(o.name, model ? model->c_str() : "camera", sizeof o.name);
			drv_strlcpy(o.bus_info, cam->id().c_str(), sizeof o.bus_info);
		}
		release_manager();
		return n;
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

/* The camera's frame duration limits as a rate range into m (0, 0 if it
 * has no such control). */
static void rate_range(const Camera &cam, mdrv_mode &m)
{
	auto it = cam.controls().find(&controls::FrameDurationLimits);
	if (it == cam.controls().end())
		return;
	int64_t shortest = it->second.min().get<int64_t>(), longest = it->second.max().get<int64_t>();
	if (shortest > 0 && longest >= shortest) {
		m.fps_min = 1e6 / (double)longest;
		m.fps_max = 1e6 / (double)shortest;
	}
}

/* Fills out from camera `id`'s video configuration, without acquiring it. */
static int list_modes(CameraManager *cm, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	std::shared_ptr<Camera> cam = cm->get(id);
	if (!cam)
		return drv_errf(err, errlen, MDRV_ERR_NODEV, DRV ": no camera '%s' (found: %s)", id,
				list_cameras(cm).c_str());
	std::unique_ptr<CameraConfiguration> cfg = cam->generateConfiguration({StreamRole::VideoRecording});
	if (!cfg || cfg->empty())
		return drv_errf(err, errlen, MDRV_ERR_FORMAT, DRV ": camera '%s' offers no video stream", id);
	const StreamFormats &formats = cfg->at(0).formats();
	int n = 0;
	for (const PixelFormat &pf : formats.pixelformats()) {
		const FormatMap *fm = find_format(pf);
		for (const Size &sz : formats.sizes(pf)) {
			if (!fm || n >= max)
				break;
			mdrv_mode &m = out[n++];
			memset(&m, 0, sizeof m);
			drv_strlcpy(m.pixel_format, fm->name, sizeof m.pixel_format);
			m.pixfmt = fm->fmt;
			m.width = sz.width;
			m.height = sz.height;
			rate_range(*cam, m);
		}
	}
	return n;
}

int libcamera_modes(const mdrv_host *host, const char *id, mdrv_mode *out, int max, char *err, size_t errlen)
{
	(void)host;
	try {
		CameraManager *cm = acquire_manager(err, errlen);
		if (!cm)
			return MDRV_ERR_IO;
		int n = list_modes(cm, id, out, max, err, errlen);
		release_manager();
		return n;
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

void *libcamera_open(const mdrv_host *host, char *err, size_t errlen)
{
	try {
		auto d = std::make_unique<Device>();
		d->host = *host;
		if (read_settings(host, d->cfg, err, errlen))
			return drv_open_failed(host, MDRV_ERR_CONFIG); /* the keys do not change by waiting */
		d->cm = acquire_manager(err, errlen);
		if (!d->cm || select_camera(*d, err, errlen) || configure(*d, err, errlen))
			return nullptr;
		d->camera->requestCompleted.connect(d.get(), &Device::on_request_completed);
		d->camera->disconnected.connect(d.get(), &Device::on_disconnected);
		drv_logf(host, MDRV_LOG_INFO, DRV ": opened '%s': %s", d->camera->id().c_str(),
			 d->config->at(0).toString().c_str());
		return d.release();
	} catch (const std::exception &e) {
		drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
		return nullptr;
	}
}

int libcamera_get_format(void *dev, mdrv_format *fmt, char *, size_t)
{
	*fmt = static_cast<Device *>(dev)->fmt;
	return MDRV_OK;
}

int libcamera_start(void *dev, char *err, size_t errlen)
{
	Device &d = *static_cast<Device *>(dev);
	try {
		int st = start(d, err, errlen);
		if (st)
			d.stop_stream();
		return st;
	} catch (const std::exception &e) {
		d.stop_stream();
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

int libcamera_next_frame(void *dev, mdrv_frame *slot, int timeout_ms, char *err, size_t errlen)
{
	try {
		Device &d = *static_cast<Device *>(dev);
		if (!d.running)
			return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": next_frame before start");
		return next_frame(d, slot, timeout_ms, err, errlen);
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

void libcamera_stop(void *dev)
{
	try {
		static_cast<Device *>(dev)->stop_stream();
	} catch (...) {
	}
}

void libcamera_close(void *dev)
{
	try {
		delete static_cast<Device *>(dev);
	} catch (...) {
	}
}

/* The keys, read as open() reads them; no camera manager is started. */
int libcamera_check(const mdrv_host *host, char *err, size_t errlen)
{
	try {
		Settings s;
		return read_settings(host, s, err, errlen);
	} catch (const std::exception &e) {
		return drv_errf(err, errlen, MDRV_ERR_IO, DRV ": %s", e.what());
	}
}

} /* namespace */

MDRV_DEFINE_DRIVER_MODES(libcamera, "libcamera",
		   "cameras through libcamera (UVC, Raspberry Pi, IPU3, RkISP1, simple pipelines)")
