/* stand-in: PX4 px4_platform_common/px4_work_queue/ScheduledWorkItem.hpp */
#pragma once
#include <stdint.h>

namespace px4
{
struct wq_config_t {
	const char *name;
	uint16_t stacksize;
	int8_t relative_priority;
};

namespace wq_configurations
{
extern const wq_config_t nav_and_controllers;
} // namespace wq_configurations

class WorkItem
{
public:
	virtual ~WorkItem() = default;
	void ScheduleNow();

protected:
	virtual void Run() = 0;
};

class ScheduledWorkItem : public WorkItem
{
public:
	ScheduledWorkItem(const char *name, const wq_config_t &config);
	void ScheduleClear();
	void ScheduleOnInterval(uint32_t interval_us, uint32_t delay_us = 0);
};
} // namespace px4
