// The rendering adapter: VTK polydata from the mesh, a vtkOpenGLPolyDataMapper
// whose vertex shader applies eq. (2) and (3), the stream uploaded by
// glBufferSubData of the dirty ranges into a texture buffer, bounds and
// picking that agree with what is drawn.

#include "render/surface_view.h"

#include "deform/surface.h"
#include "render/shaders.h"

#include <vtkAutoInit.h>
VTK_MODULE_INIT(vtkRenderingOpenGL2);

#include <Eigen/Geometry>

#include <vtk_glew.h>
#include <vtkActor.h>
#include <vtkMatrix4x4.h>
#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkMath.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkOpenGLBufferObject.h>
#include <vtkOpenGLHelper.h>
#include <vtkOpenGLIndexBufferObject.h>
#include <vtkOpenGLPolyDataMapper.h>
#include <vtkOpenGLRenderWindow.h>
#include <vtkOpenGLVertexBufferObject.h>
#include <vtkOpenGLVertexBufferObjectGroup.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkShader.h>
#include <vtkShaderProgram.h>
#include <vtkSmartPointer.h>
#include <vtkTextureObject.h>
#include <vtkTypeInt32Array.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace palpa::render {
namespace {

constexpr const char* kStreamArrayName = "palpa_stream";
constexpr const char* kNormalsArrayName = "Normals";
constexpr Index kPickChunk = 64;  // triangles per picking box

// Everything the mapper and the view share: the undeformed mesh in float as
// the GPU sees it, the CPU mirror of the stream, what is waiting for upload.
struct DeformData {
  UploadPath path = UploadPath::PartialTextureBuffer;
  std::shared_ptr<const mesh::SurfaceMesh> mesh;
  std::vector<float> rest_normal;    // 4 per vertex (N0.xyz, 0): RGBA32F texels
  std::vector<float> stream;         // 4 per vertex: Ncorr.xyz, h (m)
  std::vector<IndexRange> pending;   // changed since the last upload, sorted, disjoint
  bool need_full_upload = true;
  UploadStats stats;

  // Vertices with h != 0 (bit 0: displaced now, bit 1: listed).
  std::vector<std::uint8_t> displaced_flag;
  std::vector<Index> displaced;
  std::uint64_t version = 0;  // bumped by every update

  // Picking: axis-aligned boxes of kPickChunk consecutive undeformed triangles.
  std::vector<std::array<double, 6>> chunk_box;

  // Drawing only some triangles (draw_only_near): the chunks of kPickChunk
  // triangles to draw, ascending; every triangle when `limited` is false.
  bool limited = false;
  std::vector<std::uint32_t> drawn_chunks;

  // The VBO transform VTK used at the last draw: P_vbo = (P - shift) * scale.
  Vec3 vbo_shift = Vec3::Zero();
  Vec3 vbo_scale = Vec3::Ones();

  vtkSmartPointer<vtkPolyData> poly;
  vtkSmartPointer<vtkDoubleArray> points;  // P0 (or the CPU-displaced positions)
  vtkSmartPointer<vtkFloatArray> normals;  // N0 (or the CPU-displaced normals)
  vtkSmartPointer<vtkFloatArray> stream_array;  // VtkModified only

  Vec3 drawn_position(Index i) const {
    // eq. (2) with the float h and N0 the shader reads (P0 stays double: VTK
    // shifts it before converting to float).
    const double h = stream[4 * i + 3];
    const Vec3& p = mesh->positions[i];
    return Vec3(p[0] + h * rest_normal[4 * i], p[1] + h * rest_normal[4 * i + 1], p[2] + h * rest_normal[4 * i + 2]);
  }
  Vec3 drawn_normal(Index i) const {
    // eq. (3) in float.
    float n[3];
    for (int k = 0; k < 3; ++k) n[k] = rest_normal[4 * i + k] + stream[4 * i + k];
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0)) return Vec3(rest_normal[4 * i], rest_normal[4 * i + 1], rest_normal[4 * i + 2]);
    return Vec3(n[0] / len, n[1] / len, n[2] / len);
  }

  // Keeps only the vertices still displaced in the list.
  void compact_displaced() {
    std::size_t w = 0;
    for (Index i : displaced) {
      if (displaced_flag[i] & 1u)
        displaced[w++] = i;
      else
        displaced_flag[i] = 0;
    }
    displaced.resize(w);
  }

  double max_displacement() {
    compact_displaced();
    double m = 0;
    for (Index i : displaced) m = std::max(m, static_cast<double>(std::abs(stream[4 * i + 3])));
    return m;
  }
};

