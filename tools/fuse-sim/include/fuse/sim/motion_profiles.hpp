// Randomised motion styles (spec "Trajectory"): handheld walking (bob at the step frequency,
// lateral sway and roll at half of it, small pitch and yaw oscillation), an aggressive handheld
// sweep (large yaw / pitch / roll swings) and a vehicle (small vibrations, lane wander).
// All draws come from the motion stream of --seed.
#pragma once

#include "fuse/sim/random.hpp"
#include "fuse/sim/trajectory.hpp"

namespace fuse::sim {

/// Walking: step frequency 1.8-2.0 Hz, bob 2-3 cm, sway 1.5-2.5 cm, roll 1-2.5 deg, pitch 1-2 deg.
MotionConfig walking_motion(Rng& rng);
/// Walking plus large rotations (yaw 50-70 deg, pitch 25-35 deg, roll 20-30 deg at 0.6-1.3 Hz).
MotionConfig aggressive_handheld_motion(Rng& rng);
/// Vehicle: bob ~1 cm, lane wander ~5 cm, roll / pitch / yaw vibrations below 1 deg.
MotionConfig vehicle_motion(Rng& rng);

}  // namespace fuse::sim
