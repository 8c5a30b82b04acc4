"""Every code block in docs/integration.md compiles against stub autopilot headers written here and the
real generated code (generated_c/m300); the bare-metal loop is also linked and run."""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.helpers import ROOT

DOC = ROOT / "docs" / "integration.md"
GENERATED = ROOT / "generated_c" / "m300"
FLAGS = ["-Wall", "-Wextra", "-Werror", "-Wno-unused-parameter"]

# What each autopilot provides, reduced to the declarations the guide uses (names and types as the
# autopilots spell them).
STUBS = {
    "board.h": """#include <stdint.h>
typedef struct { float vel_ned[3], acc_ned[3], q[4], rpm[4], yaw_setpoint; } board_nav_t;
uint64_t board_time_us(void);
int board_read_nav(board_nav_t *nav);
int board_landed(void);
void board_publish(float wind_n, float wind_e, float sigma_h, int trusted);
""",
    "drivers/drv_hrt.h": "#pragma once\n#include <stdint.h>\ntypedef uint64_t hrt_abstime;\nhrt_abstime hrt_absolute_time();\n",
    "uORB/Subscription.hpp": """#pragma once
#define ORB_ID(name) #name
namespace uORB {
class Subscription {
public:
    explicit Subscription(const char *name) : _name(name) {}
    template <class T> bool update(T *data) { return _name == nullptr && data != nullptr; }
    template <class T> bool copy(T *data) { return _name == nullptr && data != nullptr; }
private:
    const char *_name;
};
}
""",
    "uORB/Publication.hpp": """#pragma once
#ifndef ORB_ID
#define ORB_ID(name) #name
#endif
namespace uORB {
template <class T> class Publication {
public:
    explicit Publication(const char *name) : _name(name) {}
    bool publish(const T &data) { return _name != nullptr && &data != nullptr; }
private:
    const char *_name;
};
}
""",
    "uORB/topics/vehicle_attitude.h": "#pragma once\n#include <stdint.h>\nstruct vehicle_attitude_s { uint64_t timestamp; float q[4]; };\n",
    "uORB/topics/vehicle_local_position.h": "#pragma once\n#include <stdint.h>\nstruct vehicle_local_position_s { uint64_t timestamp; float vx, vy, vz, ax, ay, az; };\n",
    "uORB/topics/vehicle_attitude_setpoint.h": "#pragma once\n#include <stdint.h>\nstruct vehicle_attitude_setpoint_s { uint64_t timestamp; float yaw_body; };\n",
    "uORB/topics/vehicle_land_detected.h": "#pragma once\n#include <stdint.h>\nstruct vehicle_land_detected_s { uint64_t timestamp; bool landed, maybe_landed, ground_contact; };\n",
    "uORB/topics/esc_status.h": """#pragma once
#include <stdint.h>
struct esc_report_s { uint64_t timestamp; int32_t esc_rpm; };
struct esc_status_s { uint64_t timestamp; uint8_t esc_count; uint8_t esc_online_flags; esc_report_s esc[8]; };
""",
    "uORB/topics/wind.h": """#pragma once
#include <stdint.h>
struct wind_s { uint64_t timestamp, timestamp_sample; float windspeed_north, windspeed_east, variance_north,
                variance_east, tas_innov, tas_innov_var, beta_innov, beta_innov_var; uint8_t source; };
""",
    "AP_Math/AP_Math.h": """#pragma once
#define GRAVITY_MSS 9.80665f
class Vector3f { public: float x, y, z; Vector3f() : x(0), y(0), z(0) {} Vector3f(float a, float b, float c) : x(a), y(b), z(c) {} };
class Quaternion { public: float q1, q2, q3, q4; Quaternion() : q1(1), q2(0), q3(0), q4(0) {} };
""",
    "AP_AHRS/AP_AHRS.h": """#pragma once
#include <AP_Math/AP_Math.h>
class AP_AHRS {
public:
    bool get_velocity_NED(Vector3f &vec) const;
    bool get_quaternion(Quaternion &quat) const;
    const Vector3f &get_accel_ef() const;
};
namespace AP { AP_AHRS &ahrs(); }
""",
    "AP_ESC_Telem/AP_ESC_Telem.h": """#pragma once
#include <stdint.h>
class AP_ESC_Telem { public: bool get_rpm(uint8_t esc_index, float &rpm) const; };
namespace AP { AP_ESC_Telem &esc_telem(); }
""",
}

