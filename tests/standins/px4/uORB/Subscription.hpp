/* stand-in: PX4 uORB/Subscription.hpp */
#pragma once
#include <uORB/uORB.h>

namespace uORB
{
class Subscription
{
public:
	explicit Subscription(const orb_metadata *meta, uint8_t instance = 0);
	bool updated();
	bool update(void *dst);
	bool copy(void *dst);
};
} // namespace uORB
