/* stand-in: PX4 msg/HoverThrustEstimate.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct hover_thrust_estimate_s {
	uint64_t timestamp;
	uint64_t timestamp_sample;
	float hover_thrust;
	float hover_thrust_var;
	bool valid;
};
ORB_DECLARE(hover_thrust_estimate);
