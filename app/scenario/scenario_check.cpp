// The scenario commands shared by `palpa scenario` and `palpa-scenario`.

#include "app/scenario/scenario_check.h"

#include "scenario/scenario.h"

#include <ostream>

namespace palpa::app {

int run_scenario_command(const std::vector<std::string>& args, const std::string& program, std::ostream& out,
                         std::ostream& err) {
  const std::string usage = "usage: " + program + " check FILE    validate a scenario file and print its summary\n" +
                            "       " + program + " format FILE   rewrite it in the canonical layout (same content)\n";
  if (args.size() == 1 && (args[0] == "--help" || args[0] == "-h")) {
    out << usage;
    return 0;
  }
  if (args.size() != 2 || (args[0] != "check" && args[0] != "format")) {
    err << usage;
    return 2;
  }
  try {
    scenario::Scenario s = scenario::load_scenario(args[1]);
    if (args[0] == "format") {
      scenario::save_scenario(s, args[1]);
      out << args[1] << ": written in the canonical layout\n";
      return 0;
    }
    out << args[1] << ": valid\n" << scenario::summary(s);
    return 0;
  } catch (const std::exception& e) {
    err << e.what() << "\n";
    return 1;
  }
}

}  // namespace palpa::app
