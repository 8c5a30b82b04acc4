/* stand-in: PX4 msg/VehicleLandDetected.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct vehicle_land_detected_s {
	uint64_t timestamp;
	float alt_max;
	bool freefall;
	bool ground_contact;
	bool maybe_landed;
	bool landed;
	bool in_ground_effect;
	bool in_descend;
	bool has_low_throttle;
	bool vertical_movement;
	bool horizontal_movement;
	bool rotational_movement;
	bool close_to_ground_or_skipped_check;
	bool at_rest;
};
ORB_DECLARE(vehicle_land_detected);
