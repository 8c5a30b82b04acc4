/* stand-in: PX4 msg/Wind.msg */
#pragma once
#include <uORB/uORB.h>
struct wind_s {
	uint64_t timestamp;
	uint64_t timestamp_sample;
	float windspeed_north;
	float windspeed_east;
	float variance_north;
	float variance_east;
	float tas_innov;
	float tas_innov_var;
	float beta_innov;
	float beta_innov_var;
};
ORB_DECLARE(wind);
