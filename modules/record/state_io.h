#pragma once
// Binary forms of the engine's plain data for the session file: the whole
// SessionState (snapshots for seeking), per-vertex material maps, commands
// and the probe setups.
//
// The fixed-size plain structs (CoreState, LoopCommand, ProbeSetup's spec,
// mapping and limits, Contact, VertexState, Material) are written byte for
// byte, the vectors as a count and their elements, the pointers replaced by
// what they point to (a material map inline, the model's tissue map by a
// flag, a SetTissue's tissue map and field inline, field by field), and the
// whole deflated. Byte-for-byte structs tie a file to the
// layout of the build that wrote it: layout_tag() names that layout, the
// session file stores it, and a reader of another layout refuses the
// snapshots and commands with a message that says so (the ticks, events and
// mesh, stored as columns of numbers, read on any build).

#include "record/format.h"
#include "deform/material.h"
#include "haptics/session.h"

#include <deque>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpa::record {

/// The sizes of the structs written byte for byte, e.g.
/// "x86_64-le CoreState=3392 LoopCommand=728 ...".
std::string layout_tag();

/// A decoded snapshot: the state, and the material map its pending edit
/// names (kept alive here; null when none), which must outlive any session
/// restored from it.
struct DecodedState {
  haptics::SessionState state;
  std::shared_ptr<const deform::MaterialArrays> pending_map;
  /// Deformation steps a replay had asked for and not yet made (a snapshot
  /// of a replay of a running loop's recording; empty otherwise).
  std::deque<haptics::DeformRequest> pending;
};

/// `s` as bytes (deflated), with the replay's `pending` steps after it when
/// there are any (a state without them encodes as before). A pending step
/// may carry a reset or a uniform material edit, not a map or a tissue:
/// std::invalid_argument otherwise.
std::vector<std::uint8_t> encode_state(const haptics::SessionState& s,
                                       const std::deque<haptics::DeformRequest>& pending = {});
/// The most pending deformation steps a snapshot holds (a reader refuses
/// more as damaged).
inline constexpr std::uint32_t kMaxPendingSteps = 4096;
/// Whether encode_state can store `pending`: no map or tissue edit in it, at
/// most kMaxPendingSteps steps.
bool storable(const std::deque<haptics::DeformRequest>& pending);
/// The state back; `model` gives the tissue map a state that used the
/// model's refers to. The SetTissue tissues and maps it names are owned by
/// the decoded state (SessionState::tissue, surface_tissue, pending_tissue_map). Throws DecodeError (bad bytes, a tissue map the
/// model lacks, a vertex count that is not the model's).
DecodedState decode_state(std::span<const std::uint8_t> blob, const haptics::SessionModel& model);

/// A per-vertex material map as bytes (deflated), and back (`vertices`
/// entries expected). Throws DecodeError.
std::vector<std::uint8_t> encode_materials(const deform::MaterialArrays& m);
deform::MaterialArrays decode_materials(std::span<const std::uint8_t> blob, std::size_t vertices);

/// A command as bytes (a SetMaterialMap's map, a SetTissue's tissue inline),
/// and back: the map of a SetMaterialMap is put in `keep` and the command
/// points to it; the tissue of a SetTissue is kept there too (by a pointer
/// that owns it and points to no map). Throws DecodeError naming what is
/// wrong (a count over its limit, an array that does not fit the mesh, a
/// tissue validate_tissue refuses, bytes missing).
std::vector<std::uint8_t> encode_command(const haptics::LoopCommand& c);
haptics::LoopCommand decode_command(std::span<const std::uint8_t> blob, std::size_t vertices,
                                    std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep);

/// Probe setups, core configuration and surface options as bytes, and back.
std::vector<std::uint8_t> encode_setup(const std::vector<haptics::ProbeSetup>& setups, const haptics::CoreConfig& config,
                                       const deform::SurfaceOptions& options);
void decode_setup(std::span<const std::uint8_t> blob, std::vector<haptics::ProbeSetup>& setups,
                  haptics::CoreConfig& config, deform::SurfaceOptions& options);

}  // namespace palpa::record
