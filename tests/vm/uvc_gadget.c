/* uvc_gadget: a USB Video Class camera made of software, for the driver tests
 * in the qemu VM.  It runs on the device side of the kernel's dummy_hcd
 * (a USB host and device controller pair in one machine) through gadgetfs,
 * so the guest's real uvcvideo driver sees a real USB camera: enumeration,
 * string descriptors with a serial number, probe/commit negotiation and
 * bulk streaming.  dummy_hcd has no isochronous endpoints, so the camera
 * streams over bulk, as many real UVC cameras do.
 *
 * Formats: MJPEG (format 1) and YUYV (format 2), 320x240, at 30 or 15 fps.
 * YUYV frames carry a pattern the test checks: Y = (x + y + n) mod 256 on
 * frame n, U = V = 128.  MJPEG frames are the same picture compressed with
 * libturbojpeg.
 *
 * Plugging: SIGUSR1 unplugs (closes gadgetfs, the host sees a disconnect),
 * SIGUSR2 plugs it in again; SIGTERM ends the program.
 *
 * Usage: uvc_gadget [SERIAL]   (default MOCAPUVC01; gadgetfs must be mounted
 * at /dev/gadget) */
#include "base/mc_time.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/usb/ch9.h>
#include <linux/usb/gadgetfs.h>
#include <linux/usb/video.h>
#include <pthread.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <turbojpeg.h>
#include <unistd.h>

#define GADGET_DIR "/dev/gadget"
#define EP_IN_NAME "ep1in-bulk"
#define WIDTH 320
#define HEIGHT 240
#define YUYV_SIZE (WIDTH * HEIGHT * 2)
#define HEADER 2 /* UVC payload header: length, flags */
#define MAX_PAYLOAD (YUYV_SIZE + HEADER)
#define INTERVAL_30 333333u /* 100 ns units */
#define INTERVAL_15 666666u

enum { FORMAT_MJPEG = 1, FORMAT_YUYV = 2 };

static const char *serial = "MOCAPUVC01";
static volatile sig_atomic_t want_unplug, want_plug, want_exit;

/* ---- descriptors ---- */

static void put16(uint8_t *p, unsigned v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
}

static void put32(uint8_t *p, uint32_t v)
{
	put16(p, v & 0xffff);
	put16(p + 2, v >> 16);
}

/* A frame descriptor (MJPEG or uncompressed) with two discrete intervals. */
static size_t frame_desc(uint8_t *p, uint8_t subtype)
{
	memset(p, 0, 34);
	p[0] = 34;
	p[1] = USB_DT_CS_INTERFACE;
	p[2] = subtype;
	p[3] = 1; /* bFrameIndex */
	p[4] = 0; /* bmCapabilities */
	put16(p + 5, WIDTH);
	put16(p + 7, HEIGHT);
	put32(p + 9, YUYV_SIZE * 8 * 15);   /* dwMinBitRate */
	put32(p + 13, YUYV_SIZE * 8 * 30);  /* dwMaxBitRate */
	put32(p + 17, YUYV_SIZE);           /* dwMaxVideoFrameBufferSize */
	put32(p + 21, INTERVAL_30);         /* dwDefaultFrameInterval */
	p[25] = 2;                          /* bFrameIntervalType: discrete */
	put32(p + 26, INTERVAL_30);
	put32(p + 30, INTERVAL_15);
	return 34;
}

