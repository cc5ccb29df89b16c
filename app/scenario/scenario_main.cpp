// palpa-scenario: checks (and reformats) scenario files with no display and
// no Qt; the same as `palpa scenario ...`.

#include "app/scenario/scenario_check.h"

#include <iostream>

int main(int argc, char** argv) {
  return palpa::app::run_scenario_command({argv + 1, argv + argc}, "palpa-scenario", std::cout, std::cerr);
}
