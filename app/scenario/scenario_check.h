#pragma once
// `palpa scenario check FILE` and `palpa-scenario check FILE`: one
// implementation for both (docs/SCENARIO.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace palpa::app {

/// Runs a scenario command: `check FILE` validates the file and prints its
/// summary to `out` (exit status 0), or prints the error to `err` (1);
/// `format FILE` rewrites it in the canonical layout (atomically);
/// `--help` prints the usage. `program` names the command in messages.
int run_scenario_command(const std::vector<std::string>& args, const std::string& program, std::ostream& out,
                         std::ostream& err);

}  // namespace palpa::app