/* The whole configuration for one speed; returns its length. */
static size_t config_desc(uint8_t *buf, unsigned maxpacket)
{
	uint8_t *p = buf;
	uint8_t *cfg = p;
	*p++ = USB_DT_CONFIG_SIZE, *p++ = USB_DT_CONFIG;
	p += 2; /* wTotalLength, below */
	*p++ = 2, *p++ = 1, *p++ = 0, *p++ = USB_CONFIG_ATT_ONE, *p++ = 50;

	/* interface association: video function of interfaces 0 and 1 */
	*p++ = 8, *p++ = USB_DT_INTERFACE_ASSOCIATION, *p++ = 0, *p++ = 2;
	*p++ = USB_CLASS_VIDEO, *p++ = UVC_SC_VIDEO_INTERFACE_COLLECTION, *p++ = 0, *p++ = 0;

	/* video control interface */
	*p++ = USB_DT_INTERFACE_SIZE, *p++ = USB_DT_INTERFACE, *p++ = 0, *p++ = 0, *p++ = 0;
	*p++ = USB_CLASS_VIDEO, *p++ = UVC_SC_VIDEOCONTROL, *p++ = 0, *p++ = 0;
	uint8_t *vc = p;
	*p++ = 13, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VC_HEADER;
	put16(p, 0x0110), p += 2; /* bcdUVC 1.1 */
	p += 2;                   /* wTotalLength, below */
	put32(p, 48000000), p += 4;
	*p++ = 1, *p++ = 1; /* one streaming interface: 1 */
	/* camera terminal (id 1), no controls */
	*p++ = 18, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VC_INPUT_TERMINAL, *p++ = 1;
	put16(p, UVC_ITT_CAMERA), p += 2;
	*p++ = 0, *p++ = 0;
	memset(p, 0, 6), p += 6; /* focal lengths */
	*p++ = 3, *p++ = 0, *p++ = 0, *p++ = 0;
	/* output terminal (id 2) fed by the camera */
	*p++ = 9, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VC_OUTPUT_TERMINAL, *p++ = 2;
	put16(p, UVC_TT_STREAMING), p += 2;
	*p++ = 0, *p++ = 1, *p++ = 0;
	put16(vc + 5, (unsigned)(p - vc));

	/* video streaming interface with one bulk endpoint */
	*p++ = USB_DT_INTERFACE_SIZE, *p++ = USB_DT_INTERFACE, *p++ = 1, *p++ = 0, *p++ = 1;
	*p++ = USB_CLASS_VIDEO, *p++ = UVC_SC_VIDEOSTREAMING, *p++ = 0, *p++ = 0;
	uint8_t *vs = p;
	*p++ = 15, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VS_INPUT_HEADER, *p++ = 2;
	p += 2; /* wTotalLength, below */
	*p++ = USB_DIR_IN | 1, *p++ = 0, *p++ = 2, *p++ = 0, *p++ = 0, *p++ = 0, *p++ = 1, *p++ = 0, *p++ = 0;
	/* format 1: MJPEG */
	*p++ = 11, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VS_FORMAT_MJPEG, *p++ = FORMAT_MJPEG, *p++ = 1;
	*p++ = 0, *p++ = 1, *p++ = 0, *p++ = 0, *p++ = 0, *p++ = 0;
	p += frame_desc(p, UVC_VS_FRAME_MJPEG);
	/* format 2: uncompressed YUY2 */
	static const uint8_t yuy2[16] = {'Y', 'U', 'Y', '2', 0x00, 0x00, 0x10, 0x00,
					 0x80, 0x00, 0x00, 0xaa, 0x00, 0x38, 0x9b, 0x71};
	*p++ = 27, *p++ = USB_DT_CS_INTERFACE, *p++ = UVC_VS_FORMAT_UNCOMPRESSED, *p++ = FORMAT_YUYV, *p++ = 1;
	memcpy(p, yuy2, 16), p += 16;
	*p++ = 16, *p++ = 1, *p++ = 0, *p++ = 0, *p++ = 0, *p++ = 0;
	p += frame_desc(p, UVC_VS_FRAME_UNCOMPRESSED);
	put16(vs + 4, (unsigned)(p - vs));
	/* the bulk IN endpoint */
	*p++ = USB_DT_ENDPOINT_SIZE, *p++ = USB_DT_ENDPOINT, *p++ = USB_DIR_IN | 1, *p++ = USB_ENDPOINT_XFER_BULK;
	put16(p, maxpacket), p += 2;
	*p++ = 0;

	put16(cfg + 2, (unsigned)(p - cfg));
	return (size_t)(p - buf);
}

static size_t device_desc(uint8_t *p)
{
	struct usb_device_descriptor d = {
		.bLength = USB_DT_DEVICE_SIZE,
		.bDescriptorType = USB_DT_DEVICE,
		.bcdUSB = 0x0200,
		.bDeviceClass = USB_CLASS_MISC, /* with an interface association */
		.bDeviceSubClass = 2,
		.bDeviceProtocol = 1,
		.bMaxPacketSize0 = 64,
		.idVendor = 0x1d6b,  /* Linux Foundation */
		.idProduct = 0x0102, /* its gadget ids */
		.bcdDevice = 0x0100,
		.iManufacturer = 1,
		.iProduct = 2,
		.iSerialNumber = 3,
		.bNumConfigurations = 1,
	};
	memcpy(p, &d, sizeof d);
	return sizeof d;
}

