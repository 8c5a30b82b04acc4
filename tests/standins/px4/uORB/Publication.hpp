/* stand-in: PX4 uORB/Publication.hpp */
#pragma once
#include <uORB/uORB.h>

namespace uORB
{
template<typename T> class Publication
{
public:
	explicit Publication(const orb_metadata *meta);
	bool publish(const T &data);
};
} // namespace uORB
