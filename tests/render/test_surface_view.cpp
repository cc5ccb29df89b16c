// The rendering adapter against physics, with no display: a contact dents the
// picture where the core says and nowhere else, the normal correction moves
// the shading towards the true normals, the GPU path draws what the CPU
// reference draws, bounds and picking agree with the drawn surface, and a
// frame uploads only the dirty stream ranges.

#include "render/surface_view.h"

#include "render/offscreen.h"
#include "render/scene.h"
#include "render_test_support.h"
#include "upload_counter.h"

#include <vtkActor.h>
#include <vtkDataObject.h>
#include <vtkHardwareSelector.h>
#include <vtkMapper.h>
#include <vtkNew.h>
#include <vtkPlane.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <numeric>

namespace palpa::render {
namespace {

using test::DentScene;
using test::GlUploadCounter;
using test::UploadCounts;

constexpr int kSize = 400;  // pixels

// World point drawn at display pixel (x, y) (origin bottom-left), from the depth buffer.
Vec3 drawn_point(OffscreenScene& scene, int x, int y) {
  const float z = scene.window().depth_at(x, y);
  vtkRenderer* ren = scene.renderer();
  ren->SetDisplayPoint(x + 0.5, y + 0.5, z);
  ren->DisplayToWorld();
  double w[4];
  ren->GetWorldPoint(w);
  return Vec3(w[0] / w[3], w[1] / w[3], w[2] / w[3]);
}

// Deformed positions by the core (eq. 2 in double).
std::vector<Vec3> core_positions(const deform::DeformableSurface& s) {
  std::vector<Vec3> p(s.mesh().vertex_count());
  for (Index i = 0; i < p.size(); ++i) p[i] = s.deformed_position(i);
  return p;
}

// Renders `view` alone in `scene` and returns the picture.
Image render_alone(OffscreenScene& scene, SurfaceView& view) {
  scene.renderer()->RemoveAllViewProps();
  scene.add(view.actor());
  return scene.render_image();
}

TEST(SurfaceView, DentAppearsWhereThePhysicsPutsItAndFarPixelsStayIdentical) {
  DentScene dent(0.005);
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3::UnitZ(), Vec3::UnitY());
  const Image before = scene.render_image();
  const auto top_px = test::to_pixel(scene.renderer(), dent.mesh->positions[dent.top], kSize);
  const int px = static_cast<int>(top_px.x()), py_display = kSize - 1 - static_cast<int>(top_px.y());
  const Vec3 surface_before = drawn_point(scene, px, py_display);

  // Press and settle; the core says where the top vertex went.
  dent.settle();
  const double h_top = dent.surface->state().vertices[dent.top].h;
  ASSERT_NEAR(h_top, -0.005, 0.0005) << "the core did not settle the contact vertex near -depth";
  view.sync(*dent.surface);
  const Image after = scene.render_image();
  const Vec3 surface_after = drawn_point(scene, px, py_display);

  // Only pixels that displaced triangles can cover changed; many of them did.
  const auto mask = test::footprint(scene.renderer(), *dent.mesh, dent.surface->stream(), kSize, kSize,
                                    core_positions(*dent.surface));
  const auto diff = test::compare(before, after, mask);
  EXPECT_EQ(diff.changed_outside, 0) << "pixels far from the contact changed";
  EXPECT_GT(diff.changed_inside, 300) << "the dent is not visible";