static void endpoint_desc(struct usb_endpoint_descriptor *d, unsigned maxpacket)
{
	memset(d, 0, sizeof *d);
	d->bLength = USB_DT_ENDPOINT_SIZE;
	d->bDescriptorType = USB_DT_ENDPOINT;
	d->bEndpointAddress = USB_DIR_IN | 1;
	d->bmAttributes = USB_ENDPOINT_XFER_BULK;
	d->wMaxPacketSize = (uint16_t)maxpacket;
}

/* String descriptor `index` in UTF-16LE; returns its length. */
static size_t string_desc(unsigned index, uint8_t *out)
{
	static const char *const strings[] = {NULL, "mocapd", "mocapd test UVC camera"};
	if (index == 0) {
		out[0] = 4, out[1] = USB_DT_STRING, out[2] = 0x09, out[3] = 0x04; /* en-US */
		return 4;
	}
	const char *s = index == 3 ? serial : index < 3 ? strings[index] : NULL;
	if (!s)
		return 0;
	size_t n = strlen(s);
	out[0] = (uint8_t)(2 + 2 * n), out[1] = USB_DT_STRING;
	for (size_t i = 0; i < n; i++)
		out[2 + 2 * i] = (uint8_t)s[i], out[3 + 2 * i] = 0;
	return 2 + 2 * n;
}

/* ---- state shared by the control loop and the writer ---- */

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t changed = PTHREAD_COND_INITIALIZER;
static int ep_in = -1;           /* the bulk endpoint, while configured */
static bool streaming;           /* committed and configured */
static unsigned generation;      /* bumped on every commit and disconnect */
static bool writing;             /* the writer is inside write() */
static struct uvc_streaming_control probe, commit;
static pthread_t writer;

static void fill_control(struct uvc_streaming_control *c)
{
	if (c->bFormatIndex != FORMAT_MJPEG && c->bFormatIndex != FORMAT_YUYV)
		c->bFormatIndex = FORMAT_YUYV;
	c->bFrameIndex = 1;
	if (c->dwFrameInterval != INTERVAL_15)
		c->dwFrameInterval = INTERVAL_30;
	c->dwMaxVideoFrameSize = YUYV_SIZE;
	c->dwMaxPayloadTransferSize = MAX_PAYLOAD;
	c->dwClockFrequency = 48000000;
	c->bmFramingInfo = 3;
	c->bPreferedVersion = 1;
	c->bMinVersion = 1;
	c->bMaxVersion = 1;
}

/* Interrupts a write blocked in the writer so that it sees new state. */
static void kick_writer(void)
{
	pthread_kill(writer, SIGURG);
}

/* ---- the writer thread: frames as bulk payloads ---- */

static void make_yuyv(uint8_t *f, unsigned n)
{
	for (unsigned y = 0; y < HEIGHT; y++)
		for (unsigned x = 0; x < WIDTH; x++) {
			uint8_t *p = f + (y * WIDTH + x) * 2;
			p[0] = (uint8_t)(x + y + n);
			p[1] = 128;
		}
}

/* Compresses the YUYV picture's luma as a greyscale JPEG into out. */
static size_t make_mjpeg(tjhandle tj, const uint8_t *yuyv, uint8_t *grey, uint8_t *out, size_t cap)
{
	for (unsigned i = 0; i < WIDTH * HEIGHT; i++)
		grey[i] = yuyv[2 * i];
	for (int quality = 90; quality > 10; quality--) {
		unsigned char *jpeg = out;
		unsigned long size = cap;
		if (tjCompress2(tj, grey, WIDTH, 0, HEIGHT, TJPF_GRAY, &jpeg, &size, TJSAMP_GRAY, quality,
				TJFLAG_NOREALLOC) != 0)
			return 0;
		/* a payload that fills its last packet exactly would need a
		 * zero-length packet gadgetfs does not send */
		if ((size + HEADER) % 512 != 0)
			return size;
	}
	return 0;
}

