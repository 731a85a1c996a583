// A C ABI over libfreenect2 for trigait's Rust driver. It exists to make libfreenect2 safe to
// drive from a long-running node, not just to translate calls:
// - its own frame listener, because SyncMultiFrameListener::waitForNewFrame(ms) ignores the
//   timeout unless libfreenect2 was built with ENABLE_CXX11 (a blocked wait would make a stop
//   hang); ours uses std::condition_variable::wait_for, and stamps each frame with the host
//   clock in the callback, the earliest point the host sees it (for NTP on the host clock);
// - a serial is checked against the enumeration before a pipeline is built (opening an unknown
//   serial can deadlock in libfreenect2's thread shutdown), and a second open of one serial is
//   refused (libfreenect2 returns the same device pointer, which would be freed twice);
// - open and close run on a watchdog thread: if libfreenect2 deadlocks, the caller gets an
//   error after the timeout, the stuck objects are leaked, and the context is poisoned so it is
//   neither used nor deleted again (destroying the context deletes its devices);
// - libfreenect2's log goes to a callback (Rust's tracing) instead of stderr, and an
//   enumeration notes when a Kinect was seen but could not be opened (LIBUSB_ERROR_ACCESS: the
//   udev rule is missing).
#include "trigait_freenect2.h"

#include <libfreenect2/libfreenect2.hpp>
#include <libfreenect2/logger.h>
#include <libfreenect2/packet_pipeline.h>
#ifndef TRIGAIT_FAKE_FREENECT2
#include <libfreenect2/registration.h>
#endif

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

namespace {

int64_t host_nanos() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::atomic<tg_log_fn> g_log_fn{nullptr};
std::atomic<int> g_log_level{2};
std::atomic<bool> g_access_denied{false};

class ForwardingLogger : public libfreenect2::Logger {
 public:
  ForwardingLogger() { level_ = Debug; }
  Level level() const override {
    // Errors are always formatted: an access error is how a missing udev rule shows.
    int l = g_log_level.load();
    return static_cast<Level>(l < Error ? Error : l);
  }
  void log(Level level, const std::string &message) override {
    if (message.find("LIBUSB_ERROR_ACCESS") != std::string::npos) g_access_denied = true;
    tg_log_fn f = g_log_fn.load();
    if (f != nullptr && static_cast<int>(level) <= g_log_level.load())
      f(static_cast<int>(level), message.data(), message.size());
  }
};

void ensure_logger() {
  static std::once_flag once;
  std::call_once(once, [] { libfreenect2::setGlobalLogger(new ForwardingLogger()); });
}

// Runs f on a detached thread and waits up to timeout_ms; false when it did not finish
// (the thread keeps whatever f captured alive through the shared state).
bool run_with_watchdog(std::function<void()> f, int timeout_ms) {
  struct State {
    std::mutex m;
    std::condition_variable cv;
    bool done = false;
  };
  auto state = std::make_shared<State>();
  std::thread([state, f]() {
    f();
    std::lock_guard<std::mutex> lock(state->m);
    state->done = true;
    state->cv.notify_all();
  }).detach();
  std::unique_lock<std::mutex> lock(state->m);
  return state->cv.wait_for(lock, std::chrono::milliseconds(timeout_ms),
                            [&] { return state->done; });
}

std::mutex g_open_mutex;
std::set<std::string> g_open_serials;

class Listener : public libfreenect2::FrameListener {
 public:
  bool onNewFrame(libfreenect2::Frame::Type type, libfreenect2::Frame *frame) override;
  int wait(int timeout_ms, tg_frame **out);
  void drain();
  uint64_t dropped() {
    std::lock_guard<std::mutex> lock(m_);
    return dropped_;
  }

 private:
  static constexpr size_t kCapacity = 16;
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<tg_frame *> queue_;
  uint64_t dropped_ = 0;
};

}  // namespace

struct tg_frame {
  int type;
  libfreenect2::Frame *frame;
  int64_t host_nanos;
};

struct tg_context {
  libfreenect2::Freenect2 *f2 = nullptr;
  std::timed_mutex m;
  std::atomic<bool> poisoned{false};
  std::atomic<int> open_devices{0};
};

