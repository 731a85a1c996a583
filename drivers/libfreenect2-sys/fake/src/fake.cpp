// trigait's fake libfreenect2: the classes the shim calls, playing frames from memory on a
// thread per device. It reproduces the behaviours the shim must cope with: frames just stop on
// an unplug (no event), a stall makes the sequence jump, openDevice returns the same pointer for
// a second open of one serial, close() can block, a device without access rights is logged as
// LIBUSB_ERROR_ACCESS and left out of the enumeration.
#include <libfreenect2/libfreenect2.hpp>
#include <libfreenect2/logger.h>

#include "fake_control.h"

#include <atomic>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct BusDevice {
  std::string firmware;
  uint32_t period_us = 33333;
  uint32_t timestamp0 = 0;
  uint32_t sequence0 = 0;
  std::vector<float> depth;
  bool plugged = false;
  uint64_t generation = 0;
  Clock::time_point stall_until{};
  uint32_t hang_close_ms = 0;
  bool denied = false;
};

std::mutex g_bus_mutex;
std::map<std::string, BusDevice> g_bus;
uint64_t g_generation = 0;
std::atomic<int> g_pipelines_built{0};

libfreenect2::Logger *g_logger = nullptr;

void log_line(libfreenect2::Logger::Level level, const std::string &message) {
  libfreenect2::Logger *l = g_logger;
  if (l != nullptr && l->level() >= level) l->log(level, "[fake] " + message);
}

}  // namespace

namespace libfreenect2 {

Frame::Frame(size_t width, size_t height, size_t bytes_per_pixel, unsigned char *data_)
    : width(width), height(height), bytes_per_pixel(bytes_per_pixel), data(data_),
      timestamp(0), sequence(0), exposure(0.f), gain(0.f), gamma(0.f), status(0),
      format(Frame::Invalid), rawdata(NULL) {
  if (data_) return;
  rawdata = new unsigned char[width * height * bytes_per_pixel];
  data = rawdata;
}
Frame::~Frame() { delete[] rawdata; }
FrameListener::~FrameListener() {}
PacketPipeline::PacketPipeline() {}
PacketPipeline::~PacketPipeline() {}
CpuPacketPipeline::CpuPacketPipeline() {}
CpuPacketPipeline::~CpuPacketPipeline() {}
Logger::~Logger() {}
Logger::Level Logger::level() const { return level_; }
Logger *getGlobalLogger() { return g_logger; }
void setGlobalLogger(Logger *logger) {
  delete g_logger;
  g_logger = logger;
}
Freenect2Device::~Freenect2Device() {}

class FakeDevice;

class Freenect2Impl {
 public:
  std::vector<std::string> enumerated;
  std::map<std::string, FakeDevice *> open;
};

class FakeDevice : public Freenect2Device {
 public:
  FakeDevice(Freenect2Impl *ctx, const std::string &serial, uint64_t generation,
             const PacketPipeline *pipeline)
      : ctx_(ctx), serial_(serial), generation_(generation), pipeline_(pipeline) {}
  ~FakeDevice() override {
    stop();
    ctx_->open.erase(serial_);
    delete pipeline_;
  }
  std::string getSerialNumber() override { return serial_; }
  std::string getFirmwareVersion() override {
    std::lock_guard<std::mutex> lock(g_bus_mutex);
    return g_bus[serial_].firmware;
  }
  IrCameraParams getIrCameraParams() override {
    return IrCameraParams{365.5f, 365.5f, 257.0f, 205.0f, 0.09f, -0.27f, 0.09f, 0.f, 0.f};
  }
  void setColorFrameListener(FrameListener *) override {}
  void setIrAndDepthFrameListener(FrameListener *l) override { listener_ = l; }
  bool start() override { return startStreams(true, true); }
  bool startStreams(bool, bool depth) override {
    if (running_) return true;
    running_ = true;
    if (depth) thread_ = std::thread([this] { play(); });
    return true;
  }
  bool stop() override {
    running_ = false;
    if (thread_.joinable()) thread_.join();
    return true;
  }
  bool close() override {
    stop();
    uint32_t hang = 0;
    {
      std::lock_guard<std::mutex> lock(g_bus_mutex);
      hang = g_bus[serial_].hang_close_ms;
    }
    if (hang > 0) std::this_thread::sleep_for(std::chrono::milliseconds(hang));
    return true;
  }

