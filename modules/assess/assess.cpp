// The assessment of a recorded session (assess.h, docs/ASSESSMENT.md).

#include "assess/assess.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <sstream>

namespace palpa::assess {

namespace {

double norm(const haptics::Triple& t) { return std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]); }

}  // namespace

struct Assessor::Impl {
  Coverage coverage;
  std::vector<tissue::Lesion> lesions;
  std::vector<tissue::LesionData> lesion_data;
  Task task;
  Options options;
  Report r;
  bool first = true;
  double t0 = 0, last_t = 0;
  struct ProbeTrack {
    bool in_contact = false;
    std::uint32_t episode = 0;
    Vec3 last_point = Vec3::Zero();
    std::deque<std::pair<double, Vec3>> history;  // (time, contact point) over the speed window
  };
  std::array<ProbeTrack, haptics::kMaxProbes> probes;
  std::uint32_t next_episode = 0;
  double contact_force_sum = 0, contact_force_time = 0, search_force_sum = 0, palpation_force_sum = 0;
  std::vector<double> max_contrast, max_contrast_time;

  Impl(std::shared_ptr<const mesh::SurfaceMesh> mesh, std::vector<tissue::Lesion> l, Task t, Options o)
      : coverage(std::move(mesh), o.tip_radius), lesions(std::move(l)), task(t), options(std::move(o)) {
    for (const auto& x : lesions) lesion_data.push_back(tissue::lesion_data(x));
    max_contrast.assign(lesions.size(), 0.0);
    max_contrast_time.assign(lesions.size(), 0.0);
  }
};

Assessor::Assessor(std::shared_ptr<const mesh::SurfaceMesh> mesh, std::vector<tissue::Lesion> lesions, Task task,
                   Options options)
    : impl_(std::make_unique<Impl>(std::move(mesh), std::move(lesions), task, std::move(options))) {}
Assessor::~Assessor() = default;
const Coverage& Assessor::coverage() const { return impl_->coverage; }

void Assessor::add(const haptics::TickRecord& tick, std::span<const haptics::ProbeTickResult> results) {
  Impl& m = *impl_;
  Report& r = m.r;
  if (m.first) {
    m.t0 = m.last_t = tick.time;
    m.first = false;
  }
  // Each tick stands for the time until the next (the first for nothing).
  const double dt = std::max(0.0, tick.time - m.last_t);
  m.last_t = tick.time;
  r.exam_time = tick.time - m.t0;
  ++r.ticks;
  const std::size_t n = std::min<std::size_t>(tick.probe_count, results.size());
  r.probes = std::max(r.probes, n);
  bool any_contact = false;
  for (std::size_t j = 0; j < n; ++j) {
    const haptics::ProbeTickResult& p = results[j];
    Impl::ProbeTrack& track = m.probes[j];
    const double f = norm(p.force_world);
    if (f > r.peak_force) {
      r.peak_force = f;
      r.peak_force_time = tick.time - m.t0;
    }
    if (m.task.force_limit > 0 && f > m.task.force_limit) r.time_over_limit += dt;
    const bool contact = p.in_contact != 0 && p.depth > 0;
    if (!contact) {
      track.in_contact = false;
      track.history.clear();
      r.level_time[0] += dt;
      continue;
    }
    any_contact = true;
    const Vec3 cp = haptics::to_vec(p.contact_point);
    if (!track.in_contact) track.episode = m.next_episode++;
    const Level level = m.coverage.add(cp, p.depth, track.episode, f);
    r.level_time[static_cast<std::size_t>(level)] += dt;
    if (track.in_contact) r.path_length += (cp - track.last_point).norm();
    track.in_contact = true;
    track.last_point = cp;
    m.contact_force_sum += f * dt;
    m.contact_force_time += dt;

    // Search (gliding) or palpation (slow, pressing): the contact point's
    // speed over the last speed_window.
    track.history.emplace_back(tick.time, cp);
    while (track.history.size() > 2 && tick.time - track.history.front().first > m.options.speed_window)
      track.history.pop_front();
    const auto& [t_then, p_then] = track.history.front();
    const double speed = tick.time > t_then ? (cp - p_then).norm() / (tick.time - t_then) : 0.0;
    if (speed >= m.options.glide_speed) {
      r.search_time += dt;
      m.search_force_sum += f * dt;
    } else {
      r.palpation_time += dt;
      m.palpation_force_sum += f * dt;
    }

    // How strongly each lesion was felt: the contrast law at the tip.
    const Index v = m.coverage.nearest(cp);
    const Vec3 tip = cp - p.depth * m.coverage.mesh().normals[v];
    for (std::size_t k = 0; k < m.lesions.size(); ++k) {
      const double c = tissue::lesion_contrast(m.lesion_data[k], tip, p.depth, m.options.tip_radius);
      if (c > m.max_contrast[k]) {
        m.max_contrast[k] = c;
        m.max_contrast_time[k] = tick.time - m.t0;
      }
    }
  }
  if (any_contact) r.contact_time += dt;
}