struct tg_device {
  tg_context *ctx = nullptr;
  libfreenect2::Freenect2Device *dev = nullptr;
  Listener listener;
  std::string serial;
  int frame_types = 0;
  bool started = false;
};

namespace {

bool Listener::onNewFrame(libfreenect2::Frame::Type type, libfreenect2::Frame *frame) {
  const int64_t now = host_nanos();
  tg_frame *f = new tg_frame{static_cast<int>(type), frame, now};
  {
    std::lock_guard<std::mutex> lock(m_);
    if (queue_.size() >= kCapacity) {
      tg_frame *old = queue_.front();
      queue_.pop_front();
      delete old->frame;
      delete old;
      ++dropped_;
    }
    queue_.push_back(f);
  }
  cv_.notify_one();
  return true;  // we own the frame now; libfreenect2 allocates a new one
}

int Listener::wait(int timeout_ms, tg_frame **out) {
  std::unique_lock<std::mutex> lock(m_);
  if (!cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms < 0 ? 0 : timeout_ms),
                    [&] { return !queue_.empty(); }))
    return TG_TIMEOUT;
  *out = queue_.front();
  queue_.pop_front();
  return TG_OK;
}

void Listener::drain() {
  std::lock_guard<std::mutex> lock(m_);
  for (tg_frame *f : queue_) {
    delete f->frame;
    delete f;
  }
  queue_.clear();
}

void copy_string(const std::string &s, char *buf, size_t len) {
  if (buf == nullptr || len == 0) return;
  size_t n = s.size() < len - 1 ? s.size() : len - 1;
  std::memcpy(buf, s.data(), n);
  buf[n] = '\0';
}

libfreenect2::PacketPipeline *make_pipeline(int pipeline) {
  switch (pipeline) {
    case TG_PIPELINE_CPU:
      return new libfreenect2::CpuPacketPipeline();
#ifdef LIBFREENECT2_WITH_OPENGL_SUPPORT
    case TG_PIPELINE_OPENGL:
      return new libfreenect2::OpenGLPacketPipeline();
#endif
#ifdef LIBFREENECT2_WITH_OPENCL_SUPPORT
    case TG_PIPELINE_OPENCL:
      return new libfreenect2::OpenCLPacketPipeline();
#endif
#ifdef LIBFREENECT2_WITH_CUDA_SUPPORT
    case TG_PIPELINE_CUDA:
      return new libfreenect2::CudaPacketPipeline();
#endif
    default:
      return nullptr;
  }
}

}  // namespace

