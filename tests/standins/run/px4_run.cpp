// Runs the PX4 module `dobwind generate --target px4` writes, in one process, against fakes of the PX4
// APIs the stand-ins in ../px4 declare: a uORB bus (the latest message of each topic, and every message
// the module publishes), a clock, the module's parameters. One translation unit: the module's source is
// included below, then the fakes' definitions, then a flight (tests/test_autopilot_run.py builds it).
//
// Usage: px4_run DT_S GROUND_S AIR_S HOVER_RPM ROTORS [FAULT_S stop|offline|zero]
// At 1 / DT_S Hz, level and at rest in still air: GROUND_S seconds on the ground (the land detector says
// landed, in its last second only maybe landed, in its last half second only ground contact; the rotors
// stopped, no thrust), then AIR_S seconds of hover (airborne, the rotors at HOVER_RPM, or
// the thrust setpoint at the hover throttle). From FAULT_S on, ESC 1's telemetry fails: esc_status is no
// longer published (stop), or says ESC 1 is offline (offline), or reads 0 rpm for it (zero).
// Prints a line per message the module publishes:
//   D <time us> <status> <wind_n> <wind_e> <wind_d>    dob_wind
//   W <time us> <windspeed_north> <windspeed_east>     the standard wind topic
#include "DobWind.cpp"

#include <uORB/topics/esc_status.h>
#include <uORB/topics/hover_thrust_estimate.h>
#include <uORB/topics/parameter_update.h>
#include <uORB/topics/sensor_combined.h>
#include <uORB/topics/vehicle_land_detected.h>
#include <uORB/topics/vehicle_thrust_setpoint.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <vector>

#define FAKE_TOPIC(name) const struct orb_metadata __orb_##name = {#name, sizeof(name##_s)}
FAKE_TOPIC(dob_wind);
FAKE_TOPIC(esc_status);
FAKE_TOPIC(hover_thrust_estimate);
FAKE_TOPIC(parameter_update);
FAKE_TOPIC(sensor_combined);
FAKE_TOPIC(vehicle_attitude);
FAKE_TOPIC(vehicle_attitude_setpoint);
FAKE_TOPIC(vehicle_land_detected);
FAKE_TOPIC(vehicle_local_position);
FAKE_TOPIC(vehicle_thrust_setpoint);
FAKE_TOPIC(wind);

namespace
{
struct Topic {
	std::vector<unsigned char> data;
	unsigned generation{0};
};
std::map<const orb_metadata *, Topic> bus;
// A subscription object's topic and the generation it last read, by its address (the stand-in classes
// have no members of their own).
std::map<const void *, std::pair<const orb_metadata *, unsigned>> readers;
std::map<const void *, const orb_metadata *> writers;
std::map<const void *, void *> atomics;
hrt_abstime now_us = 0;

void publish_raw(const orb_metadata *meta, const void *data)
{
	Topic &topic = bus[meta];
	topic.data.assign(static_cast<const unsigned char *>(data), static_cast<const unsigned char *>(data) + meta->o_size);
	topic.generation++;
}

bool reader_updated(const void *reader)
{
	const auto &r = readers.at(reader);
	auto found = bus.find(r.first);
	return found != bus.end() && found->second.generation != r.second;
}

bool reader_copy(const void *reader, void *dst)
{
	auto &r = readers.at(reader);
	auto found = bus.find(r.first);
	if (found == bus.end()) {
		return false;
	}
	std::memcpy(dst, found->second.data.data(), r.first->o_size);
	r.second = found->second.generation;
	return true;
}

template<typename T> void publish(const orb_metadata *meta, const T &message)
{
	publish_raw(meta, &message);
}
} // namespace

// uORB
uORB::Subscription::Subscription(const orb_metadata *meta, uint8_t) { readers[this] = {meta, 0}; }
bool uORB::Subscription::updated() { return reader_updated(this); }
bool uORB::Subscription::update(void *dst) { return reader_updated(this) && reader_copy(this, dst); }
bool uORB::Subscription::copy(void *dst) { return reader_copy(this, dst); }
uORB::SubscriptionInterval::SubscriptionInterval(const orb_metadata *meta, uint32_t, uint8_t) { readers[this] = {meta, 0}; }
bool uORB::SubscriptionInterval::updated() { return reader_updated(this); }
bool uORB::SubscriptionInterval::update(void *dst) { return reader_updated(this) && reader_copy(this, dst); }
bool uORB::SubscriptionInterval::copy(void *dst) { return reader_copy(this, dst); }
uORB::SubscriptionCallbackWorkItem::SubscriptionCallbackWorkItem(px4::WorkItem *, const orb_metadata *meta,
		uint8_t instance) : SubscriptionInterval(meta, 0, instance) {}
bool uORB::SubscriptionCallbackWorkItem::registerCallback() { return true; }
void uORB::SubscriptionCallbackWorkItem::unregisterCallback() {}
template<typename T> uORB::Publication<T>::Publication(const orb_metadata *meta) { writers[this] = meta; }
template<typename T> bool uORB::Publication<T>::publish(const T &data)
{
	publish_raw(writers.at(this), &data);
	return true;
}
template<typename T> uORB::PublicationMulti<T>::PublicationMulti(const orb_metadata *meta) { writers[this] = meta; }
template<typename T> bool uORB::PublicationMulti<T>::publish(const T &data)
{
	publish_raw(writers.at(this), &data);
	return true;
}