Report Assessor::finish(const std::vector<record::EventRecord>& events) {
  Impl& m = *impl_;
  Report r = m.r;
  const Coverage& cov = m.coverage;
  const mesh::SurfaceMesh& mesh = cov.mesh();
  const std::size_t nv = mesh.vertex_count();

  // Coverage of the region of interest, by area.
  auto in_roi = [&](Index v) { return m.options.roi.empty() || m.options.roi[v] >= 0.5f; };
  double covered_any = 0, revisited = 0;
  std::array<double, kLevels> at{};
  for (Index v = 0; v < nv; ++v) {
    if (!in_roi(v)) continue;
    const double a = cov.area()[v];
    r.roi_area += a;
    if (cov.highest()[v] != Level::None) {
      covered_any += a;
      if (cov.episodes()[v] >= 2) revisited += a;
    }
    for (std::size_t l = 1; l < kLevels; ++l)
      if (cov.covered(v, static_cast<Level>(l))) at[l] += a;
  }
  if (r.roi_area > 0) {
    r.coverage[0] = covered_any / r.roi_area;
    for (std::size_t l = 1; l < kLevels; ++l) r.coverage[l] = at[l] / r.roi_area;
  }
  r.revisited = covered_any > 0 ? revisited / covered_any : 0;
  // The largest uncovered patch: connected uncovered ROI vertices.
  std::vector<std::uint8_t> done(nv, 0);
  std::vector<Index> queue;
  for (Index s = 0; s < nv; ++s) {
    if (done[s] || !in_roi(s) || cov.highest()[s] != Level::None) continue;
    double area = 0;
    queue.assign(1, s);
    done[s] = 1;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const Index v = queue[q];
      area += cov.area()[v];
      for (Index w : mesh.vertex_neighbors.row(v))
        if (!done[w] && in_roi(w) && cov.highest()[w] == Level::None) {
          done[w] = 1;
          queue.push_back(w);
        }
    }
    r.largest_gap_area = std::max(r.largest_gap_area, area);
  }
  r.largest_gap_diameter = 2 * std::sqrt(r.largest_gap_area / M_PI);

  // Phases and forces.
  r.search_force = r.search_time > 0 ? m.search_force_sum / r.search_time : 0;
  r.palpation_force = r.palpation_time > 0 ? m.palpation_force_sum / r.palpation_time : 0;
  r.force_ratio = r.search_force > 0 && r.palpation_force > 0 ? r.palpation_force / r.search_force : 0;
  r.mean_contact_force = m.contact_force_time > 0 ? m.contact_force_sum / m.contact_force_time : 0;

  // Marks against lesions, one to one: the closest pairs first, within the tolerance.
  for (const auto& e : events) {
    if (e.kind == record::EventKind::Reaction) ++r.reactions;
    if (e.kind == record::EventKind::Fault) ++r.faults;
    if (e.kind == record::EventKind::Unmark) {
      // The trainee deleted a mark: the latest standing one at that point goes.
      const Vec3 p = haptics::to_vec(e.point);
      for (auto it = r.marks.rbegin(); it != r.marks.rend(); ++it)
        if (it->point == p) {
          r.marks.erase(std::next(it).base());
          ++r.marks_deleted;
          break;
        }
      continue;
    }
    if (e.kind != record::EventKind::Mark) continue;
    MarkResult mk;
    mk.point = haptics::to_vec(e.point);
    mk.diameter = e.value;
    mk.consistency = std::string(e.text, strnlen(e.text, sizeof e.text));
    mk.time = e.time - m.t0;
    r.marks.push_back(mk);
  }
  for (std::size_t k = 0; k < m.lesions.size(); ++k) {
    const auto& l = m.lesions[k];
    LesionResult lr;
    lr.name = l.name;
    lr.centre = l.centre;
    lr.diameter = 2 * std::cbrt(l.semi_axes.x() * l.semi_axes.y() * l.semi_axes.z());
    lr.max_contrast = m.max_contrast[k];
    lr.max_contrast_time = m.max_contrast_time[k];
    r.lesions.push_back(lr);
  }
  struct Pair {
    double d;
    std::size_t mark, lesion;
  };
  std::vector<Pair> pairs;
  std::vector<Vec3> above;
  for (const auto& l : m.lesions) above.push_back(surface_point_above(m.coverage.mesh(), l));
  for (std::size_t i = 0; i < r.marks.size(); ++i)
    for (std::size_t k = 0; k < r.lesions.size(); ++k) {
      const double d = mark_distance(r.marks[i].point, m.lesions[k], above[k]);
      if (d <= m.task.position_tolerance) pairs.push_back({d, i, k});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  for (const auto& p : pairs) {
    if (r.marks[p.mark].lesion >= 0 || r.lesions[p.lesion].found) continue;
    r.marks[p.mark].lesion = static_cast<int>(p.lesion);
    LesionResult& lr = r.lesions[p.lesion];
    lr.found = true;
    lr.mark = static_cast<int>(p.mark);
    lr.localisation_error = p.d;
    lr.size_error = r.marks[p.mark].diameter > 0 ? std::abs(r.marks[p.mark].diameter - lr.diameter) / lr.diameter : 1.0;
    lr.time_to_detection = r.marks[p.mark].time;
  }
  std::size_t found = 0;
  double size_part = 0;
  for (auto& lr : r.lesions) {
    if (lr.found) {
      ++found;
      size_part += std::max(0.0, 1.0 - lr.size_error / std::max(1e-9, m.task.size_tolerance));
    } else {
      lr.missed = lr.max_contrast >= m.options.felt_contrast ? "felt but missed" : "never adequately probed";
    }
  }
  for (const auto& mk : r.marks) r.false_positives += mk.lesion < 0 ? 1 : 0;
  r.sensitivity = r.lesions.empty() ? 0 : static_cast<double>(found) / static_cast<double>(r.lesions.size());

  // The score: the scenario's weights over the parts that can be scored.
  r.parts[0] = r.lesions.empty() ? -1 : r.sensitivity;
  r.parts[1] = found > 0 ? size_part / static_cast<double>(found) : (r.lesions.empty() ? -1 : 0);
  r.parts[2] = -1;  // consistency: the scenario gives no expected consistency to compare with
  r.parts[3] = m.task.force_limit > 0 && r.contact_time > 0
                   ? std::max(0.0, 1.0 - r.time_over_limit / std::max(r.contact_time, 1e-12))
                   : -1;
  r.parts[4] = r.coverage[0];
  const double w[5] = {m.task.weight_found, m.task.weight_size, m.task.weight_consistency, m.task.weight_force,
                       m.task.weight_coverage};
  double sw = 0, s = 0;
  for (int k = 0; k < 5; ++k)
    if (r.parts[k] >= 0) {
      sw += w[k];
      s += w[k] * r.parts[k];
    }
  r.score = sw > 0 ? s / sw : 0;
  r.passed = r.score >= m.task.pass_score;
  std::ostringstream v;
  v.precision(2);
  v << std::fixed << (r.passed ? "passed" : "not passed") << ": score " << r.score << " (pass " << m.task.pass_score
    << "); found " << found << " of " << r.lesions.size() << " lesions, " << r.false_positives
    << " false positives, covered " << 100 * r.coverage[0] << "% of the region";
  if (m.task.force_limit > 0) v << ", " << r.time_over_limit << " s over the force limit";
  if (m.task.time_limit > 0 && r.exam_time > m.task.time_limit) v << ", over the time limit";
  r.verdict = v.str();
  return r;
}

