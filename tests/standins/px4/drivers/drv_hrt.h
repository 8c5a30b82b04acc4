/* stand-in: PX4 drivers/drv_hrt.h (high-resolution timer) */
#pragma once
#include <stdint.h>
typedef uint64_t hrt_abstime;
hrt_abstime hrt_absolute_time(void);