# The bare-metal loop's board: 200 steps of hover in still air at the rpm whose nominal thrust is m g.
BOARD = """#include <math.h>
#include <stdio.h>
#include "board.h"
void wind_task_init(void);
void wind_task_run(void);
static uint64_t now = 1000000;
static int published, trusted_count;
static float last_n = 99.0f, last_e = 99.0f;
uint64_t board_time_us(void) { return now; }
int board_landed(void) { return 0; }
int board_read_nav(board_nav_t *nav) {
    int i;
    for (i = 0; i < 3; i++) { nav->vel_ned[i] = 0.0f; nav->acc_ned[i] = 0.0f; }
    nav->q[0] = 1.0f; nav->q[1] = nav->q[2] = nav->q[3] = 0.0f;
    for (i = 0; i < 4; i++) nav->rpm[i] = HOVER_RPM;
    nav->yaw_setpoint = 0.0f;
    return 1;
}
void board_publish(float n, float e, float sigma_h, int trusted) {
    (void)sigma_h; published++; trusted_count += trusted; last_n = n; last_e = e;
}
int main(void) {
    int k;
    wind_task_init();
    for (k = 0; k < 500; k++) { wind_task_run(); now += 10000; }
    printf("%d %d %.6f %.6f\\n", published, trusted_count, last_n, last_e);
    return 0;
}
"""


def _blocks() -> list[tuple[str, str, str]]:
    """(language, path, code) of every ```c / ```cpp block; the first line names the file."""
    out = []
    for lang, code in re.findall(r"```(c|cpp)\n(.*?)```", DOC.read_text(), re.S):
        first = code.splitlines()[0].strip()
        name = first.removeprefix("//").removeprefix("/*").removesuffix("*/").strip()
        out.append((lang, name, code))
    return out


def _tree(tmp_path: Path) -> Path:
    inc = tmp_path / "include"
    for rel, text in STUBS.items():
        (inc / rel).parent.mkdir(parents=True, exist_ok=True)
        (inc / rel).write_text(text)
    for lang, name, code in _blocks():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(code)
    return inc


def test_the_guide_has_the_three_integrations():
    names = [name for _, name, _ in _blocks()]
    assert names == ["app/wind_task.c", "src/modules/dob_wind/DobWind.cpp", "libraries/AP_DOBWind/AP_DOBWind.h",
                     "libraries/AP_DOBWind/AP_DOBWind.cpp"]


@pytest.mark.skipif(shutil.which("g++") is None, reason="needs g++ (installed on CI by .ci/run)")
def test_every_cpp_block_compiles_against_the_stubs_and_the_generated_header(tmp_path):
    inc = _tree(tmp_path)
    for lang, name, _ in _blocks():
        if lang != "cpp" or not name.endswith(".cpp"):
            continue
        src = tmp_path / name
        done = subprocess.run(["g++", "-std=c++14", *FLAGS, "-Wno-address", "-Wno-nonnull-compare", "-c", str(src),
                               "-I", str(inc), "-I", str(GENERATED), "-I", str(src.parent), "-o", str(src) + ".o"],
                              capture_output=True, text=True)
        assert done.returncode == 0, f"{name}:\n{done.stderr}"


def test_the_bare_metal_loop_links_with_the_generated_code_and_runs(tmp_path):
    from dobwind.model.airframe import load_airframe
    import numpy as np

    inc = _tree(tmp_path)
    af = load_airframe(ROOT / "airframes" / "m300.toml")
    # Hover rpm: per-rotor thrust polynomial in Omega = rpm / max_rpm equal to m g / rotors (scale included).
    c = np.array(af.thrust.coefficients) * af.thrust.scale
    roots = np.roots(np.r_[c[::-1][:-1], c[0] - af.mass_kg * af.gravity_mps2 / af.thrust.rotors])
    omega = max(r.real for r in roots if abs(r.imag) < 1e-9 and r.real > 0)
    (tmp_path / "board.c").write_text(BOARD)
    exe = tmp_path / "loop"
    done = subprocess.run(["cc", "-std=c99", *FLAGS, f"-DHOVER_RPM={omega * af.thrust.max_rpm:.6f}f",
                           str(tmp_path / "app" / "wind_task.c"), str(tmp_path / "board.c"), str(GENERATED / "m300_wind.c"),
                           "-I", str(inc), "-I", str(GENERATED), "-lm", "-o", str(exe)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    published, trusted, north, east = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    # 500 accepted steps; trusted once the 3.5 s settling time has passed; hovering in still air with the
    # force offset and envelope of the airframe: a small wind.
    assert int(published) == 500 and 100 < int(trusted) < 200
    assert abs(float(north)) < 0.5 and abs(float(east)) < 0.5