// The module framework, the work queue, parameters, clock and log.
template<class T> void px4::atomic<T>::store(T value) { atomics[this] = static_cast<void *>(value); }
template<class T> T px4::atomic<T>::load() const { return static_cast<T>(atomics[this]); }
template<class T> int ModuleBase<T>::main(int, char **) { return 0; }
template<class T> int ModuleBase<T>::print_status() { return 0; }
template<class T> bool ModuleBase<T>::should_exit() const { return false; }
template<class T> void ModuleBase<T>::exit_and_cleanup() {}
const px4::wq_config_t px4::wq_configurations::nav_and_controllers{"nav_and_controllers", 2240, -13};
px4::ScheduledWorkItem::ScheduledWorkItem(const char *, const wq_config_t &) {}
void px4::ScheduledWorkItem::ScheduleClear() {}
void px4::ScheduledWorkItem::ScheduleOnInterval(uint32_t, uint32_t) {}
void px4::WorkItem::ScheduleNow() { Run(); } // the callback runs at once: the test's "work queue"
ModuleParams::ModuleParams(ModuleParams *) {}
void ModuleParams::updateParams() {}
template<px4::params p> bool ParamBool<p>::get() const { return p == px4::params::DOBW_EN; }
template<px4::params p> int ParamInt<p>::get() const { return 0; }
template<px4::params p> float ParamFloat<p>::get() const { return p == px4::params::MPC_THR_HOVER ? 0.5f : 0.f; }
hrt_abstime hrt_absolute_time(void) { return now_us; }
void px4_log_stub(const char *, ...) {}
void px4_module_usage_stub(const char *) {}

int main(int argc, char *argv[])
{
	if (argc != 6 && argc != 8) {
		std::fprintf(stderr, "usage: px4_run DT_S GROUND_S AIR_S HOVER_RPM ROTORS [FAULT_S stop|offline|zero]\n");
		return 2;
	}
	const double dt = std::atof(argv[1]);
	const double ground_s = std::atof(argv[2]);
	const double air_s = std::atof(argv[3]);
	const float hover_rpm = static_cast<float>(std::atof(argv[4]));
	const int rotors = std::atoi(argv[5]);
	const double fault_s = argc == 8 ? std::atof(argv[6]) : 1e300;
	const char *fault = argc == 8 ? argv[7] : "";
	const long steps = static_cast<long>((ground_s + air_s) / dt + 0.5);
	DobWind module;
	module.init();
	unsigned seen_dob = 0, seen_wind = 0;

	for (long k = 1; k <= steps; k++) {
		now_us = static_cast<hrt_abstime>(k * dt * 1e6 + 0.5);
		const bool landed = k * dt <= ground_s;
		vehicle_land_detected_s land{};
		land.timestamp = now_us;
		// PX4's land detector is staged: ground_contact, then maybe_landed, then landed (and back in the
		// reverse order). The last second on the ground has landed clear, then maybe_landed too: the module
		// must hold off on every stage, not only on landed.
		const double to_takeoff = ground_s - k * dt;
		land.ground_contact = landed;
		land.maybe_landed = landed && to_takeoff >= 0.5;
		land.landed = landed && to_takeoff >= 1.0;
		publish(ORB_ID(vehicle_land_detected), land);
		vehicle_attitude_s attitude{};
		attitude.timestamp = attitude.timestamp_sample = now_us;
		attitude.q[0] = 1.f;
		publish(ORB_ID(vehicle_attitude), attitude);
		const bool failed = k * dt > fault_s;
		esc_status_s esc{};
		esc.timestamp = now_us;
		esc.esc_count = static_cast<uint8_t>(rotors);
		esc.esc_online_flags = static_cast<uint8_t>((1u << rotors) - 1u);
		for (int i = 0; i < rotors && i < 8; i++) {
			esc.esc[i].esc_rpm = landed ? 0 : static_cast<int32_t>(hover_rpm + 0.5f);
		}
		if (failed && std::strcmp(fault, "offline") == 0) {
			esc.esc_online_flags &= static_cast<uint8_t>(~1u);
		}
		if (failed && std::strcmp(fault, "zero") == 0) {
			esc.esc[0].esc_rpm = 0;
		}
		if (!(failed && std::strcmp(fault, "stop") == 0)) {
			publish(ORB_ID(esc_status), esc);
		}
		vehicle_thrust_setpoint_s thrust{};
		thrust.timestamp = now_us;
		thrust.xyz[2] = landed ? 0.f : -0.5f; // MPC_THR_HOVER (0.5 above): the weight
		publish(ORB_ID(vehicle_thrust_setpoint), thrust);
		sensor_combined_s imu{};
		imu.timestamp = now_us;
		imu.accelerometer_m_s2[2] = -9.80665f; // at rest: the specific force is -g along body z
		publish(ORB_ID(sensor_combined), imu);
		vehicle_local_position_s position{};
		position.timestamp = position.timestamp_sample = now_us;
		position.xy_valid = position.z_valid = position.v_xy_valid = position.v_z_valid = true;
		publish(ORB_ID(vehicle_local_position), position); // last: the module's callback topic
		module.ScheduleNow();

		const Topic &dob = bus[ORB_ID(dob_wind)];
		if (dob.generation != seen_dob) {
			seen_dob = dob.generation;
			dob_wind_s m;
			std::memcpy(&m, dob.data.data(), sizeof m);
			std::printf("D %llu %u %.6g %.6g %.6g\n", static_cast<unsigned long long>(m.timestamp_sample), m.status,
				    static_cast<double>(m.wind_ned[0]), static_cast<double>(m.wind_ned[1]),
				    static_cast<double>(m.wind_ned[2]));
		}
		const Topic &w = bus[ORB_ID(wind)];
		if (w.generation != seen_wind) {
			seen_wind = w.generation;
			wind_s m;
			std::memcpy(&m, w.data.data(), sizeof m);
			std::printf("W %llu %.6g %.6g\n", static_cast<unsigned long long>(m.timestamp_sample),
				    static_cast<double>(m.windspeed_north), static_cast<double>(m.windspeed_east));
		}
	}
	return 0;
}
