/* stand-in: PX4 msg/ParameterUpdate.msg (the fields used) */
#pragma once
#include <uORB/uORB.h>
struct parameter_update_s {
	uint64_t timestamp;
	uint32_t instance;
};
ORB_DECLARE(parameter_update);
