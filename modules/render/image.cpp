// PNG input/output through VTK's PNG reader and writer.

#include "render/image.h"

#include "render/offscreen.h"

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPNGWriter.h>
#include <vtkUnsignedCharArray.h>

#include <cstring>
#include <system_error>

namespace palpa::render {

void write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw RenderError(path.string() + ": cannot write PNG (image is empty or its size is inconsistent)");

  const auto folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  if (std::error_code ec; !std::filesystem::is_directory(folder, ec))
    throw RenderError(path.string() + ": cannot write PNG (the folder is missing or not writable)");

  // VTK images are bottom row first: flip while copying.
  vtkNew<vtkImageData> data;
  data->SetDimensions(image.width, image.height, 1);
  data->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* dst = static_cast<unsigned char*>(data->GetScalarPointer());
  for (int y = 0; y < image.height; ++y)
    std::memcpy(dst + static_cast<std::size_t>(image.height - 1 - y) * image.width * 3, image.at(0, y),
                static_cast<std::size_t>(image.width) * 3);

  // Write beside the target, then rename over it.
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(data);
  writer->SetFileName(tmp.string().c_str());
  writer->Write();
  std::error_code ec;
  if (writer->GetErrorCode() != 0 || !std::filesystem::exists(tmp, ec) ||
      std::filesystem::file_size(tmp, ec) == 0) {
    std::filesystem::remove(tmp, ec);
    throw RenderError(path.string() + ": cannot write PNG (the folder is missing or not writable)");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw RenderError(path.string() + ": cannot write PNG (" + ec.message() + ")");
  }
}

Image read_png(const std::filesystem::path& path) {
  vtkNew<vtkPNGReader> reader;
  if (!std::filesystem::is_regular_file(path) || !reader->CanReadFile(path.string().c_str()))
    throw RenderError(path.string() + ": cannot read PNG");
  reader->SetFileName(path.string().c_str());
  reader->Update();
  vtkImageData* data = reader->GetOutput();
  int dims[3];
  data->GetDimensions(dims);
  const int comps = data->GetNumberOfScalarComponents();
  if (dims[0] < 1 || dims[1] < 1 || data->GetScalarType() != VTK_UNSIGNED_CHAR || comps < 1 || comps > 4)
    throw RenderError(path.string() + ": cannot read PNG");
  Image img;
  img.width = dims[0];
  img.height = dims[1];
  img.rgb.resize(static_cast<std::size_t>(img.width) * img.height * 3);
  const auto* src = static_cast<const unsigned char*>(data->GetScalarPointer());
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const unsigned char* s = src + (static_cast<std::size_t>(img.height - 1 - y) * img.width + x) * comps;
      unsigned char* d = img.at(x, y);
      if (comps >= 3) {
        d[0] = s[0], d[1] = s[1], d[2] = s[2];
      } else {
        d[0] = d[1] = d[2] = s[0];
      }
    }
  }
  return img;
}

}  // namespace palpa::render