static void *writer_main(void *arg)
{
	(void)arg;
	tjhandle tj = tjInitCompress();
	static uint8_t yuyv[YUYV_SIZE], grey[WIDTH * HEIGHT], payload[MAX_PAYLOAD];
	unsigned n = 0, fid = 0;
	uint64_t next = mc_now_ns();
	for (;;) {
		pthread_mutex_lock(&lock);
		while (!streaming && !want_exit)
			pthread_cond_wait(&changed, &lock);
		if (want_exit) {
			pthread_mutex_unlock(&lock);
			break;
		}
		unsigned gen = generation;
		int fd = ep_in;
		int format = commit.bFormatIndex;
		uint64_t interval = (uint64_t)commit.dwFrameInterval * 100;
		pthread_mutex_unlock(&lock);

		uint64_t t = mc_now_ns();
		if (next > t) {
			struct timespec ts = {.tv_sec = (time_t)((next - t) / 1000000000u),
					      .tv_nsec = (long)((next - t) % 1000000000u)};
			nanosleep(&ts, NULL);
		}
		next = (next > t ? next : t) + interval;
		make_yuyv(yuyv, n);
		size_t size = YUYV_SIZE;
		if (format == FORMAT_MJPEG)
			size = make_mjpeg(tj, yuyv, grey, payload + HEADER, sizeof payload - HEADER);
		else
			memcpy(payload + HEADER, yuyv, YUYV_SIZE);
		payload[0] = HEADER;
		payload[1] = (uint8_t)(UVC_STREAM_EOH | UVC_STREAM_EOF | fid);
		pthread_mutex_lock(&lock);
		bool current = gen == generation && ep_in == fd;
		writing = current;
		pthread_mutex_unlock(&lock);
		ssize_t w = current ? write(fd, payload, size + HEADER) : -1;
		pthread_mutex_lock(&lock);
		writing = false;
		pthread_cond_broadcast(&changed);
		current = gen == generation;
		pthread_mutex_unlock(&lock);
		if (w < 0 && errno != EINTR && current) {
			/* the host went away; wait for the next commit */
			pthread_mutex_lock(&lock);
			if (gen == generation)
				streaming = false;
			pthread_mutex_unlock(&lock);
		}
		if (w == (ssize_t)(size + HEADER)) {
			fid ^= UVC_STREAM_FID;
			n++;
		}
	}
	tjDestroy(tj);
	return NULL;
}

/* ---- ep0: control requests ---- */

static int open_endpoint(int speed)
{
	int fd = open(GADGET_DIR "/" EP_IN_NAME, O_RDWR);
	if (fd < 0) {
		perror(GADGET_DIR "/" EP_IN_NAME);
		return -1;
	}
	uint8_t buf[4 + 2 * USB_DT_ENDPOINT_SIZE];
	uint32_t tag = 1;
	struct usb_endpoint_descriptor fs, hs;
	endpoint_desc(&fs, 64);
	endpoint_desc(&hs, 512);
	memcpy(buf, &tag, 4);
	memcpy(buf + 4, &fs, USB_DT_ENDPOINT_SIZE);
	memcpy(buf + 4 + USB_DT_ENDPOINT_SIZE, &hs, USB_DT_ENDPOINT_SIZE);
	if (write(fd, buf, sizeof buf) != (ssize_t)sizeof buf) {
		fprintf(stderr, "uvc_gadget: configuring %s (speed %d): %s\n", EP_IN_NAME, speed, strerror(errno));
		close(fd);
		return -1;
	}
	return fd;
}

/* Stops streaming and closes the endpoint, once the writer is out of its
 * write() (a signal makes gadgetfs cancel the transfer). */
static void close_endpoint(void)
{
	pthread_mutex_lock(&lock);
	streaming = false;
	generation++;
	int fd = ep_in;
	ep_in = -1;
	while (writing) {
		pthread_mutex_unlock(&lock);
		kick_writer();
		usleep(1000);
		pthread_mutex_lock(&lock);
	}
	pthread_mutex_unlock(&lock);
	if (fd >= 0)
		close(fd);
}

static void ack(int ep0)
{
	if (read(ep0, NULL, 0) < 0 && errno != EIDRM)
		perror("uvc_gadget: ack");
}

