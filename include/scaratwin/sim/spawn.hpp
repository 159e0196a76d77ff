// Where the scene spawns a cube when nobody says where: the browser UI's colour buttons and the
// companion dialect's NewObj. A free random spot on the table that the robot can reach at grasp
// height, in the overhead camera's view (so the vision can find it) and off the trays.
#pragma once

#include <random>

#include "scaratwin/core/result.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {

// Places a cube of `color` at a free random spot drawn from `rng`. Errors: the colour's pool is
// used up (SimError::kPoolExhausted), or no free spot was found in 200 tries (kOccupied).
Result<CubeState> spawn_at_random(Simulation& sim, CubeColor color, std::mt19937_64& rng);

}  // namespace scaratwin::sim
