// The headless job behind palpa-render: options and a full run.

#include "app/render/render_job.h"

#include "common/test_support.h"

#include <sstream>

namespace palpa::app {
namespace {

using render::GlBackend;
using render::Image;
using render::read_png;
using render::RenderError;

std::string parse_error(const std::vector<std::string>& args) {
  try {
    parse_render_args(args);
  } catch (const RenderError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RenderJob, OptionsParseAndBadOnesAreNamed) {
  bool help = false;
  const auto o = parse_render_args({"--probe", "0.01,0.02,0.03,0.004", "--size", "320x200", "--gl", "osmesa",
                                    "--shape", "volume", "--radius", "0.03", "--output", "x.png"},
                                   &help);
  EXPECT_FALSE(help);
  ASSERT_EQ(o.probes.size(), 1u);
  EXPECT_EQ(o.probes[0].point, Vec3(0.01, 0.02, 0.03));
  EXPECT_EQ(o.probes[0].depth, 0.004);
  EXPECT_EQ(o.width, 320);
  EXPECT_EQ(o.height, 200);
  EXPECT_EQ(o.backend, GlBackend::OSMesa);
  EXPECT_EQ(o.shape.kind, deform::ShapeKind::VolumeConserving);
  EXPECT_EQ(o.shape.radius, 0.03);
  EXPECT_EQ(parse_error({"--probe", "1,2"}),
            "--probe: expected X,Y,Z,DEPTH in metres with |X|, |Y|, |Z| <= 10 and DEPTH 0 .. 0.1, got '1,2'");
  EXPECT_EQ(parse_error({"--size", "12"}), "--size: expected WxH with 16..8192 pixels each, got '12'");
  EXPECT_EQ(parse_error({"--stiffness", "-3"}), "--stiffness: expected a number in 0.001 .. 1e+06 N/m, got '-3'");
  // Every number has a range and is refused outside it (issue 12): no hang, no clamp, no overflow.
  EXPECT_EQ(parse_error({"--settle", "1e9"}), "--settle: expected a number in 0.001 .. 60 s, got '1e9'");
  EXPECT_EQ(parse_error({"--settle", "1e300"}), "--settle: expected a number in 0.001 .. 60 s, got '1e300'");
  EXPECT_EQ(parse_error({"--settle", "0"}), "--settle: expected a number in 0.001 .. 60 s, got '0'");
  EXPECT_EQ(parse_error({"--mass", "nan"}), "--mass: expected a number in 1e-09 .. 10 kg, got 'nan'");
  EXPECT_EQ(parse_error({"--radius", "2"}), "--radius: expected a number in 0.0001 .. 0.5 m, got '2'");
  EXPECT_EQ(parse_error({"--damping", "1e5"}), "--damping: expected a number in 1e-06 .. 10000 N s/m, got '1e5'");
  EXPECT_EQ(parse_error({"--probe", "1e30,0,0,0.004"}),
            "--probe: expected X,Y,Z,DEPTH in metres with |X|, |Y|, |Z| <= 10 and DEPTH 0 .. 0.1, got '1e30,0,0,0.004'");
  EXPECT_EQ(parse_error({"--probe", "0,0,0,5"}),
            "--probe: expected X,Y,Z,DEPTH in metres with |X|, |Y|, |Z| <= 10 and DEPTH 0 .. 0.1, got '0,0,0,5'");
  EXPECT_EQ(parse_error({"--size", "99999999999x100"}), "--size: expected WxH with 16..8192 pixels each, got '99999999999x100'");
  EXPECT_EQ(parse_error({"--size", "320.5x200"}), "--size: expected WxH with 16..8192 pixels each, got '320.5x200'");
  EXPECT_EQ(parse_error({"--view", "0,0,0"}), "--view: expected a non-zero direction X,Y,Z, got '0,0,0'");
  {
    std::vector<std::string> nine;
    for (int k = 0; k < 9; ++k) nine.insert(nine.end(), {"--probe", "0,0,0,0.001"});
    EXPECT_EQ(parse_error(nine), "--probe: at most 8 probes, got 9");
  }
  // A tiny direction is a direction, not zero (its norm underflows).
  const auto tiny = parse_render_args({"--view", "1e-200,0,0"});
  ASSERT_TRUE(tiny.view_dir);
  EXPECT_EQ(*tiny.view_dir, Vec3(1, 0, 0));
  EXPECT_EQ(parse_error({"--gl", "dx"}), "unknown GL backend 'dx' (expected auto, osmesa or egl)");
  EXPECT_EQ(parse_error({"--mesh"}), "--mesh: needs a value");
  EXPECT_EQ(parse_error({"--frobnicate"}), "unknown option '--frobnicate' (see --help)");
  parse_render_args({"--help"}, &help);
  EXPECT_TRUE(help);
}

TEST(RenderJob, PressesTheDefaultOrganAndWritesAPicture) {
  RenderJobOptions o;
  o.output = palpa::test::temp_dir("render_job") / "organ.png";
  o.width = 240;
  o.height = 180;
  o.settle_time = 0.4;
  std::ostringstream log;
  const RenderJobResult r = run_render_job(o, log);
  ASSERT_EQ(r.probes.size(), 1u);
  EXPECT_TRUE(r.probes[0].in_contact);
  // A linear material pressed 6 mm: the force is of the order of k * depth
  // (the field pushes many vertices, so more than one vertex's k d).
  EXPECT_GT(r.probes[0].force.norm(), 200.0 * 0.006 * 0.5);
  EXPECT_NEAR(r.max_displacement, 0.006, 0.001);
  const Image img = read_png(o.output);
  EXPECT_EQ(img.width, 240);
  // The organ fills a good part of the picture.
  long organ = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) organ += img.grey(x, y) > 60;
  EXPECT_GT(organ, img.width * img.height / 8);
  EXPECT_NE(log.str().find("wrote"), std::string::npos);
}

}  // namespace
}  // namespace palpa::app
