// The OpenIGTLink stream decoder of the `igtl` device (see igtl_decoder.h).

#include "igtl_decoder.h"

#include <Eigen/Geometry>
#include <igtl_util.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace palpa::plugins::igtl {
namespace {

std::uint64_t be(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = v << 8 | p[k];
  return v;
}

float be_float(const std::uint8_t* p) {
  const auto u = static_cast<std::uint32_t>(be(p, 4));
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// A fixed-size name field: some allowed characters, then only NULs.
bool plausible_name(const std::uint8_t* p, std::size_t n, bool type) {
  std::size_t k = 0;
  for (; k < n && p[k] != 0; ++k) {
    const char c = static_cast<char>(p[k]);
    const bool ok = type ? (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+')
                         : (p[k] >= 0x20 && p[k] < 0x7f);
    if (!ok) return false;
  }
  if (type && k == 0) return false;
  for (; k < n; ++k)
    if (p[k] != 0) return false;
  return true;
}

std::string field(const std::uint8_t* p, std::size_t n) {
  std::size_t k = 0;
  while (k < n && p[k] != 0) ++k;
  return std::string(reinterpret_cast<const char*>(p), k);
}

std::uint64_t max_body(const std::string& type, int version) {
  const std::uint64_t content = type == "TRANSFORM" ? kMaxTransformBody
                                : type == "POSITION" ? kMaxPositionBody
                                                     : kMaxOtherBody;
  return content + (version == 2 ? kMaxMetadata : 0);
}

}  // namespace

Decoder::Decoder(DecoderOptions options) : options_(std::move(options)) {}

void Decoder::reset() {
  in_.clear();
  searching_ = false;
}

// Can a header start at `at`? Its type and device name must be names, its
// body no larger than its type allows. (An unknown version with a plausible
// header is `ok`: handle() refuses it by number and its body is skipped.)
Decoder::Header Decoder::check_header(std::size_t at, std::string* why) const {
  if (in_.size() - at < kHeaderSize) return Header::incomplete;
  const std::uint8_t* h = in_.data() + at;
  const auto version = static_cast<int>(be(h, 2));
  if (!plausible_name(h + 2, 12, true) || !plausible_name(h + 14, 20, false)) {
    if (why) *why = "refused a header whose type or device name is not a name";
    return Header::bad;
  }
  const std::string type = field(h + 2, 12);
  const std::uint64_t body = be(h + 42, 8);
  const std::uint64_t most = max_body(type, version == 2 ? 2 : 1);
  if (body > most) {
    if (why)
      *why = "refused a " + type + " message with a body of " + std::to_string(body) + " bytes (a " +
             (type == "TRANSFORM" || type == "POSITION" ? type : std::string("message")) + " of header version " +
             std::to_string(version) + " has at most " + std::to_string(most) + ")";
    return Header::bad;
  }
  return Header::ok;
}

void Decoder::refuse(const std::string& why) {
  ++bad_;
  problem_ = why;
}

// Drops bytes up to the next position where a header can start.
void Decoder::resynchronise() {
  std::size_t i = 0;
  while (true) {
    const Header h = check_header(i, nullptr);
    if (h == Header::bad) {
      ++i;
      continue;
    }
    in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(i));
    skipped_ += i;
    search_skipped_ += i;
    if (h == Header::ok) {
      searching_ = false;
      problem_ += "; resynchronised after skipping " + std::to_string(search_skipped_) + " bytes";
    }
    return;
  }
}

void Decoder::feed(const std::uint8_t* data, std::size_t size, std::vector<Pose>& poses) {
  in_.insert(in_.end(), data, data + size);
  while (true) {
    if (searching_) {
      resynchronise();
      if (searching_) return;  // no header yet: wait for more bytes
    }
    std::string why;
    const Header h = check_header(0, &why);
    if (h == Header::incomplete) return;
    if (h == Header::bad) {
      // Its size cannot be trusted: search for the next header.
      refuse(why);
      ++resyncs_;
      searching_ = true;
      search_skipped_ = 1;
      ++skipped_;
      in_.erase(in_.begin());
      continue;
    }
    const std::uint8_t* head = in_.data();
    const std::uint64_t body = be(head + 42, 8);  // <= max_body: fits in memory
    if (in_.size() < kHeaderSize + body) return;
    ++messages_;
    handle(field(head + 2, 12), field(head + 14, 20), head + kHeaderSize, body, be(head + 50, 8),
           static_cast<int>(be(head, 2)), poses);
    in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(kHeaderSize + body));
  }
}