// Adds [b, e) to a sorted list of disjoint ranges, merging overlaps and
// neighbours (so the list stays short however often the same region changes).
void add_range(std::vector<IndexRange>& ranges, Index b, Index e) {
  if (b >= e) return;
  auto it = std::lower_bound(ranges.begin(), ranges.end(), b,
                             [](const IndexRange& r, Index v) { return r.end < v; });
  auto first = it;
  while (it != ranges.end() && it->begin <= e) {
    b = std::min(b, it->begin);
    e = std::max(e, it->end);
    ++it;
  }
  it = ranges.erase(first, it);
  ranges.insert(it, IndexRange{b, e});
}

// ---------------------------------------------------------------------------
// The mapper: VTK's OpenGL polydata mapper with the deformation injected
// into its vertex shader and the stream kept in texture buffers.
class DeformMapper : public vtkOpenGLPolyDataMapper {
 public:
  static DeformMapper* New();
  vtkTypeMacro(DeformMapper, vtkOpenGLPolyDataMapper);

  DeformData* data = nullptr;

  void ReleaseGraphicsResources(vtkWindow* win) override {
    if (rest_texture_) rest_texture_->ReleaseGraphicsResources(win);
    if (stream_texture_) stream_texture_->ReleaseGraphicsResources(win);
    if (rest_buffer_) rest_buffer_->ReleaseGraphicsResources();
    if (stream_buffer_) stream_buffer_->ReleaseGraphicsResources();
    rest_texture_ = nullptr;
    stream_texture_ = nullptr;
    rest_buffer_ = nullptr;
    stream_buffer_ = nullptr;
    if (data) data->need_full_upload = true;
    Superclass::ReleaseGraphicsResources(win);
  }

 protected:
  DeformMapper() = default;
  ~DeformMapper() override = default;

  // Inject shaders/deform_*.glsl into VTK's vertex shader: declarations after
  // //VTK::Normal::Dec, statements before the first use of vertexMC or
  // normalMC in main(). VTK's replacements run in between, so we can see
  // whether it declared normalMC (it does when it lights the surface).
  void ReplaceShaderValues(std::map<vtkShader::Type, vtkShader*> shaders, vtkRenderer* ren,
                           vtkActor* act) override {
    const bool deform = data && data->path != UploadPath::CpuDisplaced;
    vtkShader* vs = shaders[vtkShader::Vertex];
    if (deform) {
      std::string src = vs->GetSource();
      vtkShaderProgram::Substitute(src, "//VTK::Normal::Dec", "//VTK::Normal::Dec\n//PALPA::Deform::Dec", false);
      vtkShaderProgram::Substitute(src, "//VTK::Normal::Impl", "//PALPA::Deform::Impl\n  //VTK::Normal::Impl", false);
      vs->SetSource(src.c_str());
    }
    Superclass::ReplaceShaderValues(shaders, ren, act);
    if (deform) {
      std::string src = vs->GetSource();
      const bool has_normal = src.find("in vec3 normalMC;") != std::string::npos;
      std::string dec = "\n";
      if (has_normal) dec += "#define PALPA_DEFORM_NORMAL 1\n";
      dec += data->path == UploadPath::PartialTextureBuffer ? shaders::deform_fetch_texture
                                                            : shaders::deform_fetch_attribute;
      dec += shaders::deform_vs_dec;
      vtkShaderProgram::Substitute(src, "//PALPA::Deform::Dec", dec, false);
      vtkShaderProgram::Substitute(src, "//PALPA::Deform::Impl", shaders::deform_vs_impl, false);
      vs->SetSource(src.c_str());
    }
    // PALPA_DUMP_SHADERS=1 prints the final vertex shader (for debugging).
    if (const char* dump = std::getenv("PALPA_DUMP_SHADERS"); dump && *dump == '1')
      std::fprintf(stderr, "---- palpa vertex shader ----\n%s\n", vs->GetSource().c_str());
  }

