// palpa-assess SESSION --json OUT.json --html OUT.html: the assessment of a
// recorded session (docs/ASSESSMENT.md): time, pressure levels, coverage,
// path and phases, lesions found, force against the task's limit, the
// verdict. Uses the results stored with each tick; a session recorded
// without them is replayed first.

#include "app/replay/export.h"
#include "app/replay/overlay.h"
#include "app/replay/session_job.h"
#include "assess/assess.h"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
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
    const auto& h = s.file.header();
    assess::Options opt;
    opt.tip_radius = s.tip_radius;
    opt.roi = s.roi;
    assess::Assessor a(s.model->mesh, s.lesions, s.task, opt);
    std::vector<std::pair<double, double>> curve;  // (s, max |F| over 50 ms)
    double t0 = 0;
    bool first = true;
    auto add = [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r) {
      a.add(t, r);
      if (first) {
        t0 = t.time;
        first = false;
      }
      double f = 0;
      for (const auto& p : r) f = std::max(f, haptics::to_vec(p.force_world).norm());
      const double bucket = std::floor((t.time - t0) / 0.05) * 0.05;
      if (curve.empty() || curve.back().first < bucket)
        curve.emplace_back(bucket, f);
      else
        curve.back().second = std::max(curve.back().second, f);
    };
    // The stored results, or a replay when the file has none.
    const std::uint64_t first_tick = s.first_tick;  // 0 unless recorded from a running loop
    const bool stored = h.ticks > 0 && !s.file.ticks(first_tick, first_tick + 1).results.empty();
    if (stored) {
      for (std::uint64_t w = first_tick; w < first_tick + h.ticks; w += 20000) {
        const auto span = s.file.ticks(w, w + 20000);
        if (span.ticks.empty() || span.results.size() != span.ticks.size()) break;
        for (std::size_t k = 0; k < span.ticks.size(); ++k)
          add(span.ticks[k], std::span<const haptics::ProbeTickResult>(span.results[k].data(), span.ticks[k].probe_count));
      }
    } else if (h.ticks > 0) {
      app::ForceCheck check;
      app::replay_session(s, first_tick, first_tick + h.ticks, [&](const auto& t, auto r, const auto&) { add(t, r); }, check);
      std::printf("(no results stored: replayed; %s)\n", app::describe(check).c_str());
    }
    assess::Report r = a.finish(s.file.events());
    r.session_status = std::string(record::status_name(h.status));
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
    if (!vtp.empty()) app::write_coverage_vtp(a.coverage(), vtp);
    if (!markups.empty()) write_file(markups, app::markups_json(r));
    if (!html.empty()) {
      std::vector<std::uint8_t> png;
      cv::imencode(".png", app::coverage_map(a.coverage(), Vec3(0, -std::sin(0.61), std::cos(0.61)), Vec3::UnitZ(), 480),
                   png);
      const std::string title = "Palpa assessment: " + (s.scenario_title.empty() ? session : s.scenario_title) +
                                (h.info.trainee.empty() ? "" : " (" + h.info.trainee + ")");
      write_file(html, assess::to_html(r, title, png, curve, s.force_limit));
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-assess: %s\n", e.what());
    return 1;
  }
}
