/* stand-in: PX4 uORB/SubscriptionInterval.hpp */
#pragma once
#include <uORB/Subscription.hpp>

namespace uORB
{
class SubscriptionInterval
{
public:
	SubscriptionInterval(const orb_metadata *meta, uint32_t interval_us = 0, uint8_t instance = 0);
	bool updated();
	bool update(void *dst);
	bool copy(void *dst);
};
} // namespace uORB