  // Per draw: the VBO's position scale and, on our path, the two texture
  // buffers bound to free texture units.
  void SetMapperShaderParameters(vtkOpenGLHelper& cellBO, vtkRenderer* ren, vtkActor* act) override {
    Superclass::SetMapperShaderParameters(cellBO, ren, act);
    vtkShaderProgram* prog = cellBO.Program;
    if (!prog || !data || data->path == UploadPath::CpuDisplaced) return;
    float scale[3] = {1.f, 1.f, 1.f};
    data->vbo_shift = Vec3::Zero();
    data->vbo_scale = Vec3::Ones();
    if (vtkOpenGLVertexBufferObject* vbo = this->VBOs->GetVBO("vertexMC")) {
      if (vbo->GetCoordShiftAndScaleEnabled()) {
        const std::vector<double>& s = vbo->GetScale();
        const std::vector<double>& t = vbo->GetShift();
        for (int k = 0; k < 3 && k < static_cast<int>(s.size()); ++k) {
          scale[k] = static_cast<float>(s[k]);
          data->vbo_scale[k] = s[k];
        }
        for (int k = 0; k < 3 && k < static_cast<int>(t.size()); ++k) data->vbo_shift[k] = t[k];
      }
    }
    if (prog->IsUniformUsed("palpaPositionScale")) prog->SetUniform3f("palpaPositionScale", scale);
    if (data->path == UploadPath::PartialTextureBuffer && rest_texture_ && stream_texture_) {
      if (!textures_active_) {
        rest_texture_->Activate();
        stream_texture_->Activate();
        textures_active_ = true;
      }
      if (prog->IsUniformUsed("palpaRestNormals"))
        prog->SetUniformi("palpaRestNormals", rest_texture_->GetTextureUnit());
      if (prog->IsUniformUsed("palpaStream")) prog->SetUniformi("palpaStream", stream_texture_->GetTextureUnit());
    }
  }

  void RenderPieceStart(vtkRenderer* ren, vtkActor* act) override {
    if (data && data->path == UploadPath::PartialTextureBuffer)
      upload_stream(static_cast<vtkOpenGLRenderWindow*>(ren->GetRenderWindow()));
    Superclass::RenderPieceStart(ren, act);
  }

