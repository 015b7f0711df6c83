"""Physical constants and TORCS's clock: the one place they are defined.

Sources: TORCS 1.3.7 calls a robot's drive every 0.02 s of simulated time and steps its physics
every 0.002 s (src/interfaces/raceman.h, RCM_MAX_DT_ROBOTS and RCM_MAX_DT_SIMU); the tutorial's
car model takes air density as 1.23 kg/m^3 for the wings' downforce (robot tutorial, chapter
"Aerodynamics").
"""

from __future__ import annotations

# 9.81 rather than TORCS's own 9.80665 (tgf.h): every figure measured so far was made with it
G_MPS2 = 9.81
AIR_DENSITY_KGPM3 = 1.23
DRIVE_STEP_S = 0.02  # simulated time between two drive calls
SIM_STEP_S = 0.002  # simulated time of one physics step
# litres of fuel an engine burns per joule of its work (|torque| x engine speed, driving or engine
# braking), times the car's fuel consumption factor: simuv2 engine.cpp, SimEngineUpdateTq
FUEL_L_PER_J = 1e-7
# the units TORCS's car files write spring and damper rates in (lbs/in: TORCS's pound is a mass)
INCH_M = 0.0254
POUND_KG = 0.45359237
