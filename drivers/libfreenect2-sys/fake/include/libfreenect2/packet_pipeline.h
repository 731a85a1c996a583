// Fake libfreenect2: the packet pipelines (CPU only, as a build without GPU support).
#ifndef PACKET_PIPELINE_H_
#define PACKET_PIPELINE_H_
#include <libfreenect2/config.h>
#include <stdlib.h>
namespace libfreenect2 {
class LIBFREENECT2_API PacketPipeline {
 public:
  PacketPipeline();
  virtual ~PacketPipeline();
};
class LIBFREENECT2_API CpuPacketPipeline : public PacketPipeline {
 public:
  CpuPacketPipeline();
  virtual ~CpuPacketPipeline();
};
}  // namespace libfreenect2
#endif