  // Drawing some triangles only: VTK draws the triangles' index buffer as a
  // whole, so the buffer is given the chosen chunks' indices (taken from
  // VTK's own list, read back after each build when a limited draw first
  // needs it: the same triangles, in the same order) and its full list again
  // when everything is drawn.
  void RenderPieceDraw(vtkRenderer* ren, vtkActor* act) override {
    vtkOpenGLIndexBufferObject* ibo = this->Primitives[PrimitiveTris].IBO;
    const std::size_t triangles = data ? data->mesh->triangle_count() : 0;
    if (ibo && this->VBOBuildTime.GetMTime() != built_at_) {
      // VTK (re)built its buffers: the index buffer holds its full list,
      // read back the first time a limited draw needs it (never, in a view
      // that always draws everything).
      built_at_ = this->VBOBuildTime.GetMTime();
      subset_ = false;
      full_read_ = false;
      full_.clear();
    }
    if (ibo && data && data->limited && !full_read_) {
      full_read_ = true;
      if (ibo->IndexCount == 3 * triangles && !this->HaveCellScalars && !this->HaveCellNormals) {
        full_.resize(ibo->IndexCount);
        ibo->Bind();
        glGetBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(full_.size() * sizeof(unsigned)),
                           full_.data());
        ibo->Release();
      }
    }
    const bool limit = data && data->limited && !full_.empty();
    if (limit) {
      part_.clear();
      for (const std::uint32_t c : data->drawn_chunks) {
        const std::size_t b = 3 * std::size_t{c} * kPickChunk, e = std::min(full_.size(), b + 3 * kPickChunk);
        part_.insert(part_.end(), full_.begin() + static_cast<std::ptrdiff_t>(b),
                     full_.begin() + static_cast<std::ptrdiff_t>(e));
      }
      if (!part_.empty()) ibo->Upload(part_, vtkOpenGLBufferObject::ElementArrayBuffer);
      ibo->IndexCount = part_.size();
      subset_ = true;
    } else if (subset_) {
      ibo->Upload(full_, vtkOpenGLBufferObject::ElementArrayBuffer);
      ibo->IndexCount = full_.size();
      subset_ = false;
    }
    Superclass::RenderPieceDraw(ren, act);
  }

  void RenderPieceFinish(vtkRenderer* ren, vtkActor* act) override {
    if (textures_active_) {
      stream_texture_->Deactivate();
      rest_texture_->Deactivate();
      textures_active_ = false;
    }
    Superclass::RenderPieceFinish(ren, act);
  }

  // Bounds of what is drawn: the undeformed points and every displaced
  // vertex where the shader puts it (recomputed only after an update).
  void ComputeBounds() override {
    Superclass::ComputeBounds();
    if (!data || data->path == UploadPath::CpuDisplaced || !vtkMath::AreBoundsInitialized(this->Bounds)) return;
    if (bounds_version_ != data->version || this->GetInput()->GetMTime() > bounds_time_) {
      data->compact_displaced();
      for (int k = 0; k < 6; ++k) displaced_bounds_[k] = (k % 2 == 0) ? std::numeric_limits<double>::max()
                                                                        : std::numeric_limits<double>::lowest();
      for (Index i : data->displaced) {
        const Vec3 p = data->drawn_position(i);
        for (int k = 0; k < 3; ++k) {
          displaced_bounds_[2 * k] = std::min(displaced_bounds_[2 * k], p[k]);
          displaced_bounds_[2 * k + 1] = std::max(displaced_bounds_[2 * k + 1], p[k]);
        }
      }
      bounds_version_ = data->version;
      bounds_time_ = this->GetInput()->GetMTime();
    }
    if (data->displaced.empty()) return;
    for (int k = 0; k < 3; ++k) {
      this->Bounds[2 * k] = std::min(this->Bounds[2 * k], displaced_bounds_[2 * k]);
      this->Bounds[2 * k + 1] = std::max(this->Bounds[2 * k + 1], displaced_bounds_[2 * k + 1]);
    }
  }

 private:
  // Our path: the first time (or after the context changed) both texture
  // buffers are created and filled; afterwards only the pending ranges of
  // the stream go up, one glBufferSubData each.
  void upload_stream(vtkOpenGLRenderWindow* win) {
    DeformData& d = *data;
    const std::size_t n = d.mesh->vertex_count();
    if (!rest_texture_ || !stream_texture_ || d.need_full_upload) {
      rest_buffer_ = vtkSmartPointer<vtkOpenGLBufferObject>::New();
      rest_buffer_->SetType(vtkOpenGLBufferObject::TextureBuffer);
      rest_buffer_->Upload(d.rest_normal.data(), d.rest_normal.size(), vtkOpenGLBufferObject::TextureBuffer);
      rest_texture_ = vtkSmartPointer<vtkTextureObject>::New();
      rest_texture_->SetContext(win);
      rest_texture_->CreateTextureBuffer(static_cast<unsigned>(n), 4, VTK_FLOAT, rest_buffer_);

      stream_buffer_ = vtkSmartPointer<vtkOpenGLBufferObject>::New();
      stream_buffer_->SetType(vtkOpenGLBufferObject::TextureBuffer);
      stream_buffer_->Upload(d.stream.data(), d.stream.size(), vtkOpenGLBufferObject::TextureBuffer);
      stream_texture_ = vtkSmartPointer<vtkTextureObject>::New();
      stream_texture_->SetContext(win);
      stream_texture_->CreateTextureBuffer(static_cast<unsigned>(n), 4, VTK_FLOAT, stream_buffer_);

      d.stats.bytes += d.stream.size() * sizeof(float);
      d.stats.full_uploads += 1;
      d.need_full_upload = false;
      d.pending.clear();
      return;
    }
    if (d.pending.empty()) return;
    stream_buffer_->Bind();
    for (const IndexRange& r : d.pending) {
      const GLintptr offset = static_cast<GLintptr>(r.begin) * 4 * sizeof(float);
      const GLsizeiptr size = static_cast<GLsizeiptr>(r.end - r.begin) * 4 * sizeof(float);
      glBufferSubData(GL_TEXTURE_BUFFER, offset, size, d.stream.data() + std::size_t{4} * r.begin);
      d.stats.bytes += static_cast<std::uint64_t>(size);
      d.stats.ranges += 1;
    }
    stream_buffer_->Release();
    d.pending.clear();
  }

  vtkSmartPointer<vtkOpenGLBufferObject> rest_buffer_, stream_buffer_;
  vtkSmartPointer<vtkTextureObject> rest_texture_, stream_texture_;
  bool textures_active_ = false;
  vtkMTimeType built_at_ = 0;        // VBOBuildTime when full_ was read
  bool full_read_ = false;           // full_ read since VTK's last build
  std::vector<unsigned> full_;       // VTK's triangle indices (empty: not read, or not ours to limit)
  std::vector<unsigned> part_;       // the chosen chunks' indices
  bool subset_ = false;              // the index buffer holds part_
  std::uint64_t bounds_version_ = ~std::uint64_t{0};
  vtkMTimeType bounds_time_ = 0;
  double displaced_bounds_[6] = {0, 0, 0, 0, 0, 0};
};