  // Seen from above, the drawn surface at the contact moved down by |h|, to
  // where the core's deformed position is.
  EXPECT_NEAR(surface_before.z(), dent.mesh->positions[dent.top].z(), 1.5e-4);
  EXPECT_NEAR(surface_after.z(), dent.surface->deformed_position(dent.top).z(), 1.5e-4);
  EXPECT_NEAR(surface_before.z() - surface_after.z(), -h_top, 2e-4);
}

TEST(SurfaceView, GpuPathsMatchTheCpuDisplacedReferenceWithinOneGreyLevel) {
  DentScene dent(0.006);
  dent.settle();
  OffscreenScene scene(kSize, kSize);
  SurfaceView partial(dent.mesh, UploadPath::PartialTextureBuffer);
  SurfaceView vtk(dent.mesh, UploadPath::VtkModified);
  SurfaceView cpu(dent.mesh, UploadPath::CpuDisplaced);
  // The reference: the core's deformed_position / deformed_normal, drawn by
  // VTK's unmodified mapper.
  SurfaceView reference(test::core_reference_mesh(*dent.surface), UploadPath::CpuDisplaced);
  const auto stream = dent.surface->stream();
  for (SurfaceView* v : {&partial, &vtk, &cpu}) v->update_all(stream);
  // An oblique view so the dent's rim and slope are in the picture.
  scene.look_at(reference.bounds(), Vec3(0, -1, 1.2), Vec3::UnitZ());
  const Image ref = render_alone(scene, reference);
  const Image ours = render_alone(scene, partial);
  const Image theirs = render_alone(scene, vtk);
  const Image cpu_float = render_alone(scene, cpu);
  RecordProperty("max_diff_partial", test::max_difference(ours, ref));
  RecordProperty("max_diff_vtk", test::max_difference(theirs, ref));
  EXPECT_LE(test::max_difference(ours, ref), 1);
  EXPECT_LE(test::max_difference(theirs, ref), 1);
  EXPECT_LE(test::max_difference(cpu_float, ref), 1);
  // And the picture really has a dent in it (not three undeformed spheres).
  SurfaceView flat(dent.mesh);
  EXPECT_GT(test::max_difference(render_alone(scene, flat), ref), 20);
}

TEST(SurfaceView, VboShiftAndScaleAreCompensatedFarFromTheOrigin) {
  // 1 km from the origin VTK shifts and scales the float positions; h N0
  // must be scaled the same way or the dent comes out wrong.
  for (ShiftScale mode : {ShiftScale::Auto, ShiftScale::Always}) {
    DentScene dent(0.006, Vec3(1000.0, -400.0, 250.0));
    dent.settle();
    OffscreenScene scene(kSize, kSize);
    SurfaceView partial(dent.mesh, UploadPath::PartialTextureBuffer);
    SurfaceView reference(test::core_reference_mesh(*dent.surface), UploadPath::CpuDisplaced);
    partial.set_shift_scale(mode);
    reference.set_shift_scale(mode);
    partial.update_all(dent.surface->stream());
    scene.look_at(reference.bounds(), Vec3(0, -1, 1.2), Vec3::UnitZ());
    const Image ref = render_alone(scene, reference);
    const Image ours = render_alone(scene, partial);
    const VboTransform t = partial.vbo_transform();
    EXPECT_GT(t.shift.norm(), 100.0) << "VTK did not shift this far-away mesh; the test would prove nothing";
    EXPECT_GT((t.scale - Vec3::Ones()).norm(), 1e-3) << "VTK did not scale this mesh";
    EXPECT_LE(test::max_difference(ours, ref), 1);
  }
}

TEST(SurfaceView, NormalCorrectionMovesShadingTowardsTheTrueNormals) {
  DentScene dent(0.006);
  dent.settle();
  const auto stream = dent.surface->stream();
  std::vector<float> no_correction(stream.begin(), stream.end());
  for (std::size_t i = 0; i < no_correction.size(); i += 4) no_correction[i] = no_correction[i + 1] = no_correction[i + 2] = 0;

  // Truth: the deformed mesh with normals recomputed from its triangles.
  auto truth_mesh = std::make_shared<mesh::SurfaceMesh>(*dent.mesh);
  truth_mesh->positions = core_positions(*dent.surface);
  mesh::compute_normals(*truth_mesh);

  OffscreenScene scene(kSize, kSize);
  SurfaceView corrected(dent.mesh), uncorrected(dent.mesh), truth(truth_mesh);
  corrected.update_all(stream);
  uncorrected.update_all(no_correction);
  scene.look_at(corrected.bounds(), Vec3(0, -1, 1.2), Vec3::UnitZ());
  const Image with = render_alone(scene, corrected);
  const Image without = render_alone(scene, uncorrected);
  const Image geometric = render_alone(scene, truth);

  const auto mask = test::footprint(scene.renderer(), *dent.mesh, stream, kSize, kSize, truth_mesh->positions);
  const auto changed = test::compare(with, without, mask);
  EXPECT_EQ(changed.changed_outside, 0);
  EXPECT_GT(changed.changed_inside, 300) << "the normal correction did not change the shading";
  const double err_with = test::compare(with, geometric, mask).mean_grey_inside;
  const double err_without = test::compare(without, geometric, mask).mean_grey_inside;
  RecordProperty("err_with", std::to_string(err_with));
  RecordProperty("err_without", std::to_string(err_without));
  EXPECT_LT(err_with, 0.5 * err_without) << "with correction " << err_with << ", without " << err_without;
}

TEST(SurfaceView, BoundsContainEveryDisplacedVertex) {
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(2000, 0.05));
  SurfaceView view(mesh);
  const auto rest = view.bounds();
  std::vector<float> stream(4 * mesh->vertex_count(), 0.f);
  Index top = 0, bottom = 0;
  for (Index i = 0; i < mesh->vertex_count(); ++i) {
    if (mesh->positions[i].z() > mesh->positions[top].z()) top = i;
    if (mesh->positions[i].z() < mesh->positions[bottom].z()) bottom = i;
  }
  // Push the top vertex out by 10 mm, the bottom one in by 4 mm.
  stream[4 * top + 3] = 0.010f;
  stream[4 * bottom + 3] = -0.004f;
  view.update_all(stream);
  const auto b = view.bounds();
  EXPECT_DOUBLE_EQ(b[5], view.drawn_position(top).z());
  EXPECT_GT(b[5], rest[5] + 0.0099);
  EXPECT_DOUBLE_EQ(b[4], rest[4]);  // the undeformed bottom still bounds what is drawn elsewhere
  for (Index i = 0; i < mesh->vertex_count(); ++i) {
    const Vec3 p = view.drawn_position(i);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p[k], b[2 * k]);
      EXPECT_LE(p[k], b[2 * k + 1]);
    }
  }
  double actor_bounds[6];
  view.actor()->GetBounds(actor_bounds);
  for (int k = 0; k < 6; ++k) EXPECT_DOUBLE_EQ(actor_bounds[k], b[k]);

  // Released: back to the undeformed bounds.
  std::fill(stream.begin(), stream.end(), 0.f);
  view.update_all(stream);
  EXPECT_EQ(view.bounds(), rest);
  EXPECT_EQ(view.max_displacement(), 0.0);
}

