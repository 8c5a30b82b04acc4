/* stand-in: PX4 msg/EscStatus.msg and msg/EscReport.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct esc_report_s {
	uint64_t timestamp;
	uint32_t esc_errorcount;
	int32_t esc_rpm;
	float esc_voltage;
	float esc_current;
	float esc_temperature;
	uint8_t esc_address;
	uint8_t actuator_function;
};
struct esc_status_s {
	uint64_t timestamp;
	uint16_t counter;
	uint8_t esc_count;
	uint8_t esc_connectiontype;
	uint8_t esc_online_flags;
	uint8_t esc_armed_flags;
	struct esc_report_s esc[8];
};
ORB_DECLARE(esc_status);
