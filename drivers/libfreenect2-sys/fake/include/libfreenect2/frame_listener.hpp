// Fake libfreenect2: Frame and FrameListener, declared as upstream 0.2 declares them.
#ifndef FRAME_LISTENER_HPP_
#define FRAME_LISTENER_HPP_
#include <cstddef>
#include <stdint.h>
#include <libfreenect2/config.h>
namespace libfreenect2 {
class LIBFREENECT2_API Frame {
 public:
  enum Type { Color = 1, Ir = 2, Depth = 4 };
  enum Format { Invalid = 0, Raw = 1, Float = 2, BGRX = 4, RGBX = 5, Gray = 6 };
  size_t width;
  size_t height;
  size_t bytes_per_pixel;
  unsigned char *data;
  uint32_t timestamp;
  uint32_t sequence;
  float exposure;
  float gain;
  float gamma;
  uint32_t status;
  Format format;
  Frame(size_t width, size_t height, size_t bytes_per_pixel, unsigned char *data_ = NULL);
  virtual ~Frame();
 protected:
  unsigned char *rawdata;
};
class LIBFREENECT2_API FrameListener {
 public:
  virtual ~FrameListener();
  virtual bool onNewFrame(Frame::Type type, Frame *frame) = 0;
};
}  // namespace libfreenect2
#endif
