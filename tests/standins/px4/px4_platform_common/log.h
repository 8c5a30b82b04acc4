/* stand-in: PX4 px4_platform_common/log.h (printf-checked, as PX4's are) */
#pragma once
__attribute__((format(printf, 1, 2))) void px4_log_stub(const char *format, ...);
#define PX4_ERR(...) px4_log_stub(__VA_ARGS__)
#define PX4_WARN(...) px4_log_stub(__VA_ARGS__)
#define PX4_INFO(...) px4_log_stub(__VA_ARGS__)
