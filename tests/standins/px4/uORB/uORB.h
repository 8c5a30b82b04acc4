/* stand-in: PX4 uORB/uORB.h */
#pragma once
#include <stdint.h>
struct orb_metadata {
	const char *o_name;
	uint16_t o_size;
};
#define ORB_ID(name) (&__orb_##name)
#define ORB_DECLARE(name) extern const struct orb_metadata __orb_##name