extern "C" {

uint32_t tg_pipelines_available(void) {
  uint32_t bits = TG_PIPELINE_CPU;
#ifdef LIBFREENECT2_WITH_OPENGL_SUPPORT
  bits |= TG_PIPELINE_OPENGL;
#endif
#ifdef LIBFREENECT2_WITH_OPENCL_SUPPORT
  bits |= TG_PIPELINE_OPENCL;
#endif
#ifdef LIBFREENECT2_WITH_CUDA_SUPPORT
  bits |= TG_PIPELINE_CUDA;
#endif
  return bits;
}

void tg_set_log(tg_log_fn callback, int level) {
  g_log_fn = callback;
  g_log_level = level;
  ensure_logger();
}

tg_context *tg_context_new(void) {
  ensure_logger();
  tg_context *ctx = new tg_context();
  ctx->f2 = new libfreenect2::Freenect2();
  return ctx;
}

int tg_context_free(tg_context *ctx) {
  if (ctx == nullptr) return TG_ERR_NULL;
  if (ctx->poisoned || ctx->open_devices > 0) return TG_ERR_WATCHDOG;  // leaked on purpose
  delete ctx->f2;
  delete ctx;
  return TG_OK;
}

int tg_enumerate(tg_context *ctx, int *usb_access_denied) {
  if (ctx == nullptr) return TG_ERR_NULL;
  if (ctx->poisoned) return TG_ERR_WATCHDOG;
  std::unique_lock<std::timed_mutex> lock(ctx->m, std::chrono::seconds(5));
  if (!lock.owns_lock()) return TG_ERR_WATCHDOG;
  g_access_denied = false;
  int n = ctx->f2->enumerateDevices();
  if (usb_access_denied != nullptr) *usb_access_denied = g_access_denied ? 1 : 0;
  return n;
}

int tg_serial(tg_context *ctx, int idx, char *buf, size_t len) {
  if (ctx == nullptr) return TG_ERR_NULL;
  if (ctx->poisoned) return TG_ERR_WATCHDOG;
  std::unique_lock<std::timed_mutex> lock(ctx->m, std::chrono::seconds(5));
  if (!lock.owns_lock()) return TG_ERR_WATCHDOG;
  std::string s = ctx->f2->getDeviceSerialNumber(idx);
  if (s.empty()) return TG_ERR_INDEX;
  copy_string(s, buf, len);
  return static_cast<int>(s.size());
}

int tg_open(tg_context *ctx, const char *serial, int pipeline, int frame_types, int timeout_ms,
            tg_device **out) {
  if (ctx == nullptr || serial == nullptr || out == nullptr) return TG_ERR_NULL;
  if (ctx->poisoned) return TG_ERR_WATCHDOG;
  const std::string wanted(serial);
  if ((tg_pipelines_available() & static_cast<uint32_t>(pipeline)) == 0 ||
      (pipeline & (pipeline - 1)) != 0)
    return TG_ERR_PIPELINE_UNAVAILABLE;
  {
    std::lock_guard<std::mutex> lock(g_open_mutex);
    if (g_open_serials.count(wanted) != 0) return TG_ERR_ALREADY_OPEN;
    g_open_serials.insert(wanted);
  }
  auto release_serial = [&] {
    std::lock_guard<std::mutex> lock(g_open_mutex);
    g_open_serials.erase(wanted);
  };
  std::unique_lock<std::timed_mutex> lock(ctx->m, std::chrono::milliseconds(timeout_ms));
  if (!lock.owns_lock()) {
    release_serial();
    return TG_ERR_WATCHDOG;
  }
  bool known = false;
  int n = ctx->f2->enumerateDevices();
  for (int i = 0; i < n && !known; ++i) known = ctx->f2->getDeviceSerialNumber(i) == wanted;
  if (!known) {
    release_serial();
    return TG_ERR_NO_SUCH_SERIAL;
  }
  auto result = std::make_shared<libfreenect2::Freenect2Device *>(nullptr);
  libfreenect2::Freenect2 *f2 = ctx->f2;
  bool finished = run_with_watchdog(
      [result, f2, wanted, pipeline] {
        // openDevice takes the pipeline (deletes it on failure).
        *result = f2->openDevice(wanted, make_pipeline(pipeline));
      },
      timeout_ms);
  if (!finished) {
    ctx->poisoned = true;  // the stuck thread still uses f2; never touch or delete it again
    return TG_ERR_WATCHDOG;  // the serial stays marked open: its device is in limbo
  }
  if (*result == nullptr) {
    release_serial();
    return TG_ERR_OPEN_FAILED;
  }
  tg_device *dev = new tg_device();
  dev->ctx = ctx;
  dev->dev = *result;
  dev->serial = wanted;
  dev->frame_types = frame_types;
  if (frame_types & (TG_FRAME_IR | TG_FRAME_DEPTH)) dev->dev->setIrAndDepthFrameListener(&dev->listener);
  if (frame_types & TG_FRAME_COLOR) dev->dev->setColorFrameListener(&dev->listener);
  ++ctx->open_devices;
  *out = dev;
  return TG_OK;
}

int tg_firmware(tg_device *dev, char *buf, size_t len) {
  if (dev == nullptr) return TG_ERR_NULL;
  std::string s = dev->dev->getFirmwareVersion();
  copy_string(s, buf, len);
  return static_cast<int>(s.size());
}

int tg_start(tg_device *dev) {
  if (dev == nullptr) return TG_ERR_NULL;
  bool color = (dev->frame_types & TG_FRAME_COLOR) != 0;
  bool depth = (dev->frame_types & (TG_FRAME_IR | TG_FRAME_DEPTH)) != 0;
  if (!dev->dev->startStreams(color, depth)) return TG_ERR_START_FAILED;
  dev->started = true;
  return TG_OK;
}

int tg_ir_params_get(tg_device *dev, tg_ir_params *out) {
  if (dev == nullptr || out == nullptr) return TG_ERR_NULL;
  if (!dev->started) return TG_ERR_NOT_STARTED;
  libfreenect2::Freenect2Device::IrCameraParams p = dev->dev->getIrCameraParams();
  *out = tg_ir_params{p.fx, p.fy, p.cx, p.cy, p.k1, p.k2, p.k3, p.p1, p.p2};
  return TG_OK;
}

int tg_wait(tg_device *dev, int timeout_ms, tg_frame **out) {
  if (dev == nullptr || out == nullptr) return TG_ERR_NULL;
  return dev->listener.wait(timeout_ms, out);
}

uint64_t tg_dropped(tg_device *dev) { return dev == nullptr ? 0 : dev->listener.dropped(); }

void tg_frame_get(const tg_frame *frame, tg_frame_info *out) {
  if (frame == nullptr || out == nullptr) return;
  const libfreenect2::Frame *f = frame->frame;
  *out = tg_frame_info{frame->type, f->width,    f->height,      f->bytes_per_pixel,
                       f->data,     f->timestamp, f->sequence, f->status,
                       frame->host_nanos};
}

void tg_frame_free(tg_frame *frame) {
  if (frame == nullptr) return;
  delete frame->frame;
  delete frame;
}

int tg_close(tg_device *dev, int timeout_ms) {
  if (dev == nullptr) return TG_ERR_NULL;
  tg_context *ctx = dev->ctx;
  libfreenect2::Freenect2Device *d = dev->dev;
  bool started = dev->started;
  bool finished = run_with_watchdog(
      [ctx, d, started] {
        if (started) d->stop();
        d->close();
        std::lock_guard<std::timed_mutex> lock(ctx->m);
        delete d;  // unregisters itself from the context
      },
      timeout_ms);
  if (!finished) {
    ctx->poisoned = true;  // the device (and so the context) is in limbo: leak both
    return TG_ERR_WATCHDOG;
  }
  dev->listener.drain();
  {
    std::lock_guard<std::mutex> lock(g_open_mutex);
    g_open_serials.erase(dev->serial);
  }
  --ctx->open_devices;
  delete dev;
  return TG_OK;
}

int tg_registration_xyz(const tg_ir_params *params, const float *depth, float *undistorted,
                        float *xyz) {
#ifdef TRIGAIT_FAKE_FREENECT2
  (void)params;
  (void)depth;
  (void)undistorted;
  (void)xyz;
  return TG_ERR_PIPELINE_UNAVAILABLE;  // the fake library has no Registration
#else
  if (params == nullptr || depth == nullptr || undistorted == nullptr || xyz == nullptr)
    return TG_ERR_NULL;
  libfreenect2::Freenect2Device::IrCameraParams ir;
  ir.fx = params->fx;
  ir.fy = params->fy;
  ir.cx = params->cx;
  ir.cy = params->cy;
  ir.k1 = params->k1;
  ir.k2 = params->k2;
  ir.k3 = params->k3;
  ir.p1 = params->p1;
  ir.p2 = params->p2;
  libfreenect2::Freenect2Device::ColorCameraParams color;
  std::memset(&color, 0, sizeof color);
  color.fx = 1081.37f;  // only the colour maps use these; any finite values do
  color.fy = 1081.37f;
  color.cx = 959.5f;
  color.cy = 539.5f;
  libfreenect2::Registration reg(ir, color);
  libfreenect2::Frame in(512, 424, 4, reinterpret_cast<unsigned char *>(const_cast<float *>(depth)));
  libfreenect2::Frame out(512, 424, 4, reinterpret_cast<unsigned char *>(undistorted));
  reg.undistortDepth(&in, &out);
  for (int r = 0; r < 424; ++r)
    for (int c = 0; c < 512; ++c) {
      float *p = xyz + 3 * (r * 512 + c);
      reg.getPointXYZ(&out, r, c, p[0], p[1], p[2]);
    }
  return TG_OK;
#endif
}

}  // extern "C"
