// palpa: the Qt5 workbench on the bundled default organ, or on FILE (an
// organ mesh or a scenario .json) with `palpa FILE`. With no display it says
// so and does its job headless: palpates the default organ (or FILE's organ,
// or runs FILE's scenario as `palpa render --scenario FILE` would) and writes
// a PNG. `palpa render [options]` is the headless job with palpa-render's options.

#include "app/gui/main_window.h"
#include "app/render/render_job.h"
#include "app/scenario/scenario_check.h"
#include "haptics/cpu_plan.h"
#include "render/heap.h"

#include <QApplication>
#include <QFileInfo>
#include <QMessageBox>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

namespace {

// The headless job; returns the exit status.
int run_headless(const std::vector<std::string>& args, const char* default_output) {
  try {
    bool help = false;
    auto options = palpa::app::parse_render_args(args, &help);
    if (help) {
      std::cout << palpa::app::render_usage("palpa render");
      return 0;
    }
    bool has_output = false;
    for (const auto& a : args) has_output |= a == "--output";
    if (!has_output) options.output = default_output;
    palpa::app::run_render_job(options, std::cout);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa: %s\n", e.what());
    return 1;
  }
}

bool have_display() {
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (w && *w);
}

// `palpa FILE [options]`: the first argument names a file to open.
bool names_file(const std::vector<std::string>& args) {
  return !args.empty() && !args[0].empty() && args[0][0] != '-';
}

bool is_scenario(const std::string& path) { return QFileInfo(QString::fromStdString(path)).suffix().toLower() == "json"; }

}  // namespace

int main(int argc, char** argv) {
  // Mesa's software renderer frees and allocates its buffers every frame:
  // keep the freed heap in the process (render/heap.h).
  palpa::render::keep_freed_heap();
  std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && args[0] == "render") return run_headless({args.begin() + 1, args.end()}, "palpa-render.png");
  if (!args.empty() && args[0] == "scenario")
    return palpa::app::run_scenario_command({args.begin() + 1, args.end()}, "palpa scenario", std::cout, std::cerr);
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    std::cout << "usage: palpa              the workbench window on the default organ\n"
                 "       palpa FILE         the workbench on FILE: an organ mesh, or a scenario (.json) it runs\n"
                 "       palpa render ...   render to PNG with no display (palpa render --help)\n"
                 "       palpa scenario check FILE   validate a scenario file and print its summary\n"
                 "With no display, palpa palpates the default organ headless and writes palpa-headless.png\n"
                 "(options as for palpa render); palpa FILE.json then runs the scenario as\n"
                 "palpa render --scenario FILE.json would, palpa MESH palpates that organ.\n";
    return 0;
  }
  const std::string file = names_file(args) ? args[0] : std::string();
  if (!have_display()) {
    if (file.empty()) {
      std::cout << "palpa: no display (DISPLAY is not set), so no window; running headless instead: "
                   "palpating the default organ and writing a PNG\n"
                << std::flush;
      return run_headless(args, "palpa-headless.png");
    }
    // FILE headless: a scenario as `palpa render --scenario FILE`, a mesh as `--mesh FILE`.
    const bool scenario = is_scenario(file);
    std::cout << "palpa: no display (DISPLAY is not set), so no window; running headless instead: "
              << (scenario ? "running the scenario " : "palpating the organ ") << file
              << " and writing a PNG (as palpa render " << (scenario ? "--scenario " : "--mesh ") << file
              << " would)\n"
              << std::flush;
    std::vector<std::string> job = {scenario ? "--scenario" : "--mesh", file};
    job.insert(job.end(), args.begin() + 1, args.end());
    return run_headless(job, "palpa-headless.png");
  }

  // One CPU for the haptic thread, every other thread (Qt's, VTK's,
  // llvmpipe's workers, the deformation) on the others: before any of them
  // starts.
  const palpa::haptics::CpuPlan plan = palpa::haptics::reserve_haptic_cpu();
  std::printf("palpa: %s\n", plan.note.c_str());
  std::printf("palpa: %s\n",
              palpa::haptics::haptic_spin(palpa::app::Workbench::kHapticRateHz, plan.haptic_cpu).note.c_str());
  if (const std::string memory = palpa::haptics::memory_monitor_notice(palpa::haptics::running_memory_monitors());
      !memory.empty())
    std::printf("palpa: %s\n", memory.c_str());
  std::fflush(stdout);
  palpa::app::configure_application_defaults();
  QApplication app(argc, argv);
  palpa::app::MainWindow window;
  window.resize(1280, 800);
  window.show();
  // `palpa FILE`: open it over the default organ; a failure says why, naming the file.
  if (!file.empty() && !window.open_file(QString::fromStdString(file))) {
    std::fprintf(stderr, "palpa: %s\n", window.error_text().toStdString().c_str());
    QMessageBox::critical(&window, "Palpa: could not open " + QString::fromStdString(file), window.error_text());
  }
  // No FILE: the scenario opened last, if any (QSettings session/last_scenario).
  if (file.empty()) window.reopen_last_scenario();
  return app.exec();
}