/* Refuses a request: gadgetfs stalls an IN request on a read and an OUT
 * request without data on a write.  OUT data has already been taken by the
 * kernel and cannot be refused; it is read and dropped. */
static void stall(int ep0, const struct usb_ctrlrequest *r)
{
	uint8_t sink[64];
	ssize_t n;
	if (r->bRequestType & USB_DIR_IN)
		n = read(ep0, NULL, 0);
	else if (r->wLength)
		n = read(ep0, sink, sizeof sink);
	else
		n = write(ep0, NULL, 0);
	(void)n; /* -EL2HLT is the expected answer */
}

static void reply(int ep0, const void *data, size_t len, unsigned wLength)
{
	if (write(ep0, data, len < wLength ? len : wLength) < 0)
		perror("uvc_gadget: reply");
}

static void handle_uvc(int ep0, const struct usb_ctrlrequest *r)
{
	unsigned iface = r->wIndex & 0xff, selector = r->wValue >> 8;
	if (iface != 1 || (selector != UVC_VS_PROBE_CONTROL && selector != UVC_VS_COMMIT_CONTROL)) {
		stall(ep0, r); /* no camera or processing controls */
		return;
	}
	struct uvc_streaming_control *c = selector == UVC_VS_PROBE_CONTROL ? &probe : &commit;
	switch (r->bRequest) {
	case UVC_SET_CUR: {
		struct uvc_streaming_control in;
		memset(&in, 0, sizeof in);
		ssize_t n = read(ep0, &in, r->wLength < sizeof in ? r->wLength : sizeof in);
		if (n < 0)
			return;
		fill_control(&in);
		pthread_mutex_lock(&lock);
		*c = in;
		if (selector == UVC_VS_COMMIT_CONTROL) {
			generation++;
			streaming = ep_in >= 0;
			pthread_cond_broadcast(&changed);
		}
		pthread_mutex_unlock(&lock);
		if (selector == UVC_VS_COMMIT_CONTROL)
			kick_writer();
		break;
	}
	case UVC_GET_CUR:
	case UVC_GET_MIN:
	case UVC_GET_MAX:
	case UVC_GET_DEF: {
		struct uvc_streaming_control out;
		memset(&out, 0, sizeof out);
		if (r->bRequest == UVC_GET_CUR) {
			pthread_mutex_lock(&lock);
			out = *c;
			pthread_mutex_unlock(&lock);
		} else {
			out.bFormatIndex = FORMAT_YUYV;
			out.dwFrameInterval = r->bRequest == UVC_GET_MAX ? INTERVAL_15 : INTERVAL_30;
		}
		fill_control(&out);
		reply(ep0, &out, sizeof out, r->wLength);
		break;
	}
	case UVC_GET_LEN: {
		uint8_t len[2] = {sizeof(struct uvc_streaming_control), 0};
		reply(ep0, len, 2, r->wLength);
		break;
	}
	case UVC_GET_INFO: {
		uint8_t info = 3; /* GET and SET supported */
		reply(ep0, &info, 1, r->wLength);
		break;
	}
	default:
		stall(ep0, r);
	}
}

static void handle_setup(int ep0, const struct usb_ctrlrequest *r, int speed)
{
	if ((r->bRequestType & USB_TYPE_MASK) == USB_TYPE_CLASS) {
		handle_uvc(ep0, r);
		return;
	}
	switch (r->bRequest) {
	case USB_REQ_GET_DESCRIPTOR: {
		uint8_t s[128];
		size_t n = (r->wValue >> 8) == USB_DT_STRING ? string_desc(r->wValue & 0xff, s) : 0;
		if (n)
			reply(ep0, s, n, r->wLength);
		else
			stall(ep0, r);
		break;
	}
	case USB_REQ_SET_CONFIGURATION:
		close_endpoint();
		if (r->wValue) {
			int fd = open_endpoint(speed);
			pthread_mutex_lock(&lock);
			ep_in = fd;
			pthread_mutex_unlock(&lock);
		}
		ack(ep0);
		break;
	case USB_REQ_SET_INTERFACE:
		ack(ep0);
		break;
	case USB_REQ_GET_INTERFACE: {
		uint8_t alt = 0;
		reply(ep0, &alt, 1, r->wLength);
		break;
	}
	default:
		stall(ep0, r);
	}
}

