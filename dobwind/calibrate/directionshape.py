"""The drag law's direction shape when the calibration flight cannot tell it: the simulator's, for a log of
ArduPilot SITL's multicopter.

A flight that met the air from one or two directions (a mission flown along one track in a steady wind)
does not identify the direction harmonics (dragfit.direction_coverage), and the fit then writes an
isotropic law: the force the flight saw along its directions, the same from every side. For a real
vehicle that is the fairest guess. A log of ArduPilot's SITL is not a real vehicle: its physics are
the simulator's source. Its multicopter frames (libraries/SITL/SIM_Frame.cpp, Frame::calculate_forces,
every version since its frame model, ArduPilot pull request 15613 of October 2020: 4.1 to master) apply
the body drag on each BODY axis separately, areaCd 0.5 rho v_i |v_i| for i = x, y, z, and the momentum
drag linear in each axis's airflow with the same factor on x and y (4.1-4.2: mdrag_coef |v_i|
sqrt(|T_z| rho disc_area) in Frame::calculate_forces; 4.3 on: per motor in SIM_Motor.cpp), so isotropic
in the rotor plane. (4.0 and older apply only a linear, isotropic air resistance, -v g / terminal_velocity:
there the shape stands for no per-axis drag and acts only through whatever q0 the fit finds.) The
quadratic part is not isotropic: with the airflow a = s (cos t, sin t) in the body frame, the in-plane
force c s^2 (|cos t| cos t, |sin t| sin t) has

    along a:          c s^2 (|cos t|^3 + |sin t|^3)    mean 8/(3 pi), cos 4t coefficient 16/(35 pi)
    across a (+90):   c s^2 cos t sin t (|sin t| - |cos t|)               sin 4t coefficient -64/(105 pi)

(the integrals of cos^3 t against cos t and cos 4t: tests/test_directionshape.py checks them against
a numerical Fourier series and the law against the per-axis force). In the law's terms (model/forceair.py:
P = q0 s + q4c s cos 4t, Q = q4s s sin 4t) that is q4c = (6/35) q0 and q4s = -(8/35) q0, leaving the 8t
harmonics (0.5 % and 1.4 % of the mean). An isotropic law fitted on air from the nose reads the force at
45 deg to the axes 1/0.71 too high (ArduPilot's per-axis drag is 2 (1/sqrt 2)^3 = 0.71 of the along-axis
one there), so the wind from there too low.

Both drag frames carry the shape: the heading frame's law sees the per-body-axis force through the
vehicle's tilt, which shrinks the along-airflow harmonic (its true ratio is 0.16 at 20 deg, 0.14 at 30),
yet tied at the level ratios it reads tilted air at the diagonals within 2 % up to 30 deg, as the body
frame's does (tests/test_directionshape.py, both frames at a SITL flight's tilt).

With this shape the fit keeps its one quadratic coefficient q0 and ties the harmonics to it
(dragfit.tie_to_q0): the same number of free parameters as the isotropic law, the shape from the
simulator. Applied only when the flight does not identify the harmonics; a flight that does fits them.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class DirectionShape:
    """Fixed ratios of direction harmonics to the isotropic quadratic coefficient q0, and where they come from."""
    ratios: tuple[tuple[str, float], ...]   # (harmonic key, its value / q0)
    source: str                             # said in the fit's report

    def text(self) -> str:
        ratios = ", ".join(f"{key} = {ratio:+.4f} q0" for key, ratio in self.ratios)
        return f"{self.source} ({ratios})"


ARDUPILOT_SITL = DirectionShape(
    ratios=(("q4c", 6.0 / 35.0), ("q4s", -8.0 / 35.0)),
    source="ArduPilot SITL's per-body-axis quadratic drag, libraries/SITL/SIM_Frame.cpp")
