// Fake libfreenect2 (trigait's test double): the configuration header. No GPU pipelines.
#ifndef LIBFREENECT2_CONFIG_H
#define LIBFREENECT2_CONFIG_H
#define LIBFREENECT2_VERSION "0.2.0-trigait-fake"
#define LIBFREENECT2_API
#endif
