// palpa-palpate --record (record_job.h).

#include "app/cli/record_job.h"

#include "record/session_file.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace palpa::app {

std::unique_ptr<record::Recorder> open_recording(const std::string& file, const haptics::SessionModel& model,
                                                 const deform::MaterialArrays& initial,
                                                 const std::vector<haptics::ProbeSetup>& setups,
                                                 const record::SessionInfo& info) {
  record::RecorderOptions o;
  o.block_when_full = true;  // no real-time thread here: never drop
  return std::make_unique<record::Recorder>(file, model, initial, setups, info, o);
}

void close_recording(record::Recorder& recorder, std::FILE* out) {
  recorder.finish();
  const auto f = record::SessionFile::open(recorder.file());
  const auto& h = f.header();
  const auto size = f.storage();
  const std::size_t probes = h.setups.size();
  const double probe_ticks = static_cast<double>(h.ticks) * static_cast<double>(std::max<std::size_t>(1, probes));
  const double per = probe_ticks > 0 ? static_cast<double>(size.tick_bytes) / probe_ticks : 0;
  std::fprintf(out,
               "recorded %s: %llu ticks x %zu probes, %s; file %.2f MB (ticks %.2f MB, mesh %.2f MB, snapshots %.2f MB)\n"
               "  %.1f bytes per probe-tick; at %.0f Hz with %zu probes: %.0f MB per hour of ticks\n",
               recorder.file().c_str(), static_cast<unsigned long long>(h.ticks), probes,
               std::string(record::status_name(h.status)).c_str(), size.file_bytes / 1e6, size.tick_bytes / 1e6,
               size.mesh_bytes / 1e6, size.snapshot_bytes / 1e6, per, h.config.rate_hz, probes,
               per * h.config.rate_hz * 3600.0 * static_cast<double>(probes) / 1e6);
}

record::SessionInfo session_info(const std::string& organ, const std::string& scenario_file, double force_limit) {
  record::SessionInfo info;
  info.organ = organ;
  info.scenario_file = scenario_file.empty() ? std::string() : std::filesystem::absolute(scenario_file).string();
  info.force_limit = force_limit;
  if (!scenario_file.empty()) {
    std::ifstream in(scenario_file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    info.scenario_json = s.str();
  }
  const char* user = std::getenv("PALPA_TRAINEE");
  if (user) info.trainee = user;
  return info;
}

}  // namespace palpa::app