TEST(SurfaceView, PickingHitsTheDeformedSurfaceWhereItIsDrawn) {
  DentScene dent(0.006);
  dent.settle();
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3(0, -0.6, 1), Vec3::UnitZ());
  scene.render_image();

  // At pixels around the dent the CPU pick and the depth buffer agree.
  const auto c = test::to_pixel(scene.renderer(), dent.surface->deformed_position(dent.top), kSize);
  int checked = 0;
  for (int dy = -24; dy <= 24; dy += 8)
    for (int dx = -24; dx <= 24; dx += 8) {
      const int x = static_cast<int>(c.x()) + dx, y = kSize - 1 - static_cast<int>(c.y()) + dy;
      const auto hit = view.pick(scene.renderer(), x + 0.5, y + 0.5);
      ASSERT_TRUE(hit.has_value()) << "no hit at " << x << "," << y;
      EXPECT_LT((hit->point - drawn_point(scene, x, y)).norm(), 1e-4) << "at " << x << "," << y;
      ++checked;
    }
  EXPECT_EQ(checked, 49);

  // At the contact it hits the dent's bottom, 6 mm below the undeformed surface.
  const auto centre = view.pick(scene.renderer(), c.x(), kSize - c.y());
  ASSERT_TRUE(centre.has_value());
  EXPECT_LT((centre->point - dent.surface->deformed_position(dent.top)).norm(), 5e-4);
  EXPECT_NEAR((centre->rest_point - centre->point).dot(centre->rest_normal), 0.006, 5e-4);

  // A ray beside the sphere misses.
  EXPECT_FALSE(view.pick_ray(Vec3(0.2, 0, 0), Vec3(0, 0, -1)).has_value());
}