vtkStandardNewMacro(DeformMapper);

// Ray against a box (slab test); true when [0, tmax] of the ray meets it.
bool ray_hits_box(const Vec3& o, const Vec3& inv_d, const std::array<double, 6>& b, double grow, double tmax) {
  double t0 = 0, t1 = tmax;
  for (int k = 0; k < 3; ++k) {
    if (std::isinf(inv_d[k])) {  // ray parallel to this slab
      if (o[k] < b[2 * k] - grow || o[k] > b[2 * k + 1] + grow) return false;
      continue;
    }
    double a = (b[2 * k] - grow - o[k]) * inv_d[k];
    double c = (b[2 * k + 1] + grow - o[k]) * inv_d[k];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return false;
  }
  return true;
}

// Ray against triangle (a, b, c) (Moller-Trumbore); t and barycentric (u, v).
bool ray_hits_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c, double& t,
                       double& u, double& v) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-300) return false;
  const double inv = 1.0 / det;
  const Vec3 s = o - a;
  u = s.dot(p) * inv;
  if (u < 0 || u > 1) return false;
  const Vec3 q = s.cross(e1);
  v = d.dot(q) * inv;
  if (v < 0 || u + v > 1) return false;
  t = e2.dot(q) * inv;
  return t > 0;
}

}  // namespace

// ---------------------------------------------------------------------------
struct SurfaceView::Impl {
  DeformData data;
  vtkSmartPointer<DeformMapper> mapper;
  vtkSmartPointer<vtkActor> actor;
};

