/* stand-in: PX4 msg/VehicleLocalPosition.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct vehicle_local_position_s {
	uint64_t timestamp;
	uint64_t timestamp_sample;
	bool xy_valid;
	bool z_valid;
	bool v_xy_valid;
	bool v_z_valid;
	float x;
	float y;
	float z;
	float vx;
	float vy;
	float vz;
	float ax;
	float ay;
	float az;
	float heading;
};
ORB_DECLARE(vehicle_local_position);
