/* stand-in: PX4 px4_platform_common/defines.h */
#pragma once
#include <math.h>
#define PX4_OK 0
#define PX4_ERROR (-1)
#ifndef __EXPORT
#define __EXPORT __attribute__((visibility("default")))
#endif
#define PX4_ISFINITE(x) __builtin_isfinite(x)