 private:
  void play() {
    uint32_t period_us, ts, seq;
    std::vector<float> depth;
    {
      std::lock_guard<std::mutex> lock(g_bus_mutex);
      const BusDevice &b = g_bus[serial_];
      period_us = b.period_us;
      ts = b.timestamp0;
      seq = b.sequence0;
      depth = b.depth;
    }
    depth.resize(512 * 424, 0.f);
    Clock::time_point next = Clock::now();
    while (running_) {
      next += std::chrono::microseconds(period_us);
      std::this_thread::sleep_until(next);
      bool deliver;
      {
        std::lock_guard<std::mutex> lock(g_bus_mutex);
        const BusDevice &b = g_bus[serial_];
        deliver = b.plugged && b.generation == generation_ && Clock::now() >= b.stall_until;
      }
      if (deliver && listener_ != nullptr) {
        Frame *ir = new Frame(512, 424, 4);
        Frame *d = new Frame(512, 424, 4);
        float *irp = reinterpret_cast<float *>(ir->data);
        for (size_t i = 0; i < depth.size(); ++i) irp[i] = depth[i] / 10.f;
        std::memcpy(d->data, depth.data(), depth.size() * sizeof(float));
        for (Frame *f : {ir, d}) {
          f->timestamp = ts;
          f->sequence = seq;
          f->format = Frame::Float;
        }
        if (!listener_->onNewFrame(Frame::Ir, ir)) delete ir;
        if (!listener_->onNewFrame(Frame::Depth, d)) delete d;
      }
      ts += 266;  // the device counts on while frames are lost
      seq += 1;
    }
  }

  Freenect2Impl *ctx_;
  std::string serial_;
  uint64_t generation_;
  const PacketPipeline *pipeline_;
  FrameListener *listener_ = nullptr;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

Freenect2::Freenect2(void *) : impl_(new Freenect2Impl()) {}
Freenect2::~Freenect2() {
  // Like upstream: destroying the context deletes its devices.
  while (!impl_->open.empty()) delete impl_->open.begin()->second;
  delete impl_;
}

int Freenect2::enumerateDevices() {
  impl_->enumerated.clear();
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  for (auto &entry : g_bus) {
    if (!entry.second.plugged) continue;
    if (entry.second.denied) {
      log_line(Logger::Error, "failed to open Kinect v2: @1:" + entry.first + " LIBUSB_ERROR_ACCESS Access denied");
      continue;
    }
    impl_->enumerated.push_back(entry.first);
  }
  log_line(Logger::Info, "found " + std::to_string(impl_->enumerated.size()) + " devices");
  return static_cast<int>(impl_->enumerated.size());
}

std::string Freenect2::getDeviceSerialNumber(int idx) {
  if (idx < 0 || static_cast<size_t>(idx) >= impl_->enumerated.size()) return std::string();
  return impl_->enumerated[idx];
}

Freenect2Device *Freenect2::openDevice(const std::string &serial, const PacketPipeline *pipeline) {
  auto it = impl_->open.find(serial);
  if (it != impl_->open.end()) {
    delete pipeline;
    log_line(Logger::Warning, "device is already be open!");
    return it->second;  // upstream's hazard: the same pointer again
  }
  uint64_t generation;
  {
    std::lock_guard<std::mutex> lock(g_bus_mutex);
    auto b = g_bus.find(serial);
    if (b == g_bus.end() || !b->second.plugged) {
      delete pipeline;
      return nullptr;
    }
    generation = b->second.generation;
  }
  ++g_pipelines_built;
  FakeDevice *d = new FakeDevice(impl_, serial, generation, pipeline);
  impl_->open[serial] = d;
  return d;
}

}  // namespace libfreenect2

extern "C" {

void tgfake_reset(void) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  for (auto &entry : g_bus) entry.second.plugged = false;
  g_bus.clear();
  g_pipelines_built = 0;
}

void tgfake_plug(const char *serial, const char *firmware, uint32_t period_us, uint32_t timestamp0,
                 uint32_t sequence0, const float *depth) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  BusDevice &b = g_bus[serial];
  b.firmware = firmware;
  b.period_us = period_us;
  b.timestamp0 = timestamp0;
  b.sequence0 = sequence0;
  b.depth.assign(depth, depth + (depth ? 512 * 424 : 0));
  b.plugged = true;
  b.generation = ++g_generation;
  b.stall_until = Clock::time_point{};
}

void tgfake_unplug(const char *serial) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  g_bus[serial].plugged = false;
}

void tgfake_stall(const char *serial, uint32_t ms) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  g_bus[serial].stall_until = Clock::now() + std::chrono::milliseconds(ms);
}

void tgfake_hang_close(const char *serial, uint32_t ms) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  g_bus[serial].hang_close_ms = ms;
}

void tgfake_deny_access(const char *serial, int denied) {
  std::lock_guard<std::mutex> lock(g_bus_mutex);
  g_bus[serial].denied = denied != 0;
}

void tgfake_log(int level, const char *message) {
  log_line(static_cast<libfreenect2::Logger::Level>(level), message);
}

int tgfake_pipelines_built(void) { return g_pipelines_built; }

}  // extern "C"