// ---- JSON and HTML -------------------------------------------------------------

namespace {

std::string esc(const std::string& s, bool html) {
  std::string o;
  for (char c : s) {
    if (html && c == '<') o += "&lt;";
    else if (html && c == '>') o += "&gt;";
    else if (html && c == '&') o += "&amp;";
    else if (!html && (c == '"' || c == '\\')) { o += '\\'; o += c; }
    else if (!html && static_cast<unsigned char>(c) < 0x20) { char b[8]; std::snprintf(b, sizeof b, "\\u%04x", c); o += b; }
    else o += c;
  }
  return o;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string vec(const Vec3& p) {
  std::string s = "[";
  s += num(p.x());
  s += ", ";
  s += num(p.y());
  s += ", ";
  s += num(p.z());
  s += "]";
  return s;
}

std::string base64(const std::vector<std::uint8_t>& b) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string o;
  for (std::size_t i = 0; i < b.size(); i += 3) {
    const std::uint32_t v = (b[i] << 16) | ((i + 1 < b.size() ? b[i + 1] : 0) << 8) | (i + 2 < b.size() ? b[i + 2] : 0);
    o += t[(v >> 18) & 63];
    o += t[(v >> 12) & 63];
    o += i + 1 < b.size() ? t[(v >> 6) & 63] : '=';
    o += i + 2 < b.size() ? t[v & 63] : '=';
  }
  return o;
}

}  // namespace

