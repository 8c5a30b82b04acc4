/* stand-in: PX4 msg/VehicleAttitudeSetpoint.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct vehicle_attitude_setpoint_s {
	uint64_t timestamp;
	float roll_body;
	float pitch_body;
	float yaw_body;
	float yaw_sp_move_rate;
	float q_d[4];
	float thrust_body[3];
};
ORB_DECLARE(vehicle_attitude_setpoint);