TEST(SurfaceView, HardwareSelectionRendersTheDeformedSurface) {
  // VTK's picking colours come from the same vertex shader: the cell it
  // selects at a pixel is the deformed triangle drawn there.
  DentScene dent(0.008);
  dent.settle();
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh), flat(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3(0, -1, 0.8), Vec3::UnitZ());
  scene.render_image();
  const auto c = test::to_pixel(scene.renderer(), dent.surface->deformed_position(dent.top), kSize);

  // One capture of the selection buffers, then per-pixel cell ids.
  vtkNew<vtkHardwareSelector> selector;
  selector->SetRenderer(scene.renderer());
  selector->SetFieldAssociation(vtkDataObject::FIELD_ASSOCIATION_CELLS);
  selector->SetArea(0, 0, kSize - 1, kSize - 1);
  ASSERT_TRUE(selector->CaptureBuffers());
  int agree_deformed = 0, agree_undeformed = 0, total = 0;
  for (int dy = -20; dy <= 20; dy += 4)
    for (int dx = -20; dx <= 20; dx += 4) {
      const unsigned pos[2] = {static_cast<unsigned>(c.x() + dx), static_cast<unsigned>(kSize - c.y() + dy)};
      const auto info = selector->GetPixelInformation(pos);
      if (!info.Valid || info.Prop != view.actor()) continue;
      const auto deformed = view.pick(scene.renderer(), pos[0] + 0.5, pos[1] + 0.5);
      const auto undeformed = flat.pick(scene.renderer(), pos[0] + 0.5, pos[1] + 0.5);
      ++total;
      agree_deformed += deformed && static_cast<vtkIdType>(deformed->triangle) == info.AttributeID;
      agree_undeformed += undeformed && static_cast<vtkIdType>(undeformed->triangle) == info.AttributeID;
    }
  selector->ClearBuffers();
  ASSERT_GT(total, 100);
  EXPECT_GE(agree_deformed, total * 9 / 10) << agree_deformed << " of " << total;
  EXPECT_LT(agree_undeformed, total / 2) << "selection looks undeformed";
}

TEST(SurfaceView, ClippingPlanesClipTheDeformedSurface) {
  DentScene dent(0.006);
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  // Keep z below 3 mm under the top: the undeformed top is cut away, the
  // dent's bottom (6 mm down) is not.
  const double top_z = dent.mesh->positions[dent.top].z();
  vtkNew<vtkPlane> plane;
  plane->SetOrigin(0, 0, top_z - 0.003);
  plane->SetNormal(0, 0, -1);
  view.actor()->GetMapper()->AddClippingPlane(plane);
  scene.look_at(view.bounds(), Vec3::UnitZ(), Vec3::UnitY());
  const auto c = test::to_pixel(scene.renderer(), dent.mesh->positions[dent.top], kSize);
  const int x = static_cast<int>(c.x()), y = kSize - 1 - static_cast<int>(c.y());
  scene.render_image();
  EXPECT_LT(drawn_point(scene, x, y).z(), top_z - 0.05) << "the undeformed top was not clipped";
  dent.settle();
  view.sync(*dent.surface);
  scene.render_image();
  EXPECT_NEAR(drawn_point(scene, x, y).z(), dent.surface->deformed_position(dent.top).z(), 2e-4);
}