// One complete message: a pose kept, or refused with the reason, or ignored.
void Decoder::handle(const std::string& type, const std::string& name, const std::uint8_t* body,
                     std::uint64_t size, std::uint64_t crc, int version, std::vector<Pose>& poses) {
  if (version != 1 && version != 2) {
    refuse("refused a " + type + " message of header version " + std::to_string(version) +
           " (this bridge reads versions 1 and 2)");
    return;
  }
  if (type != "TRANSFORM" && type != "POSITION") return;  // other types are ignored
  if (!options_.device_filter.empty() && name != options_.device_filter) return;
  const std::string what = "refused a " + type + " message";
  if (crc64(const_cast<unsigned char*>(body), size, 0) != crc) {
    refuse(what + ": its CRC does not match its body");
    return;
  }

  // The content: the whole body (version 1), or what the extended header and metadata leave (version 2).
  const std::uint8_t* content = body;
  std::uint64_t content_size = size;
  if (version == 2) {
    if (size < 12) {
      refuse(what + ": its body of " + std::to_string(size) + " bytes is shorter than an extended header");
      return;
    }
    const std::uint64_t ext = be(body, 2), meta_header = be(body + 2, 2), meta = be(body + 4, 4);
    if (ext < 12 || ext + meta_header + meta > size) {
      refuse(what + ": its extended header and metadata (" + std::to_string(ext + meta_header + meta) +
             " bytes) do not fit its body of " + std::to_string(size));
      return;
    }
    content = body + ext;
    content_size = size - ext - meta_header - meta;
  }

  Eigen::Vector3d p;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (type == "TRANSFORM") {
    if (content_size != kMaxTransformBody) {
      refuse(what + ": its content is " + std::to_string(content_size) + " bytes, not 48");
      return;
    }
    // Column-major rotation (R11 R21 R31 R12 ...), then the translation.
    Eigen::Matrix3d r;
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) r(i, j) = be_float(content + 4 * (3 * j + i));
    for (int i = 0; i < 3; ++i) p[i] = be_float(content + 36 + 4 * i);
    if (!r.allFinite() || !p.allFinite()) {
      refuse(what + ": it holds a number that is not finite");
      return;
    }
    const double error = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    const double det = r.determinant();
    if (!(error <= kRotationTolerance) || !(det > 0)) {
      refuse(what + ": its rotation is not orthonormal (|R^T R - I| = " + number(error) +
             ", det R = " + number(det) + ")");
      return;
    }
    q = Eigen::Quaterniond(r);
  } else {
    if (content_size != 12 && content_size != 24 && content_size != 28) {
      refuse(what + ": its content is " + std::to_string(content_size) + " bytes, not 12, 24 or 28");
      return;
    }
    for (int i = 0; i < 3; ++i) p[i] = be_float(content + 4 * i);
    double v[4] = {0, 0, 0, 1};  // ox, oy, oz, w
    for (std::size_t i = 0; 12 + 4 * i < content_size; ++i) v[i] = be_float(content + 12 + 4 * i);
    if (content_size == 24) v[3] = std::sqrt(std::max(0.0, 1.0 - (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])));
    q = Eigen::Quaterniond(v[3], v[0], v[1], v[2]);
    if (!p.allFinite() || !q.coeffs().allFinite()) {
      refuse(what + ": it holds a number that is not finite");
      return;
    }
    if (!(std::abs(q.norm() - 1.0) <= kRotationTolerance)) {
      refuse(what + ": its quaternion has norm " + number(q.norm()) + ", not 1");
      return;
    }
  }

  // Position in metres, inside the workspace.
  p *= options_.unit_scale;
  if (!(p.cwiseAbs().maxCoeff() <= options_.workspace)) {
    refuse(what + ": its position (" + number(p.x()) + ", " + number(p.y()) + ", " + number(p.z()) +
           ") m is outside the workspace (|x|, |y|, |z| <= " + number(options_.workspace) + " m)");
    return;
  }
  q.normalize();
  Pose pose;
  for (int i = 0; i < 3; ++i) pose.position[i] = p[i];
  pose.orientation[0] = q.w();
  pose.orientation[1] = q.x();
  pose.orientation[2] = q.y();
  pose.orientation[3] = q.z();
  poses.push_back(pose);
}

}  // namespace palpa::plugins::igtl
