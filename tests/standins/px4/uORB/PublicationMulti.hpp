/* stand-in: PX4 uORB/PublicationMulti.hpp */
#pragma once
#include <uORB/uORB.h>

namespace uORB
{
template<typename T> class PublicationMulti
{
public:
	explicit PublicationMulti(const orb_metadata *meta);
	bool publish(const T &data);
};
} // namespace uORB