SurfaceView::SurfaceView(std::shared_ptr<const mesh::SurfaceMesh> mesh, UploadPath path)
    : impl_(std::make_unique<Impl>()) {
  if (!mesh) throw std::invalid_argument("SurfaceView: no mesh");
  if (mesh->normals.size() != mesh->positions.size())
    throw std::invalid_argument("SurfaceView: mesh has " + std::to_string(mesh->normals.size()) + " normals for " +
                                std::to_string(mesh->positions.size()) + " vertices (not finalized)");
  DeformData& d = impl_->data;
  d.path = path;
  d.mesh = std::move(mesh);
  const auto& m = *d.mesh;
  const std::size_t n = m.vertex_count();
  const std::size_t t = m.triangle_count();

  // N0 in float (the GPU's view of it) and a zero stream.
  d.rest_normal.resize(4 * n);
  d.stream.assign(4 * n, 0.f);
  d.displaced_flag.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) d.rest_normal[4 * i + k] = static_cast<float>(m.normals[i][k]);
    d.rest_normal[4 * i + 3] = 0.f;
  }

  // VTK polydata: points (double, m), point normals, triangles.
  d.points = vtkSmartPointer<vtkDoubleArray>::New();
  d.points->SetNumberOfComponents(3);
  d.points->SetNumberOfTuples(static_cast<vtkIdType>(n));
  d.normals = vtkSmartPointer<vtkFloatArray>::New();
  d.normals->SetName(kNormalsArrayName);
  d.normals->SetNumberOfComponents(3);
  d.normals->SetNumberOfTuples(static_cast<vtkIdType>(n));
  for (std::size_t i = 0; i < n; ++i) {
    d.points->SetTypedTuple(static_cast<vtkIdType>(i), m.positions[i].data());
    d.normals->SetTypedTuple(static_cast<vtkIdType>(i), &d.rest_normal[4 * i]);
  }
  vtkNew<vtkPoints> points;
  points->SetData(d.points);
  vtkNew<vtkTypeInt32Array> offsets, connectivity;
  offsets->SetNumberOfTuples(static_cast<vtkIdType>(t + 1));
  connectivity->SetNumberOfTuples(static_cast<vtkIdType>(3 * t));
  for (std::size_t c = 0; c <= t; ++c) offsets->SetValue(static_cast<vtkIdType>(c), static_cast<int>(3 * c));
  for (std::size_t c = 0; c < t; ++c)
    for (int k = 0; k < 3; ++k)
      connectivity->SetValue(static_cast<vtkIdType>(3 * c + k), static_cast<int>(m.triangles[c][k]));
  vtkNew<vtkCellArray> polys;
  polys->SetData(offsets, connectivity);
  d.poly = vtkSmartPointer<vtkPolyData>::New();
  d.poly->SetPoints(points);
  d.poly->SetPolys(polys);
  d.poly->GetPointData()->SetNormals(d.normals);

  // VTK's own path: the stream and N0 as vertex attributes.
  if (path == UploadPath::VtkModified) {
    d.stream_array = vtkSmartPointer<vtkFloatArray>::New();
    d.stream_array->SetName(kStreamArrayName);
    d.stream_array->SetNumberOfComponents(4);
    d.stream_array->SetNumberOfTuples(static_cast<vtkIdType>(n));
    d.stream_array->FillValue(0.f);
    d.poly->GetPointData()->AddArray(d.stream_array);
  }

  // Picking boxes over consecutive triangles (meshes keep neighbours close
  // in index order, so these stay small).
  for (std::size_t c0 = 0; c0 < t; c0 += kPickChunk) {
    std::array<double, 6> box = {std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                                 std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                                 std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest()};
    for (std::size_t c = c0; c < std::min(t, c0 + kPickChunk); ++c)
      for (Index v : m.triangles[c])
        for (int k = 0; k < 3; ++k) {
          box[2 * k] = std::min(box[2 * k], m.positions[v][k]);
          box[2 * k + 1] = std::max(box[2 * k + 1], m.positions[v][k]);
        }
    d.chunk_box.push_back(box);
  }

  // Mapper and actor.
  impl_->mapper = vtkSmartPointer<DeformMapper>::New();
  impl_->mapper->data = &d;
  impl_->mapper->SetInputData(d.poly);
  impl_->mapper->ScalarVisibilityOff();
  impl_->mapper->StaticOn();
  if (path == UploadPath::VtkModified) {
    impl_->mapper->MapDataArrayToVertexAttribute("palpaStreamAttr", kStreamArrayName,
                                                 vtkDataObject::FIELD_ASSOCIATION_POINTS, -1);
    impl_->mapper->MapDataArrayToVertexAttribute("palpaRestNormalAttr", kNormalsArrayName,
                                                 vtkDataObject::FIELD_ASSOCIATION_POINTS, -1);
  }
  impl_->actor = vtkSmartPointer<vtkActor>::New();
  impl_->actor->SetMapper(impl_->mapper);
  impl_->actor->GetProperty()->SetColor(0.80, 0.45, 0.40);
  impl_->actor->GetProperty()->SetSpecular(0.2);
  impl_->actor->GetProperty()->SetSpecularPower(20);
}

SurfaceView::~SurfaceView() {
  if (impl_ && impl_->mapper) impl_->mapper->data = nullptr;
}

const mesh::SurfaceMesh& SurfaceView::mesh() const { return *impl_->data.mesh; }
UploadPath SurfaceView::path() const { return impl_->data.path; }
vtkActor* SurfaceView::actor() const { return impl_->actor; }

void SurfaceView::set_transform(const Eigen::Matrix4d& m) {
  vtkNew<vtkMatrix4x4> vm;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) vm->SetElement(r, c, m(r, c));
  impl_->actor->SetUserMatrix(vm);
}
const UploadStats& SurfaceView::stats() const { return impl_->data.stats; }

