// palpa-render: renders an organ pressed by probes to a PNG with no display
// (OSMesa by default, EGL on a GPU). See app/render/render_job.h.

#include "app/render/render_job.h"
#include "render/heap.h"

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  // Mesa's software renderer frees and allocates its buffers every frame:
  // keep the freed heap in the process (render/heap.h).
  palpa::render::keep_freed_heap();
  std::vector<std::string> args(argv + 1, argv + argc);
  try {
    bool help = false;
    const auto options = palpa::app::parse_render_args(args, &help);
    if (help) {
      std::cout << palpa::app::render_usage("palpa-render");
      return 0;
    }
    palpa::app::run_render_job(options, std::cout);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-render: %s\n", e.what());
    return 1;
  }
}
