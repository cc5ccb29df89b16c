#pragma once
// From a scenario file to a session: the organ loaded (and its hash
// checked), lesions placed (from surface points, seeded random ones), the
// tissue map evaluated onto the vertices, the tissue field built, and the
// session model that runs it.

#include "haptics/session.h"
#include "mesh/organ.h"
#include "scenario/scenario.h"

#include <memory>
#include <vector>

namespace palpa::scenario {

/// A scenario made concrete for one organ mesh.
struct Resolved {
  Scenario scenario;
  mesh::Organ organ;
  std::vector<tissue::Lesion> lesions;   ///< every lesion, placed (what a session records)
  std::vector<deform::Material> tissues; ///< per scenario tissue, the Hertz local model for the probe
  std::size_t base = 0;                  ///< index of the base tissue
  std::shared_ptr<const deform::MaterialMap> materials;  ///< per-vertex tissue map
  std::shared_ptr<const tissue::TissueField> field;      ///< lesions, pulses, breathing, dynamic regions
};

/// Resolves a loaded scenario. Throws ScenarioError naming the scenario file
/// and the JSON pointer of what cannot be made (an organ that does not load
/// or whose SHA-256 differs, a region whose file cannot be read, a random
/// lesion region with no vertices), or mesh::MeshError for the organ file.
Resolved resolve(const Scenario& s);

/// Resolves `s` on an organ already loaded (its organ reference is not
/// read again: an edited scenario of a running session, whose organ path
/// and unit are the loaded organ's): the same tissues, tissue map, lesions
/// and field resolve() makes, with the same errors (ScenarioError naming
/// the file and the JSON pointer); a null or empty organ mesh is refused
/// ("/organ").
Resolved resolve_on(const Scenario& s, mesh::Organ organ);

/// The tissue of a resolved scenario for a running session
/// (haptics::HapticLoop::set_tissue): its per-vertex tissue map and its
/// field (lesions, pulses, breathing, dynamic regions), shared with `r`.
std::shared_ptr<const haptics::TissueModel> tissue_model(const Resolved& r);

/// The lesions of `s` placed on `organ` (surface-point lesions below the
/// vertex nearest their point, random lesions from the seed: the same
/// lesions on every machine). `region_weight` gives the weights of a named
/// region (for random lesions).
std::vector<tissue::Lesion> place_lesions(const Scenario& s, const mesh::SurfaceMesh& organ);

/// The haptic configuration a scenario asks for: its probe's shape function
/// and the task's force limit as the model force clamp, at rate_hz.
haptics::CoreConfig core_config(const Resolved& r, double rate_hz = 1000, double deform_rate_hz = 500);

/// The session model of a resolved scenario (its field and tissue map attached).
std::shared_ptr<const haptics::SessionModel> session_model(const Resolved& r, const haptics::CoreConfig& config,
                                                           deform::SurfaceOptions options = {});

}  // namespace palpa::scenario