void SurfaceView::draw_only_near(const PixelProjection& projection, const PixelRect& region) {
  DeformData& d = impl_->data;
  d.limited = true;
  d.drawn_chunks.clear();
  if (region.empty()) return;
  // A displaced vertex lies within max |h| of its undeformed place (N0 unit).
  const double grow = d.max_displacement() * 1.001 + 1e-9;
  vtkMatrix4x4* m = impl_->actor->GetMatrix();
  Eigen::Matrix4d to_world;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) to_world(r, c) = m->GetElement(r, c);
  for (std::size_t c = 0; c < d.chunk_box.size(); ++c) {
    const auto& b = d.chunk_box[c];
    PixelProjection::Cover cover(projection);
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? b[1] + grow : b[0] - grow, (k & 2) ? b[3] + grow : b[2] - grow,
                        (k & 4) ? b[5] + grow : b[4] - grow);
      cover.add(Vec3(to_world.topLeftCorner<3, 3>() * corner + to_world.topRightCorner<3, 1>()));
    }
    if (cover.rect(2).overlaps(region)) d.drawn_chunks.push_back(static_cast<std::uint32_t>(c));
  }
}

void SurfaceView::draw_all() {
  impl_->data.limited = false;
  impl_->data.drawn_chunks.clear();
}

void SurfaceView::set_color(double r, double g, double b) { impl_->actor->GetProperty()->SetColor(r, g, b); }

void SurfaceView::set_backface_culling(bool on) { impl_->actor->GetProperty()->SetBackfaceCulling(on); }

void SurfaceView::update(std::span<const float> stream, std::span<const IndexRange> dirty) {
  DeformData& d = impl_->data;
  const std::size_t n = d.mesh->vertex_count();
  if (stream.size() != 4 * n)
    throw std::out_of_range("SurfaceView::update: stream has " + std::to_string(stream.size()) +
                            " floats, expected 4 x " + std::to_string(n) + " vertices");
  if (dirty.empty()) return;
  for (const IndexRange& r : dirty)
    if (r.begin > r.end || r.end > n)
      throw std::out_of_range("SurfaceView::update: range [" + std::to_string(r.begin) + ", " +
                              std::to_string(r.end) + ") is outside the mesh's " + std::to_string(n) + " vertices");

  for (const IndexRange& r : dirty) {
    // Mirror the new values and track which vertices are displaced.
    std::copy(stream.begin() + 4 * std::size_t{r.begin}, stream.begin() + 4 * std::size_t{r.end},
              d.stream.begin() + 4 * std::size_t{r.begin});
    for (Index i = r.begin; i < r.end; ++i) {
      const bool now = d.stream[4 * i + 3] != 0.f;
      std::uint8_t& f = d.displaced_flag[i];
      if (now) {
        if (!(f & 2u)) d.displaced.push_back(i);
        f = 3u;
      } else {
        f &= static_cast<std::uint8_t>(~1u);
      }
    }
    switch (d.path) {
      case UploadPath::PartialTextureBuffer:
        add_range(d.pending, r.begin, r.end);
        break;
      case UploadPath::VtkModified:
        std::copy(d.stream.begin() + 4 * std::size_t{r.begin}, d.stream.begin() + 4 * std::size_t{r.end},
                  d.stream_array->GetPointer(0) + 4 * std::size_t{r.begin});
        break;
      case UploadPath::CpuDisplaced:
        // eq. (2) and (3) on the CPU, in float like the shader.
        for (Index i = r.begin; i < r.end; ++i) {
          const Vec3 p = d.drawn_position(i);
          const Vec3 nn = d.drawn_normal(i);
          d.points->SetTypedTuple(i, p.data());
          const float nf[3] = {static_cast<float>(nn[0]), static_cast<float>(nn[1]), static_cast<float>(nn[2])};
          d.normals->SetTypedTuple(i, nf);
        }
        break;
    }
  }
  // VTK's paths: a Modified() makes VTK rebuild every buffer at the next render.
  if (d.path == UploadPath::VtkModified) {
    d.stream_array->Modified();
    d.stats.bytes += d.stream.size() * sizeof(float);
    d.stats.full_uploads += 1;
  } else if (d.path == UploadPath::CpuDisplaced) {
    d.points->Modified();
    d.normals->Modified();
    d.poly->GetPoints()->Modified();
    d.stats.bytes += n * 6 * sizeof(float);
    d.stats.full_uploads += 1;
  }
  d.version += 1;
}

void SurfaceView::update_all(std::span<const float> stream) {
  const IndexRange all{0, static_cast<Index>(impl_->data.mesh->vertex_count())};
  update(stream, std::span<const IndexRange>(&all, 1));
}

