#pragma once
// palpa-palpate --record SESSION: the scripted job's session recorded into
// a session file (modules/record), the same format the workbench writes.
// The job steps its Session through record::record_step instead of
// Session::step, so the file holds every tick, command, deformation step
// and a snapshot every few seconds.

#include "haptics/session.h"
#include "record/recorder.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace palpa::app {

/// Opens a recorder on `file` for a session of `model` (headless: the job
/// waits for the writer rather than dropping records). Throws
/// record::RecordError naming the file.
std::unique_ptr<record::Recorder> open_recording(const std::string& file, const haptics::SessionModel& model,
                                                 const deform::MaterialArrays& initial,
                                                 const std::vector<haptics::ProbeSetup>& setups,
                                                 const record::SessionInfo& info);

/// Finishes the recording and prints its size: ticks, bytes of tick data per
/// probe-tick, and what an hour at the session's rate would take.
void close_recording(record::Recorder& recorder, std::FILE* out);

/// What the session file says of the session: the organ's name and, with a
/// scenario, its file, JSON text (read from the file as it is) and force limit (N).
record::SessionInfo session_info(const std::string& organ, const std::string& scenario_file = {}, double force_limit = 0);

}  // namespace palpa::app
