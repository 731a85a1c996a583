/* Controls of trigait's fake libfreenect2 (tests only): a process-wide fake USB bus. */
#ifndef TRIGAIT_FAKE_CONTROL_H
#define TRIGAIT_FAKE_CONTROL_H
#include <stdint.h>
#ifdef __cplusplus
extern "C" {
#endif
/* Unplugs everything and forgets all devices. */
void tgfake_reset(void);
/* Plugs a Kinect in: frames every period_us, device timestamps from timestamp0 (+266 per
   frame), sequence numbers from sequence0; depth is 512*424 mm played for every frame
   (copied), IR is depth/10. */
void tgfake_plug(const char *serial, const char *firmware, uint32_t period_us, uint32_t timestamp0,
                 uint32_t sequence0, const float *depth);
/* Frames stop and the device leaves the enumeration (the real library has no unplug event). */
void tgfake_unplug(const char *serial);
/* Frames are captured but not delivered for ms (a USB stall: the sequence jumps after it). */
void tgfake_stall(const char *serial, uint32_t ms);
/* The device's close() blocks for ms (libfreenect2's shutdown deadlock). */
void tgfake_hang_close(const char *serial, uint32_t ms);
/* The device is on the bus but cannot be opened (no udev rule): enumeration logs an access error. */
void tgfake_deny_access(const char *serial, int denied);
/* Logs through libfreenect2's global logger, as the library does. */
void tgfake_log(int level, const char *message);
/* Devices whose pipeline was built (openDevice reached), since the last reset. */
int tgfake_pipelines_built(void);
#ifdef __cplusplus
}
#endif
#endif