void SurfaceView::sync(deform::DeformableSurface& surface) {
  const std::vector<IndexRange> dirty = surface.take_dirty_ranges();
  update(surface.stream(), dirty);
}

std::array<double, 6> SurfaceView::bounds() const {
  std::array<double, 6> b{};
  impl_->mapper->GetBounds(b.data());
  return b;
}

double SurfaceView::max_displacement() const { return impl_->data.max_displacement(); }
Vec3 SurfaceView::drawn_position(Index i) const { return impl_->data.drawn_position(i); }
Vec3 SurfaceView::drawn_normal(Index i) const { return impl_->data.drawn_normal(i); }

void SurfaceView::set_shift_scale(ShiftScale mode) {
  int m = vtkOpenGLVertexBufferObject::AUTO_SHIFT_SCALE;
  if (mode == ShiftScale::Always) m = vtkOpenGLVertexBufferObject::ALWAYS_AUTO_SHIFT_SCALE;
  if (mode == ShiftScale::Disabled) m = vtkOpenGLVertexBufferObject::DISABLE_SHIFT_SCALE;
  impl_->mapper->SetVBOShiftScaleMethod(m);
}

VboTransform SurfaceView::vbo_transform() const { return {impl_->data.vbo_shift, impl_->data.vbo_scale}; }

std::optional<SurfacePick> SurfaceView::pick_ray(const Vec3& origin, const Vec3& direction) const {
  DeformData& d = impl_->data;
  const auto& m = *d.mesh;
  if (!(direction.squaredNorm() > 0)) return std::nullopt;
  // Boxes grow by the largest displacement (plus float slack) so none can
  // miss a displaced triangle.
  const double grow = d.max_displacement() * 1.0001 + 1e-9;
  Vec3 inv_d;
  for (int k = 0; k < 3; ++k)
    inv_d[k] = direction[k] != 0 ? 1.0 / direction[k] : std::numeric_limits<double>::infinity();
  double best = std::numeric_limits<double>::infinity();
  std::optional<SurfacePick> hit;
  const std::size_t t = m.triangle_count();
  for (std::size_t c = 0; c < d.chunk_box.size(); ++c) {
    if (!ray_hits_box(origin, inv_d, d.chunk_box[c], grow, best)) continue;
    const std::size_t end = std::min(t, (c + 1) * kPickChunk);
    for (std::size_t tri = c * kPickChunk; tri < end; ++tri) {
      const auto& v = m.triangles[tri];
      double tt, u, w;
      if (!ray_hits_triangle(origin, direction, d.drawn_position(v[0]), d.drawn_position(v[1]),
                             d.drawn_position(v[2]), tt, u, w) ||
          tt >= best)
        continue;
      best = tt;
      SurfacePick p;
      p.distance = tt;
      p.point = origin + tt * direction;
      p.triangle = static_cast<Index>(tri);
      p.barycentric = Vec3(1 - u - w, u, w);
      p.rest_point = p.barycentric[0] * m.positions[v[0]] + p.barycentric[1] * m.positions[v[1]] +
                     p.barycentric[2] * m.positions[v[2]];
      const Vec3 n = p.barycentric[0] * m.normals[v[0]] + p.barycentric[1] * m.normals[v[1]] +
                     p.barycentric[2] * m.normals[v[2]];
      p.rest_normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(m.normals[v[0]]);
      hit = p;
    }
  }
  return hit;
}

std::optional<SurfacePick> SurfaceView::pick(vtkRenderer* renderer, double x, double y) const {
  // The ray through the pixel, from the near to the far clipping plane.
  double near_w[4], far_w[4];
  renderer->SetDisplayPoint(x, y, 0.0);
  renderer->DisplayToWorld();
  renderer->GetWorldPoint(near_w);
  renderer->SetDisplayPoint(x, y, 1.0);
  renderer->DisplayToWorld();
  renderer->GetWorldPoint(far_w);
  if (near_w[3] == 0 || far_w[3] == 0) return std::nullopt;
  const Vec3 a(near_w[0] / near_w[3], near_w[1] / near_w[3], near_w[2] / near_w[3]);
  const Vec3 b(far_w[0] / far_w[3], far_w[1] / far_w[3], far_w[2] / far_w[3]);
  return pick_ray(a, b - a);
}

}  // namespace palpa::render
