// palpa-assess SESSION --json OUT.json --html OUT.html: the assessment of a
// recorded session (docs/ASSESSMENT.md): time, pressure levels, coverage,
// path and phases, lesions found, force against the task's limit, the
// verdict. Uses the results stored with each tick; a session recorded
// without them is replayed first.

#include "app/replay/export.h"
#include "app/replay/session_job.h"
#include "assess/assess.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

using namespace palpa;

const char* kUsage =
    "usage: palpa-assess SESSION [--json OUT.json] [--html OUT.html] [--csv TICKS.csv] [--vtp ORGAN.vtp]\n"
    "                    [--markups OUT.mrk.json]\n"
    "  Assesses a recorded session (docs/ASSESSMENT.md) and prints the verdict;\n"
    "  --json writes the numbers, --html one self-contained report page; exports:\n"
    "  --csv the ticks, --vtp the organ with coverage and peak-force arrays (ParaView,\n"
    "  Slicer), --markups the lesions and marks as Slicer markups.\n";

// Writes atomically: a sibling file, then a rename over `file`.
void write_file(const std::string& file, const std::string& text) {
  const std::string tmp = file + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) {
      std::filesystem::remove(tmp);
      throw std::runtime_error(file + ": cannot write");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    throw std::runtime_error(file + ": cannot write (" + ec.message() + ")");
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string session, json, html, csv, vtp, markups;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "palpa-assess: %s needs a value\n%s", a.c_str(), kUsage);
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--json") {
      json = value();
    } else if (a == "--html") {
      html = value();
    } else if (a == "--csv") {
      csv = value();
    } else if (a == "--vtp") {
      vtp = value();
    } else if (a == "--markups") {
      markups = value();
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "palpa-assess: unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    } else if (session.empty()) {
      session = a;
    } else {
      std::fprintf(stderr, "palpa-assess: one session at a time, got '%s' too\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (session.empty()) {
    std::fprintf(stderr, "palpa-assess: no session file given\n%s", kUsage);
    return 2;
  }
  try {
    app::LoadedSession s = app::load_session(session);
    const app::AssessedSession out = app::assess_session_report(s, session);
    if (out.replayed) std::printf("(no results stored: replayed; %s)\n", app::describe(out.check).c_str());
    const assess::Report& r = out.report;
    std::printf("%s\n", r.verdict.c_str());
    std::printf("exam %.1f s, in contact %.1f s; light / medium / deep %.1f / %.1f / %.1f s; coverage %.1f%% "
                "(light %.1f%%, medium %.1f%%, deep %.1f%%), largest gap %.0f mm across\n",
                r.exam_time, r.contact_time, r.level_time[1], r.level_time[2], r.level_time[3], 100 * r.coverage[0],
                100 * r.coverage[1], 100 * r.coverage[2], 100 * r.coverage[3], 1e3 * r.largest_gap_diameter);
    std::printf("peak force %.2f N, %.2f s over the limit; %zu lesions, %zu marks, sensitivity %.2f, %zu false positives\n",
                r.peak_force, r.time_over_limit, r.lesions.size(), r.marks.size(), r.sensitivity, r.false_positives);
    for (const auto& l : r.lesions)
      std::printf("  %s: %s%s (max contrast %.0f%%)\n", l.name.c_str(), l.found ? "found" : "missed, ",
                  l.found ? "" : l.missed.c_str(), 100 * l.max_contrast);
    if (!json.empty()) write_file(json, assess::to_json(r));
    if (!csv.empty()) app::write_ticks_csv(s, csv);
    if (!vtp.empty()) app::write_coverage_vtp(*out.coverage, vtp);
    if (!markups.empty()) write_file(markups, app::markups_json(r));
    if (!html.empty()) write_file(html, out.html);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-assess: %s\n", e.what());
    return 1;
  }
}