Vec3 surface_point_above(const mesh::SurfaceMesh& mesh, const tissue::Lesion& lesion) {
  Index best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    const double d = (mesh.positions[v] - lesion.centre).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = v;
    }
  }
  return mesh.vertex_count() > 0 ? mesh.positions[best] : lesion.centre;
}

double mark_distance(const Vec3& mark, const tissue::Lesion& lesion, const Vec3& surface_point) {
  return std::min((mark - lesion.centre).norm(), (mark - surface_point).norm());
}

std::string to_json(const Report& r) {
  std::ostringstream j;
  j << "{\n  \"format\": \"palpa.assessment/1\",\n";
  j << "  \"session_status\": \"" << r.session_status << "\",\n";
  j << "  \"ticks\": " << r.ticks << ",\n  \"probes\": " << r.probes << ",\n";
  j << "  \"exam_time_s\": " << num(r.exam_time) << ",\n  \"contact_time_s\": " << num(r.contact_time) << ",\n";
  j << "  \"level_time_s\": {\"none\": " << num(r.level_time[0]) << ", \"light\": " << num(r.level_time[1])
    << ", \"medium\": " << num(r.level_time[2]) << ", \"deep\": " << num(r.level_time[3]) << "},\n";
  j << "  \"roi_area_m2\": " << num(r.roi_area) << ",\n";
  j << "  \"coverage\": {\"any\": " << num(r.coverage[0]) << ", \"light\": " << num(r.coverage[1])
    << ", \"medium\": " << num(r.coverage[2]) << ", \"deep\": " << num(r.coverage[3]) << "},\n";
  j << "  \"largest_gap_area_m2\": " << num(r.largest_gap_area) << ",\n  \"largest_gap_diameter_m\": "
    << num(r.largest_gap_diameter) << ",\n  \"revisited_fraction\": " << num(r.revisited) << ",\n";
  j << "  \"path_length_m\": " << num(r.path_length) << ",\n";
  j << "  \"search_time_s\": " << num(r.search_time) << ",\n  \"palpation_time_s\": " << num(r.palpation_time)
    << ",\n  \"search_mean_force_n\": " << num(r.search_force) << ",\n  \"palpation_mean_force_n\": "
    << num(r.palpation_force) << ",\n  \"palpation_to_search_force_ratio\": " << num(r.force_ratio) << ",\n";
  j << "  \"peak_force_n\": " << num(r.peak_force) << ",\n  \"peak_force_time_s\": " << num(r.peak_force_time)
    << ",\n  \"time_over_force_limit_s\": " << num(r.time_over_limit) << ",\n  \"mean_contact_force_n\": "
    << num(r.mean_contact_force) << ",\n  \"reactions\": " << r.reactions << ",\n  \"faults\": " << r.faults << ",\n  \"marks_deleted\": " << r.marks_deleted << ",\n";
  j << "  \"lesions\": [";
  for (std::size_t k = 0; k < r.lesions.size(); ++k) {
    const auto& l = r.lesions[k];
    j << (k ? "," : "") << "\n    {\"name\": \"" << esc(l.name, false) << "\", \"centre_m\": " << vec(l.centre)
      << ", \"diameter_m\": " << num(l.diameter) << ", \"found\": " << (l.found ? "true" : "false")
      << ", \"mark\": " << l.mark << ", \"localisation_error_m\": " << (l.found ? num(l.localisation_error) : "null")
      << ", \"size_error\": " << (l.found ? num(l.size_error) : "null") << ", \"time_to_detection_s\": "
      << (l.found ? num(l.time_to_detection) : "null") << ", \"max_contrast\": " << num(l.max_contrast)
      << ", \"max_contrast_time_s\": " << num(l.max_contrast_time) << ", \"missed\": "
      << (l.missed.empty() ? "null" : "\"" + l.missed + "\"") << "}";
  }
  j << (r.lesions.empty() ? "" : "\n  ") << "],\n  \"marks\": [";
  for (std::size_t k = 0; k < r.marks.size(); ++k) {
    const auto& mk = r.marks[k];
    j << (k ? "," : "") << "\n    {\"point_m\": " << vec(mk.point) << ", \"diameter_m\": " << num(mk.diameter)
      << ", \"consistency\": \"" << esc(mk.consistency, false) << "\", \"time_s\": " << num(mk.time)
      << ", \"lesion\": " << mk.lesion << "}";
  }
  j << (r.marks.empty() ? "" : "\n  ") << "],\n";
  j << "  \"sensitivity\": " << num(r.sensitivity) << ",\n  \"false_positives\": " << r.false_positives << ",\n";
  const char* names[5] = {"found", "size", "consistency", "force", "coverage"};
  j << "  \"score_parts\": {";
  for (int k = 0; k < 5; ++k) j << (k ? ", " : "") << "\"" << names[k] << "\": " << (r.parts[k] < 0 ? "null" : num(r.parts[k]));
  j << "},\n  \"score\": " << num(r.score) << ",\n  \"passed\": " << (r.passed ? "true" : "false")
    << ",\n  \"verdict\": \"" << esc(r.verdict, false) << "\"\n}\n";
  return j.str();
}

