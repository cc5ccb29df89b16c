// palpa-render: renders an organ pressed by probes to a PNG with no display
// (OSMesa by default, EGL on a GPU). See render/render_job.h.

#include "mesh/io.h"
#include "render/render_job.h"

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  try {
    bool help = false;
    const auto options = palpa::render::parse_render_args(args, &help);
    if (help) {
      std::cout << palpa::render::render_usage("palpa-render");
      return 0;
    }
    palpa::render::run_render_job(options, std::cout);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-render: %s\n", e.what());
    return 1;
  }
}
