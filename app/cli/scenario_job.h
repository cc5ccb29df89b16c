#pragma once
// palpa-palpate --scenario FILE: runs a scenario headless with scripted
// probes, or (--indent X,Y,Z --depths FROM:TO:STEP --json OUT) presses one
// probe quasi-statically along the inward normal at the surface point
// nearest to X,Y,Z and writes the force at each depth.

#include <string>
#include <vector>

namespace palpa::app {

/// Runs the scenario job with the command line's arguments (without the
/// program name); returns the exit status (0 done, 1 failed, 2 bad usage).
int scenario_main(const std::vector<std::string>& args);

}  // namespace palpa::app
