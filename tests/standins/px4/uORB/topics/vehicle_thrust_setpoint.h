/* stand-in: PX4 msg/VehicleThrustSetpoint.msg */
#pragma once
#include <uORB/uORB.h>
struct vehicle_thrust_setpoint_s {
	uint64_t timestamp;
	uint64_t timestamp_sample;
	float xyz[3];
};
ORB_DECLARE(vehicle_thrust_setpoint);
