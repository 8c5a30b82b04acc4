// Runs the ArduPilot library `dobwind generate --target ardupilot` writes, in one process, against fakes of
// the ArduPilot APIs the stand-ins in ../ardupilot declare: the AHRS, ESC telemetry, motors, IMU, clock,
// parameters and logger. One translation unit: the library's source is included below, then the fakes'
// definitions, then a flight (tests/test_autopilot_run.py builds it with the step compiled as C).
//
// Usage: ardupilot_run DT_S GROUND_S AIR_S HOVER_RPM ROTORS [FAULT_S zero]
// At 1 / DT_S Hz, level and at rest in still air: GROUND_S seconds on the ground (the vehicle's land
// detector says not flying, the rotors stopped, no throttle), then AIR_S seconds of hover (likely flying,
// the rotors at HOVER_RPM, or the throttle at the hover throttle); update() is called once per sample with
// yaw_ref 0. From FAULT_S on, ESC 1's telemetry reads 0 rpm (zero). Prints a line per DOBW packet the library logs and per sample get_wind_NED() gives:
//   D <time us> <status> <wind_n> <wind_e> <wind_d>
//   W <time us> <wind_n> <wind_e> <wind_d>
#include "AP_DOBWind.cpp"

#include <AP_ESC_Telem/AP_ESC_Telem.h>
#include <AP_InertialSensor/AP_InertialSensor.h>
#include <AP_Motors/AP_Motors.h>

#include <cstdio>
#include <cstdlib>

namespace
{
uint64_t now_us = 0;
bool flying = false;
float rotor_rpm = 0.0f;
bool esc1_zero = false;
int rotor_count = 0;
float throttle = 0.0f;
const Vector3f accel_ef(0.0f, 0.0f, -GRAVITY_MSS); // at rest: the specific force is -g, up
const Vector3f accel_body(0.0f, 0.0f, -GRAVITY_MSS);

class FakeMotors : public AP_Motors
{
public:
    float get_throttle_hover() const override { return 0.5f; }
};
FakeMotors motors_instance;
AP_AHRS ahrs_instance;
AP_ESC_Telem esc_telem_instance;
AP_InertialSensor ins_instance;
AP_Logger logger_instance;
} // namespace

bool AP_AHRS::get_quaternion(Quaternion &quat) const
{
    quat = Quaternion(); // level, facing north
    return true;
}
bool AP_AHRS::get_velocity_NED(Vector3f &vec) const
{
    vec = Vector3f();
    return true;
}
const Vector3f &AP_AHRS::get_accel_ef() const { return accel_ef; }
bool AP_AHRS::get_likely_flying(void) const { return flying; }
AP_AHRS &AP::ahrs() { return ahrs_instance; }
bool AP_ESC_Telem::get_rpm(uint8_t esc_index, float &rpm) const
{
    rpm = esc_index == 0 && esc1_zero ? 0.0f : rotor_rpm;
    return esc_index < rotor_count;
}
AP_ESC_Telem &AP::esc_telem() { return esc_telem_instance; }
float AP_Motors::get_throttle() const { return throttle; }
AP_Motors *AP::motors() { return &motors_instance; }
const Vector3f &AP_InertialSensor::get_accel() const { return accel_body; }
AP_InertialSensor &AP::ins() { return ins_instance; }
uint64_t AP_HAL::micros64() { return now_us; }

// Every INT8 parameter of the table (the library's one: ENABLE) is set to 1.
void AP_Param::setup_object_defaults(const void *object_pointer, const struct GroupInfo *group_info)
{
    for (const GroupInfo *info = group_info; info->type != AP_PARAM_NONE; info++) {
        if (info->type == AP_PARAM_INT8) {
            *(reinterpret_cast<int8_t *>(const_cast<void *>(object_pointer)) + info->offset) = 1;
        }
    }
}

void AP_Logger::WriteBlock(const void *pBuffer, uint16_t size)
{
    if (size != sizeof(log_DOBW)) {
        std::fprintf(stderr, "a packet of %u bytes\n", static_cast<unsigned>(size));
        std::exit(3);
    }
    log_DOBW pkt;
    memcpy(&pkt, pBuffer, sizeof pkt);
    std::printf("D %llu %u %.6g %.6g %.6g\n", static_cast<unsigned long long>(pkt.time_us),
                static_cast<unsigned>(pkt.status), static_cast<double>(pkt.wind_n), static_cast<double>(pkt.wind_e),
                static_cast<double>(pkt.wind_d));
}
AP_Logger &AP::logger() { return logger_instance; }

int main(int argc, char *argv[])
{
    if (argc != 6 && argc != 8) {
        std::fprintf(stderr, "usage: ardupilot_run DT_S GROUND_S AIR_S HOVER_RPM ROTORS [FAULT_S zero]\n");
        return 2;
    }
    const double dt = std::atof(argv[1]);
    const double ground_s = std::atof(argv[2]);
    const double air_s = std::atof(argv[3]);
    const float hover_rpm = static_cast<float>(std::atof(argv[4]));
    rotor_count = std::atoi(argv[5]);
    const double fault_s = argc == 8 ? std::atof(argv[6]) : 1e300;
    const long steps = static_cast<long>((ground_s + air_s) / dt + 0.5);
    AP_DOBWind library;

    for (long k = 1; k <= steps; k++) {
        now_us = static_cast<uint64_t>(k * dt * 1e6 + 0.5);
        flying = k * dt > ground_s;
        rotor_rpm = flying ? hover_rpm : 0.0f;
        esc1_zero = k * dt > fault_s;
        throttle = flying ? 0.5f : 0.0f; // the hover throttle (0.5 above): the weight
        library.update(0.0f);
        Vector3f wind;
        if (library.get_wind_NED(wind)) {
            std::printf("W %llu %.6g %.6g %.6g\n", static_cast<unsigned long long>(now_us), static_cast<double>(wind.x),
                        static_cast<double>(wind.y), static_cast<double>(wind.z));
        }
    }
    return 0;
}
