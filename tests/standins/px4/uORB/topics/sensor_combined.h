/* stand-in: PX4 msg/SensorCombined.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct sensor_combined_s {
	uint64_t timestamp;
	float gyro_rad[3];
	uint32_t gyro_integral_dt;
	int32_t accelerometer_timestamp_relative;
	float accelerometer_m_s2[3];
	uint32_t accelerometer_integral_dt;
};
ORB_DECLARE(sensor_combined);
