/* C ABI over the subset of libfreenect2 trigait uses (see shim.cpp for why each call exists). */
#ifndef TRIGAIT_FREENECT2_H
#define TRIGAIT_FREENECT2_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Result codes. */
#define TG_OK 0
#define TG_TIMEOUT 1
#define TG_ERR_NULL -1
#define TG_ERR_NO_SUCH_SERIAL -2
#define TG_ERR_ALREADY_OPEN -3
#define TG_ERR_PIPELINE_UNAVAILABLE -4
#define TG_ERR_OPEN_FAILED -5
#define TG_ERR_START_FAILED -6
#define TG_ERR_WATCHDOG -7
#define TG_ERR_INDEX -8
#define TG_ERR_NOT_STARTED -9

/* Pipelines (bits of tg_pipelines_available). */
#define TG_PIPELINE_CPU 1
#define TG_PIPELINE_OPENGL 2
#define TG_PIPELINE_OPENCL 4
#define TG_PIPELINE_CUDA 8

/* Frame types, libfreenect2's values. */
#define TG_FRAME_COLOR 1
#define TG_FRAME_IR 2
#define TG_FRAME_DEPTH 4

typedef struct tg_context tg_context;
typedef struct tg_device tg_device;
typedef struct tg_frame tg_frame;

/* Log callback: level as libfreenect2's Logger::Level (1 error .. 4 debug). */
typedef void (*tg_log_fn)(int level, const char *message, size_t len);

typedef struct tg_ir_params {
  float fx, fy, cx, cy, k1, k2, k3, p1, p2;
} tg_ir_params;

/* What a received frame carries; `data` stays valid until tg_frame_free. */
typedef struct tg_frame_info {
  int type;
  size_t width;
  size_t height;
  size_t bytes_per_pixel;
  const unsigned char *data;
  uint32_t timestamp;
  uint32_t sequence;
  uint32_t status;
  int64_t host_nanos;
} tg_frame_info;

uint32_t tg_pipelines_available(void);
void tg_set_log(tg_log_fn callback, int level);

tg_context *tg_context_new(void);
/* Frees the context; returns TG_ERR_WATCHDOG (and leaks it) if a device close timed out before. */
int tg_context_free(tg_context *ctx);
/* Number of devices; *usb_access_denied is set when a device was seen but could not be opened. */
int tg_enumerate(tg_context *ctx, int *usb_access_denied);
/* Serial of device idx into buf (NUL-terminated); returns its length or TG_ERR_INDEX. */
int tg_serial(tg_context *ctx, int idx, char *buf, size_t len);

/* Opens a device by serial (checked against the last enumeration), with frame types
   (TG_FRAME_* bits) and a pipeline, on a watchdog of timeout_ms. */
int tg_open(tg_context *ctx, const char *serial, int pipeline, int frame_types, int timeout_ms,
            tg_device **out);
int tg_firmware(tg_device *dev, char *buf, size_t len);
int tg_start(tg_device *dev);
/* IR camera parameters (valid only after tg_start). */
int tg_ir_params_get(tg_device *dev, tg_ir_params *out);
/* Waits up to timeout_ms for the next frame: TG_OK (and *out), TG_TIMEOUT. */
int tg_wait(tg_device *dev, int timeout_ms, tg_frame **out);
/* Frames dropped because the queue was full since the device opened. */
uint64_t tg_dropped(tg_device *dev);
void tg_frame_get(const tg_frame *frame, tg_frame_info *out);
void tg_frame_free(tg_frame *frame);
/* Stops and closes on a watchdog: TG_OK or TG_ERR_WATCHDOG (the device is then leaked). */
int tg_close(tg_device *dev, int timeout_ms);

/* libfreenect2's own undistortion and back-projection (real library only): depth and
   undistorted are 512*424 floats (mm), xyz 512*424*3 floats (m, libfreenect2's frame). */
int tg_registration_xyz(const tg_ir_params *params, const float *depth, float *undistorted,
                        float *xyz);

#ifdef __cplusplus
}
#endif
#endif