std::string to_html(const Report& r, const std::string& title, const std::vector<std::uint8_t>& png,
                    const std::vector<std::pair<double, double>>& curve, double limit) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" << esc(title, true)
    << "</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:60em}table{border-collapse:collapse}"
       "td,th{border:1px solid #bbb;padding:.25em .6em;text-align:left}th{background:#eee}"
       ".pass{color:#070}.fail{color:#a00}</style></head><body>\n";
  h << "<h1>" << esc(title, true) << "</h1>\n<p class=\"" << (r.passed ? "pass" : "fail") << "\"><b>"
    << esc(r.verdict, true) << "</b></p>\n";
  if (!png.empty())
    h << "<h2>Coverage</h2><p>Surface covered within the Hertz contact radius (grey: not covered; green, yellow, "
         "red: light, medium, deep at the highest level reached).</p>\n<img alt=\"coverage map\" src=\"data:image/png;base64,"
      << base64(png) << "\">\n";
  // The force plot.
  if (!curve.empty()) {
    const double W = 800, H = 240, T = std::max(1e-9, curve.back().first);
    double F = limit * 1.25;
    for (const auto& [t, f] : curve) F = std::max(F, f * 1.05);
    if (F <= 0) F = 1;
    h << "<h2>Force</h2><svg width=\"" << W + 60 << "\" height=\"" << H + 40 << "\" xmlns=\"http://www.w3.org/2000/svg\">"
      << "<g transform=\"translate(50,10)\"><rect width=\"" << W << "\" height=\"" << H
      << "\" fill=\"#fafafa\" stroke=\"#999\"/>";
    if (limit > 0) {
      const double y = H - H * limit / F;
      h << "<line x1=\"0\" x2=\"" << W << "\" y1=\"" << y << "\" y2=\"" << y
        << "\" stroke=\"#c00\" stroke-dasharray=\"6,4\"/><text x=\"4\" y=\"" << y - 4
        << "\" font-size=\"12\" fill=\"#c00\">force limit " << num(limit) << " N</text>";
    }
    h << "<polyline fill=\"none\" stroke=\"#036\" stroke-width=\"1.2\" points=\"";
    for (const auto& [t, f] : curve) h << num(W * t / T) << "," << num(H - H * f / F) << " ";
    h << "\"/><text x=\"" << W / 2 << "\" y=\"" << H + 28 << "\" font-size=\"12\">time (s), 0 to " << num(T)
      << "</text><text x=\"-40\" y=\"12\" font-size=\"12\">" << num(F) << " N</text></g></svg>\n";
  }
  auto row = [&](const std::string& k, const std::string& v) { h << "<tr><th>" << k << "</th><td>" << v << "</td></tr>\n"; };
  h << "<h2>Numbers</h2><table>\n";
  row("exam time", num(r.exam_time) + " s");
  row("contact time", num(r.contact_time) + " s");
  row("time light / medium / deep", num(r.level_time[1]) + " / " + num(r.level_time[2]) + " / " + num(r.level_time[3]) + " s");
  row("coverage (any level)", num(100 * r.coverage[0]) + " %");
  row("coverage light / medium / deep", num(100 * r.coverage[1]) + " / " + num(100 * r.coverage[2]) + " / " + num(100 * r.coverage[3]) + " %");
  row("largest uncovered patch", num(r.largest_gap_area * 1e4) + " cm&sup2; (a disk of " + num(r.largest_gap_diameter * 1e3) + " mm)");
  row("revisited", num(100 * r.revisited) + " % of the covered area");
  row("path length in contact", num(r.path_length * 1e3) + " mm");
  row("search / palpation time", num(r.search_time) + " / " + num(r.palpation_time) + " s");
  row("mean force search / palpation", num(r.search_force) + " / " + num(r.palpation_force) + " N (ratio " + num(r.force_ratio) + ")");
  row("peak force", num(r.peak_force) + " N at " + num(r.peak_force_time) + " s");
  row("time over the force limit", num(r.time_over_limit) + " s");
  row("sensitivity", num(r.sensitivity) + " (" + std::to_string(r.false_positives) + " false positives)");
  if (r.marks_deleted > 0) row("marks deleted", std::to_string(r.marks_deleted) + " (not scored)");
  row("score", num(r.score) + (r.passed ? " (passed)" : " (not passed)"));
  h << "</table>\n<h2>Lesions</h2><table><tr><th>lesion</th><th>diameter</th><th>found</th><th>error</th><th>size error</th>"
       "<th>time</th><th>max contrast</th><th>if missed</th></tr>\n";
  for (const auto& l : r.lesions)
    h << "<tr><td>" << esc(l.name, true) << "</td><td>" << num(l.diameter * 1e3) << " mm</td><td>" << (l.found ? "yes" : "no")
      << "</td><td>" << (l.found ? num(l.localisation_error * 1e3) + " mm" : "") << "</td><td>"
      << (l.found ? num(100 * l.size_error) + " %" : "") << "</td><td>" << (l.found ? num(l.time_to_detection) + " s" : "")
      << "</td><td>" << num(100 * l.max_contrast) << " %</td><td>" << l.missed << "</td></tr>\n";
  h << "</table>\n<p>Definitions: docs/ASSESSMENT.md.</p></body></html>\n";
  return h.str();
}

}  // namespace palpa::assess
