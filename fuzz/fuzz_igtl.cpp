// libFuzzer target: the igtl device's OpenIGTLink stream decoder. The first
// byte sets the chunk size the stream is delivered in (as a network would);
// the decoder must never crash, never buffer more than a message can hold,
// and only accept finite poses inside the workspace with unit quaternions.

#include "igtl_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::size_t chunk = 1 + data[0] % 64;
  using namespace palpa::plugins::igtl;
  DecoderOptions options;
  options.unit_scale = (data[0] & 0x80) ? 1.0 : 1e-3;
  Decoder decoder(options);
  std::vector<Pose> poses;
  for (std::size_t at = 1; at < size; at += chunk) {
    decoder.feed(data + at, std::min(chunk, size - at), poses);
    if (decoder.buffered() > kHeaderSize + kMaxOtherBody + kMaxMetadata + chunk) std::abort();
  }
  for (const Pose& p : poses) {
    double q = 0;
    for (double x : p.position)
      if (!std::isfinite(x) || std::abs(x) > options.workspace) std::abort();
    for (double c : p.orientation) q += c * c;
    if (!(std::abs(q - 1.0) < 1e-9)) std::abort();
  }
  return 0;
}