/* Opens gadgetfs' controller file and writes the descriptors: the host
 * sees the camera plugged in.  -1 on failure. */
static int plug_in(void)
{
	char path[300] = "";
	DIR *d = opendir(GADGET_DIR);
	struct dirent *e;
	while (d && (e = readdir(d)))
		if (e->d_name[0] != '.' && strncmp(e->d_name, "ep", 2) != 0)
			snprintf(path, sizeof path, GADGET_DIR "/%s", e->d_name);
	if (d)
		closedir(d);
	if (!path[0]) {
		fprintf(stderr, "uvc_gadget: no controller file in %s (is gadgetfs mounted?)\n", GADGET_DIR);
		return -1;
	}
	int ep0 = open(path, O_RDWR);
	if (ep0 < 0) {
		perror(path);
		return -1;
	}
	static uint8_t buf[4096];
	uint32_t tag = 0;
	memcpy(buf, &tag, 4);
	size_t n = 4;
	n += config_desc(buf + n, 64);  /* full speed */
	n += config_desc(buf + n, 512); /* high speed */
	n += device_desc(buf + n);
	if (write(ep0, buf, n) != (ssize_t)n) {
		fprintf(stderr, "uvc_gadget: writing descriptors to %s: %s\n", path, strerror(errno));
		close(ep0);
		return -1;
	}
	return ep0;
}

static void on_signal(int sig)
{
	if (sig == SIGUSR1)
		want_unplug = 1;
	else if (sig == SIGUSR2)
		want_plug = 1;
	else if (sig == SIGTERM || sig == SIGINT)
		want_exit = 1;
}

int main(int argc, char **argv)
{
	if (argc > 1)
		serial = argv[1];
	struct sigaction sa;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal; /* no SA_RESTART: blocking calls return EINTR */
	sigaction(SIGUSR1, &sa, NULL);
	sigaction(SIGUSR2, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGURG, &sa, NULL);
	sigset_t block, old;
	sigemptyset(&block);
	sigaddset(&block, SIGUSR1);
	sigaddset(&block, SIGUSR2);
	sigaddset(&block, SIGTERM);
	sigaddset(&block, SIGINT);
	/* the writer takes SIGURG only; the control loop takes the rest */
	pthread_sigmask(SIG_BLOCK, &block, &old);
	pthread_create(&writer, NULL, writer_main, NULL);
	pthread_sigmask(SIG_SETMASK, &old, NULL);

	int ep0 = plug_in();
	if (ep0 < 0)
		return 1;
	fprintf(stderr, "uvc_gadget: plugged in (serial %s)\n", serial);
	int speed = USB_SPEED_HIGH;
	while (!want_exit) {
		if (want_unplug) {
			want_unplug = 0;
			close_endpoint();
			if (ep0 >= 0)
				close(ep0);
			ep0 = -1;
			fprintf(stderr, "uvc_gadget: unplugged\n");
		}
		if (want_plug) {
			want_plug = 0;
			if (ep0 < 0 && (ep0 = plug_in()) >= 0)
				fprintf(stderr, "uvc_gadget: plugged in again\n");
		}
		if (ep0 < 0) {
			pause();
			continue;
		}
		struct usb_gadgetfs_event ev[4];
		ssize_t n = read(ep0, ev, sizeof ev);
		if (n < 0) {
			if (errno != EINTR && errno != EIDRM && errno != EAGAIN)
				usleep(10000);
			continue;
		}
		for (size_t i = 0; i < (size_t)n / sizeof ev[0]; i++) {
			switch (ev[i].type) {
			case GADGETFS_CONNECT:
				speed = ev[i].u.speed;
				break;
			case GADGETFS_SETUP:
				handle_setup(ep0, &ev[i].u.setup, speed);
				break;
			case GADGETFS_DISCONNECT:
				close_endpoint();
				break;
			default:
				break;
			}
		}
	}
	close_endpoint();
	if (ep0 >= 0)
		close(ep0);
	pthread_mutex_lock(&lock);
	pthread_cond_broadcast(&changed);
	pthread_mutex_unlock(&lock);
	pthread_join(writer, NULL);
	return 0;
}
