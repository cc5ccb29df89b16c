// PNG files: what is written reads back the same; failures name the file.

#include "render/image.h"

#include "common/test_support.h"
#include "render/offscreen.h"

#include <fstream>

namespace palpa::render {
namespace {

TEST(Image, PngRoundTripKeepsEveryPixelAndTheRowOrder) {
  Image img;
  img.width = 7;
  img.height = 5;
  img.rgb.resize(7 * 5 * 3);
  for (std::size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = static_cast<std::uint8_t>((i * 37) % 256);
  const auto dir = palpa::test::temp_dir("image_roundtrip");
  write_png(img, dir / "a.png");
  const Image back = read_png(dir / "a.png");
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, img.rgb);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.png.tmp"));
}

TEST(Image, WritingIntoAMissingFolderNamesTheFile) {
  Image img;
  img.width = img.height = 2;
  img.rgb.assign(12, 0);
  const auto path = palpa::test::temp_dir("image_missing") / "no" / "such" / "x.png";
  try {
    write_png(img, path);
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ": cannot write PNG (the folder is missing or not writable)");
  }
}

TEST(Image, ReadingSomethingElseNamesTheFile) {
  const auto path = palpa::test::temp_dir("image_bad") / "x.png";
  { std::ofstream(path) << "not a png"; }
  try {
    read_png(path);
    FAIL() << "no error";
  } catch (const RenderError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ": cannot read PNG");
  }
}

}  // namespace
}  // namespace palpa::render