TEST(SurfaceView, AFrameUploadsOnlyTheDirtyStreamRanges) {
  DentScene dent(0.006);
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);  // everything dirty at first
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3::UnitZ(), Vec3::UnitY());
  scene.render_image();
  EXPECT_EQ(view.stats().full_uploads, 1u);

  GlUploadCounter counter;
  dent.surface->set_contacts(std::span(&dent.contact, 1));
  for (int frame = 0; frame < 5; ++frame) {
    for (int s = 0; s < 16; ++s) dent.surface->step(1e-3);
    const auto ranges = dent.surface->take_dirty_ranges();
    const std::uint64_t changed = std::accumulate(ranges.begin(), ranges.end(), std::uint64_t{0},
                                                  [](std::uint64_t a, const IndexRange& r) { return a + r.end - r.begin; });
    ASSERT_GT(changed, 0u);
    ASSERT_LT(changed, dent.mesh->vertex_count() / 4);
    const UploadStats before = view.stats();
    counter.reset();
    view.update(dent.surface->stream(), ranges);
    scene.render_image();
    const UploadCounts c = counter.counts();
    EXPECT_EQ(c.texture_buffer_bytes, 16 * changed) << "frame " << frame;
    EXPECT_EQ(c.index_bytes, 0u) << "frame " << frame;
    EXPECT_EQ(c.vertex_bytes, 0u) << "frame " << frame;
    EXPECT_EQ(c.buffer_data_calls, 0u) << "frame " << frame;
    EXPECT_EQ(view.stats().bytes - before.bytes, 16 * changed);
    EXPECT_EQ(view.stats().ranges - before.ranges, ranges.size());
  }
  EXPECT_EQ(view.stats().full_uploads, 1u);
}

TEST(SurfaceView, VtksOwnPathReuploadsEverythingIncludingTheIndexBuffer) {
  // The comparison the partial path exists for (measured, not assumed).
  DentScene dent(0.006);
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh, UploadPath::VtkModified);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3::UnitZ(), Vec3::UnitY());
  scene.render_image();
  GlUploadCounter counter;
  dent.settle(0.02);
  view.sync(*dent.surface);
  scene.render_image();
  const UploadCounts c = counter.counts();
  EXPECT_GE(c.index_bytes, 12 * dent.mesh->triangle_count());
  EXPECT_GE(c.vertex_bytes, 16 * dent.mesh->vertex_count());
}

TEST(SurfaceView, DentSurvivesBufferRebuildsAndALostContext) {
  DentScene dent(0.006);
  dent.settle();
  OffscreenScene scene(kSize, kSize);
  SurfaceView view(dent.mesh);
  view.sync(*dent.surface);
  scene.add(view.actor());
  scene.look_at(view.bounds(), Vec3(0, -1, 1.2), Vec3::UnitZ());
  const Image first = scene.render_image();
  // A property change makes VTK rebuild its buffers; our stream stays.
  view.set_color(0.2, 0.9, 0.2);
  scene.render_image();
  view.set_color(0.80, 0.45, 0.40);
  EXPECT_EQ(test::max_difference(scene.render_image(), first), 0);
  // Released graphics resources: the next frame uploads the whole stream again.
  scene.window().window()->ReleaseGraphicsResources(scene.window().window());
  EXPECT_EQ(test::max_difference(scene.render_image(), first), 0);
  EXPECT_EQ(view.stats().full_uploads, 2u);
}

