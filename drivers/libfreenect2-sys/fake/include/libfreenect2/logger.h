// Fake libfreenect2: the logger interface, as upstream 0.2 declares it.
#ifndef LIBFREENECT2_LOGGER_H_
#define LIBFREENECT2_LOGGER_H_
#include <string>
#include <libfreenect2/config.h>
namespace libfreenect2 {
class LIBFREENECT2_API Logger {
 public:
  enum Level { None = 0, Error = 1, Warning = 2, Info = 3, Debug = 4 };
  virtual ~Logger();
  virtual Level level() const;
  virtual void log(Level level, const std::string &message) = 0;
 protected:
  Level level_;
};
LIBFREENECT2_API Logger *getGlobalLogger();
LIBFREENECT2_API void setGlobalLogger(Logger *logger);
}  // namespace libfreenect2
#endif
