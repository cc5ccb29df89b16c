#pragma once
// The full step's sweep over runs of vertices in a field (with vertices at
// rest among them), for a surface of one plain Linear material
// (DeformableSurface::step_full): four vertices at a time with AVX2 where
// the processor has it, and blocks of eight (those outside a field at
// rest) eight at a time with AVX-512. Every result is the one the
// vertex-by-vertex sweep gives, bit for bit: the same operations in the
// same order on each vertex, and the same flags, dirty marks and list
// entries in index order.
// Internal to the deform module (tested on its own); not part of its
// interface.

#include "core/types.h"
#include "deform/local_model.h"

#include <cstddef>
#include <cstdint>

namespace palpa::deform::internal {

/// What the sweep reads and writes: the surface's arrays (one entry per
/// vertex, indexed as the mesh), its two lists and the step's coefficients.
struct ForcedRun {
  VertexState* state;          ///< h (m), v (m/s), q
  const double* force;         ///< field force, N
  const double* limit;         ///< drawn limit, m
  std::uint8_t* flags;         ///< vertex_flags.h bits
  float* stream;               ///< (nx, ny, nz, h) per vertex, h in m (only h written here)
  std::uint64_t* dirty_blocks; ///< the block bitmap of mark_block
  bool all_dirty;              ///< everything is dirty already: no marks
  Index* active;               ///< the active set, appended to
  std::size_t active_size;
  Index* changed;              ///< vertices remembered as changed, appended to
  std::size_t changed_size;
  LinearStep step;             ///< the one material's step for dt
};

/// How many vertices the sweep takes at a time.
enum class ForcedRunWidth : unsigned char {
  Four = 0,   ///< AVX2
  Eight = 1,  ///< AVX-512 (F, VL, BW, DQ) and BMI2, for blocks whose vertices outside a field are at rest and
              ///< out of the active set; other blocks four by four
};

/// True when this processor runs the sweep at `width` (x86-64 with AVX2;
/// Eight also needs AVX-512 F, VL, BW, DQ and BMI2).
bool forced_run_available(ForcedRunWidth width = ForcedRunWidth::Four);

/// The widest width available; Four where none is (then the sweep never runs).
ForcedRunWidth best_forced_run();

/// Advances blocks of eight vertices from `begin` (a multiple of 8) up to
/// `end` (a multiple of 8), `width` at a time, with the same results at
/// either width. A vertex in a field (flag kForced) gets what DeformableSurface's vertex-by-vertex sweep gives it:
/// the Linear step under its force, its stream height rewritten where it
/// differs (with its dirty mark), its changed mark, and a place in the
/// active set. A vertex outside every field must be out of the active set
/// and at rest (h, v and q all +0 or -0), and is left as it is, as that
/// sweep leaves it. Stops, and returns where, at the first block with no
/// vertex in a field (a multiple of 8) or at the first four with a vertex
/// outside every field that is active or moving (a multiple of 4, those
/// four untouched), or at `end`. forced_run_available(width) must be true.
/// No allocation: the lists have room for every vertex.
std::size_t advance_forced_run(ForcedRunWidth width, ForcedRun& run, std::size_t begin, std::size_t end);

}  // namespace palpa::deform::internal
