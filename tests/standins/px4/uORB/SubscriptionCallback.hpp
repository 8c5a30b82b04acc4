/* stand-in: PX4 uORB/SubscriptionCallback.hpp */
#pragma once
#include <px4_platform_common/px4_work_queue/ScheduledWorkItem.hpp>
#include <uORB/SubscriptionInterval.hpp>

namespace uORB
{
class SubscriptionCallbackWorkItem : public SubscriptionInterval
{
public:
	SubscriptionCallbackWorkItem(px4::WorkItem *work_item, const orb_metadata *meta, uint8_t instance = 0);
	bool registerCallback();
	void unregisterCallback();
};
} // namespace uORB
