// Fake libfreenect2: the subset of Freenect2 and Freenect2Device that trigait's shim calls,
// with upstream 0.2's names and signatures. Devices are "plugged" and driven through
// fake_control.h; frames are played from memory on a thread, like the real USB thread.
#ifndef LIBFREENECT2_HPP_
#define LIBFREENECT2_HPP_
#include <libfreenect2/config.h>
#include <libfreenect2/frame_listener.hpp>
#include <libfreenect2/packet_pipeline.h>
#include <string>
namespace libfreenect2 {
class LIBFREENECT2_API Freenect2Device {
 public:
  struct IrCameraParams {
    float fx, fy, cx, cy, k1, k2, k3, p1, p2;
  };
  virtual ~Freenect2Device();
  virtual std::string getSerialNumber() = 0;
  virtual std::string getFirmwareVersion() = 0;
  virtual IrCameraParams getIrCameraParams() = 0;
  virtual void setColorFrameListener(FrameListener *rgb_frame_listener) = 0;
  virtual void setIrAndDepthFrameListener(FrameListener *ir_frame_listener) = 0;
  virtual bool start() = 0;
  virtual bool startStreams(bool rgb, bool depth) = 0;
  virtual bool stop() = 0;
  virtual bool close() = 0;
};
class Freenect2Impl;
class LIBFREENECT2_API Freenect2 {
 public:
  Freenect2(void *usb_context = 0);
  virtual ~Freenect2();
  int enumerateDevices();
  std::string getDeviceSerialNumber(int idx);
  Freenect2Device *openDevice(const std::string &serial, const PacketPipeline *factory);
 private:
  Freenect2Impl *impl_;
  Freenect2(const Freenect2 &);
  Freenect2 &operator=(const Freenect2 &);
};
}  // namespace libfreenect2
#endif
