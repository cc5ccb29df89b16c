#pragma once
// Exports of a session for other tools: the ticks as CSV, the organ with
// its coverage and peak-force arrays as VTP (ParaView, 3D Slicer), and the
// lesions and marks as a 3D Slicer markups file (.mrk.json).

#include "app/replay/session_job.h"
#include "assess/assess.h"

#include <string>

namespace palpa::app {

/// One row per tick and probe: tick, time_s, probe, the device sample
/// (position_m xyz), the command sent (force_device_n xyz), flags, and with
/// results the world position, force on the probe, contact point (organ
/// frame), depth and in_contact. Throws std::runtime_error naming the file.
void write_ticks_csv(const LoadedSession& s, const std::string& file);

/// The organ (undeformed, m) with point arrays coverage_level (0 none, 1
/// light, 2 medium, 3 deep: the highest reached), peak_force_n, episodes and
/// thickness_m. Throws std::runtime_error naming the file.
void write_coverage_vtp(const assess::Coverage& coverage, const std::string& file);

/// The lesions (one list) and the marks (another) as Slicer markups
/// fiducials, in millimetres in the organ frame (declared RAS).
std::string markups_json(const assess::Report& r);

}  // namespace palpa::app
