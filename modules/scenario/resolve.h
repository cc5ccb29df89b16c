#pragma once
// From a scenario file to a session: the organ loaded (and its hash
// checked), lesions placed (from surface points, seeded random ones), the
// tissue map evaluated onto the vertices, the tissue field built, and the
// session model that runs it.

#include "haptics/session.h"
#include "mesh/organ.h"
#include "scenario/scenario.h"

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace palpa::scenario {

/// Progress and cancellation of an organ's preparation (prep::PrepOptions'
/// progress and cancel): `progress` is called on the preparing thread.
struct PrepHooks {
  std::function<void(std::string_view step, int index, int count, double fraction)> progress;
  const std::atomic<bool>* cancel = nullptr;
  /// The cache folder (empty: prep::default_cache_dir(), $PALPA_PREP_CACHE first).
  std::filesystem::path cache_dir;
};

/// Thrown by load_scenario_organ when PrepHooks::cancel was set.
class PrepCancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What preparing an organ did (from prep's report), for the user.
struct PrepSummary {
  std::size_t vertices_before = 0, triangles_before = 0;
  std::size_t vertices_after = 0, triangles_after = 0;
  bool closed = false;            ///< the prepared surface is closed, manifold and outward
  double edge_target = 0;         ///< m, the edge used (after fitting)
  double edge_mean = 0;           ///< m
  double edge_cv = 0;             ///< standard deviation / mean of the edge lengths
  double hausdorff = 0;           ///< m, to the repaired input
  double volume_change = 0;       ///< fraction, against the repaired input
  double seconds = 0;             ///< preparation time (of the first preparation when from the cache)
  bool from_cache = false;
  std::vector<std::string> unmet;     ///< issue 10's targets missed, in words
  std::vector<std::string> warnings;
  /// One line: "prepared: 80688 -> 76636 triangles, edge 2 mm (mean 1.98 mm, CV 0.14), Hausdorff 0.45 mm, volume -0.02%".
  std::string text() const;
};

/// Loads the organ `organ` names ("default": the bundled one; else its file
/// in its unit) and, when organ.prep is set, prepares it with those
/// parameters through prep's cache (prep::prepare_cached: the second time
/// the prepared mesh is loaded, not made again). The organ's note says what
/// preparation did (PrepSummary::text()); `summary` gets the numbers.
/// Throws ScenarioError naming `file` and "/organ/prep" for bad parameters
/// or an organ that cannot be prepared, or "/organ" when this build has no
/// mesh preparation; mesh::MeshError for an organ file that does not load;
/// PrepCancelled when hooks.cancel was set.
mesh::Organ load_scenario_organ(const OrganRef& organ, const std::string& file, const PrepHooks& hooks = {},
                                PrepSummary* summary = nullptr);

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

/// Resolves a loaded scenario: resolve_on(s, load_scenario_organ(s.organ)),
/// so an organ with a "prep" object is prepared (through the cache) before
/// lesions and regions are placed on it. Throws ScenarioError naming the
/// scenario file and the JSON pointer of what cannot be made (an organ that
/// does not load, prepare or whose SHA-256 differs, a region whose file
/// cannot be read, a random lesion region with no vertices), or
/// mesh::MeshError for the organ file.
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