// Redrawing only the pixels a dent can touch (OffscreenScene::render with a
// region, SurfaceView::draw_only_near) gives the frame drawn whole, bit for
// bit; the region is worked out here from VTK's own world -> display
// conversion, not from the code under test. Drawing every triangle again
// afterwards gives the whole frame too (VTK's full index list is back).
TEST(SurfaceView, RedrawingOnlyWhatADentTouchesGivesTheWholeFrame) {
  DentScene dent(0.005);
  const Vec3 eye_dir(0.3, -0.5, 1.0);
  OffscreenScene whole_scene(kSize, kSize), part_scene(kSize, kSize);
  SurfaceView whole_view(dent.mesh), part_view(dent.mesh);
  std::array<double, 6> box{};
  for (auto [scene, view] : {std::pair{&whole_scene, &whole_view}, std::pair{&part_scene, &part_view}}) {
    view->update_all(dent.surface->stream());
    scene->add(view->actor());
    scene->look_at(view->bounds(), eye_dir, Vec3::UnitZ());
    box = view->bounds();
    for (int k = 0; k < 3; ++k) box[2 * k] -= 0.02, box[2 * k + 1] += 0.02;
    scene->hold_clipping_range(box);
  }
  const Image before = whole_scene.render_image();
  EXPECT_EQ(test::max_difference(part_scene.render_image(), before), 0);

  // Where VTK puts world points agrees with the projection the region uses.
  const PixelProjection proj = part_scene.projection();
  for (Index i = 0; i < dent.mesh->vertex_count(); i += 997) {
    double x = 0, y = 0;
    ASSERT_TRUE(proj.project(dent.mesh->positions[i], x, y));
    const auto px = test::to_pixel(part_scene.renderer(), dent.mesh->positions[i], kSize);
    EXPECT_NEAR(x, px.x(), 1e-6) << "vertex " << i;
    EXPECT_NEAR(y, kSize - px.y(), 1e-6) << "vertex " << i;
  }

  dent.settle();
  const std::vector<Vec3> after = core_positions(*dent.surface);
  // The region: every triangle with a displaced corner, before and after.
  double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
  const auto st = dent.surface->stream();
  for (const auto& t : dent.mesh->triangles) {
    bool moved = false;
    for (Index v : t)
      for (int k = 0; k < 4; ++k) moved = moved || st[4 * v + k] != 0.f;
    if (!moved) continue;
    for (Index v : t)
      for (const Vec3& p : {dent.mesh->positions[v], after[v]}) {
        const auto px = test::to_pixel(part_scene.renderer(), p, kSize);
        x0 = std::min(x0, px.x()), x1 = std::max(x1, px.x());
        y0 = std::min(y0, kSize - px.y()), y1 = std::max(y1, kSize - px.y());
      }
  }
  const PixelRect region{static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2,
                         static_cast<int>(std::floor(x1)) + 3, static_cast<int>(std::floor(y1)) + 3};
  ASSERT_FALSE(region.empty());
  ASSERT_LT((region.x1 - region.x0) * (region.y1 - region.y0), kSize * kSize / 4) << "the test needs a small region";

  whole_view.update_all(dent.surface->stream());
  part_view.update_all(dent.surface->stream());
  const Image whole = whole_scene.render_image();
  EXPECT_GT(test::compare(before, whole, std::vector<std::uint8_t>(kSize * kSize, 1)).changed_inside, 300)
      << "the dent is not visible";
  part_view.draw_only_near(proj, region);
  EXPECT_TRUE(part_scene.render(region));
  part_scene.window().finish();
  EXPECT_EQ(test::max_difference(part_scene.window().capture(), whole), 0) << "the partly redrawn frame differs";

  // Every triangle again: the whole frame once more.
  part_view.draw_all();
  EXPECT_EQ(test::max_difference(part_scene.render_image(), whole), 0) << "the full index list did not come back";
}

TEST(SurfaceView, UpdateRejectsRangesOutsideTheMesh) {
  auto mesh = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(500, 0.05));
  SurfaceView view(mesh);
  const std::size_t n = mesh->vertex_count();
  std::vector<float> stream(4 * n, 0.f);
  const IndexRange bad{0, static_cast<Index>(n + 1)};
  try {
    view.update(stream, std::span(&bad, 1));
    FAIL() << "no error";
  } catch (const std::out_of_range& e) {
    EXPECT_EQ(std::string(e.what()), "SurfaceView::update: range [0, " + std::to_string(n + 1) +
                                         ") is outside the mesh's " + std::to_string(n) + " vertices");
  }
  std::vector<float> short_stream(4 * n - 4, 0.f);
  const IndexRange ok{0, 1};
  try {
    view.update(short_stream, std::span(&ok, 1));
    FAIL() << "no error";
  } catch (const std::out_of_range& e) {
    EXPECT_EQ(std::string(e.what()), "SurfaceView::update: stream has " + std::to_string(4 * n - 4) +
                                         " floats, expected 4 x " + std::to_string(n) + " vertices");
  }
}

}  // namespace
}  // namespace palpa::render
