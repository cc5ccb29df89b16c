#pragma once
// The rendering adapter of section IV: the undeformed organ is uploaded to the
// GPU once (positions P0, normals N0, triangles) and stays there; each frame
// moves only the per-vertex (nx, ny, nz, h) stream of the changed vertices,
// and the vertex shader applies eq. (2) P = P0 + h N0 and eq. (3)
// N = normalize(N0 + Ncorr), inside VTK's own shaders (lighting, picking
// colours and clipping keep working). The CPU side agrees with what is drawn:
// the bounds contain the displaced vertices and pick_ray() intersects the
// deformed surface.

#include "core/types.h"
#include "mesh/surface_mesh.h"
#include "render/pixel_region.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>

class vtkActor;
class vtkRenderer;

namespace palpa::deform {
class DeformableSurface;
}

namespace palpa::render {

/// How the stream reaches the GPU.
enum class UploadPath : unsigned char {
  /// Ours: the stream lives in a texture buffer read with
  /// texelFetch(gl_VertexID); each frame uploads only the dirty ranges with
  /// glBufferSubData (16 bytes per changed vertex) and VTK rebuilds nothing.
  PartialTextureBuffer = 0,
  /// VTK's own way, for comparison: the stream is a point-data array mapped
  /// to a vertex attribute, and each update calls Modified(), so VTK
  /// rebuilds and re-uploads every vertex and index buffer.
  VtkModified = 1,
  /// Reference: positions and normals displaced on the CPU with eq. (2) and
  /// (3) in float, drawn by VTK's unmodified mapper (Modified() each update).
  CpuDisplaced = 2,
};

/// Stream uploads since construction, counted by the adapter (take
/// differences around a render for per-frame figures). For VtkModified and
/// CpuDisplaced only the stream-sized arrays are counted; VTK uploads more.
struct UploadStats {
  std::uint64_t bytes = 0;         ///< stream bytes handed to OpenGL
  std::uint64_t ranges = 0;        ///< partial uploads (glBufferSubData calls)
  std::uint64_t full_uploads = 0;  ///< whole-stream uploads (first frame, new context, VTK rebuilds)
};

/// A hit of pick_ray() on the surface as drawn.
struct SurfacePick {
  Vec3 point = Vec3::Zero();        ///< hit point on the deformed surface, m
  double distance = 0;              ///< along the ray, in units of |direction|
  Index triangle = kNoIndex;
  Vec3 barycentric = Vec3::Zero();  ///< weights of the triangle's vertices at the hit
  Vec3 rest_point = Vec3::Zero();   ///< the same barycentric point on the undeformed surface, m
  Vec3 rest_normal = Vec3::UnitZ(); ///< interpolated undeformed normal there, unit
};

/// VTK's coordinate shift and scale of the position VBO (it keeps float
/// positions precise for meshes far from the origin); the shader scales
/// h N0 the same way, so every mode draws the same surface.
enum class ShiftScale : unsigned char {
  Auto = 0,      ///< VTK decides (shifts when the mesh is far from the origin)
  Always = 1,    ///< always shift and scale
  Disabled = 2,  ///< never
};

/// The transform VTK applied at the last draw: P_vbo = (P - shift) * scale, per axis.
struct VboTransform {
  Vec3 shift = Vec3::Zero();  ///< m
  Vec3 scale = Vec3::Ones();  ///< 1/m
};

class SurfaceView {
 public:
  /// Builds the VTK polydata (points in m, normals, triangles) and actor.
  explicit SurfaceView(std::shared_ptr<const mesh::SurfaceMesh> mesh,
                       UploadPath path = UploadPath::PartialTextureBuffer);
  ~SurfaceView();
  SurfaceView(const SurfaceView&) = delete;
  SurfaceView& operator=(const SurfaceView&) = delete;

  const mesh::SurfaceMesh& mesh() const;
  UploadPath path() const;

  /// Takes new stream values (4 floats per vertex: Ncorr.xyz, h in m, as
  /// DeformableSurface::stream()) for the vertices in `dirty`; they reach
  /// the GPU at the next render. Ranges past the mesh are an error
  /// (std::out_of_range naming the range).
  void update(std::span<const float> stream, std::span<const IndexRange> dirty);
  /// update(surface.stream(), surface.take_dirty_ranges()).
  void sync(deform::DeformableSurface& surface);
  /// Takes every vertex of `stream` (after a reset or a state restore).
  void update_all(std::span<const float> stream);

  /// The actor to add to a renderer (owned by this view).
  vtkActor* actor() const;
  /// Surface colour, RGB in 0..1.
  void set_color(double r, double g, double b);
  /// Skips the triangles that face away from the eye (off by default). The
  /// picture is the same for a closed, outward-oriented surface seen from
  /// outside (every back face lies behind a front face), at about half the
  /// rasterisation work; a surface with holes would show its inside
  /// differently.
  void set_backface_culling(bool on);
  /// From the next render on, draws only the triangles that may cover a
  /// pixel of `region` in a frame projected by `projection` (taking in the
  /// actor's transform and the largest displacement now), in blocks of 64
  /// consecutive triangles kept in their order. A render that draws only
  /// `region` (OffscreenScene::render(region)) gives the same pixels as with
  /// every triangle; the software renderer is spared the others' vertices.
  /// Call it again after the stream or the transform changed.
  void draw_only_near(const PixelProjection& projection, const PixelRect& region);
  /// Draws every triangle again (the default).
  void draw_all();
  /// Organ frame -> world (a breathing organ's motion), 4x4 affine, applied
  /// as the actor's user matrix after eq. (2); identity by default. Picks
  /// and bounds stay in the organ frame.
  void set_transform(const Eigen::Matrix4d& organ_to_world);

  /// Chooses the VBO shift/scale mode (before the first render).
  void set_shift_scale(ShiftScale mode);
  /// What VTK used at the last draw (identity before any).
  VboTransform vbo_transform() const;

  /// Stream upload accounting.
  const UploadStats& stats() const;

  /// Bounds of the surface as drawn: {xmin, xmax, ymin, ymax, zmin, zmax}, m.
  std::array<double, 6> bounds() const;
  /// Largest |h| among the vertices now displaced, m.
  double max_displacement() const;

  /// Position of vertex i as the vertex shader draws it (eq. 2 with the
  /// float h and N0 it reads), m.
  Vec3 drawn_position(Index i) const;
  /// Normal of vertex i as the vertex shader computes it (eq. 3), unit.
  Vec3 drawn_normal(Index i) const;

  /// Nearest intersection of the ray origin + t direction (t > 0) with the
  /// deformed surface, or nothing.
  std::optional<SurfacePick> pick_ray(const Vec3& origin, const Vec3& direction) const;
  /// The same through display pixel (x, y) of `renderer` (VTK display
  /// coordinates: origin at the bottom-left pixel corner).
  std::optional<SurfacePick> pick(vtkRenderer* renderer, double x, double y) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpa::render
