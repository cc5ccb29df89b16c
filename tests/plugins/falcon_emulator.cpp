#include "falcon_emulator.h"

#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <ctime>

namespace palpa::test {

namespace fc = palpa::plugins::falcon;

namespace {

constexpr double kMass = 0.2;          // kg, grip and arms as seen at the end effector
constexpr double kHandStiffness = 200; // N/m, the user's hand
constexpr double kHandDamping = 8;     // N s/m
constexpr double kSubstep = 1e-4;      // s
constexpr std::uint8_t kFtdiStatus[2] = {0x31, 0x60};

double now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

template <class T>
void put(UMockdevIoctlData* d, std::size_t offset, T value) {
  umockdev_ioctl_data_update(d, offset, reinterpret_cast<guint8*>(&value), sizeof value);
}

usbdevfs_urb* urb_of(UMockdevIoctlData* d) { return reinterpret_cast<usbdevfs_urb*>(d->data); }

}  // namespace

FalconEmulator::FalconEmulator() : handler_(umockdev_ioctl_base_new()) {
  g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(on_ioctl), this);
}

FalconEmulator::~FalconEmulator() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto* q : {&pending_, &discarded_})
    for (Urb& u : *q) {
      g_object_unref(u.urb);
      if (u.buffer) g_object_unref(u.buffer);
    }
  g_object_unref(handler_);
}

void FalconEmulator::expect_firmware(std::vector<std::uint8_t> image) {
  std::lock_guard<std::mutex> lock(mutex_);
  expected_firmware_ = std::move(image);
  firmware_loaded_ = expected_firmware_.empty();
}

void FalconEmulator::corrupt_echo_at(std::size_t index) {
  std::lock_guard<std::mutex> lock(mutex_);
  corrupt_at_ = index;
}

void FalconEmulator::set_hand(const fc::Vec3& target) {
  std::lock_guard<std::mutex> lock(mutex_);
  advance(now());
  hand_ = target;
}

void FalconEmulator::set_buttons(std::uint8_t b) {
  std::lock_guard<std::mutex> lock(mutex_);
  buttons_ = b;
}

void FalconEmulator::unplug() {
  std::lock_guard<std::mutex> lock(mutex_);
  unplugged_ = true;
}

bool FalconEmulator::firmware_loaded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return firmware_loaded_;
}

fc::Vec3 FalconEmulator::position() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return p_;
}

std::uint8_t FalconEmulator::homed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return homed_;
}

std::uint64_t FalconEmulator::command_packets() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return packets_;
}

fc::Command FalconEmulator::last_command() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return command_;
}

int FalconEmulator::max_motor_before_homing() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return max_motor_unhomed_;
}

gboolean FalconEmulator::on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
  return static_cast<FalconEmulator*>(self)->handle(client);
}

// The FTDI vendor requests the plugin uses.
void FalconEmulator::control(std::uint8_t type, std::uint8_t request, std::uint16_t value) {
  if (type != fc::kFtdiRequestType) return;
  switch (request) {
    case fc::kFtdiBaudRate:
      baud_ = value;
      // Back to normal speed after an upload: the firmware runs if it arrived intact.
      if (value == fc::kBaudNormal && uploading_) {
        uploading_ = false;
        firmware_loaded_ = uploaded_ == expected_firmware_;
      }
      break;
    case fc::kFtdiLatency: latency_ms_ = value; break;
    case fc::kFtdiReset:
      if (value == fc::kFtdiPurgeRx) in_.clear();
      if (value == fc::kFtdiPurgeTx) out_stream_.clear();
      break;
    default: break;
  }
}

// Bytes from the host: loader handshake, upload with echo, or command packets.
void FalconEmulator::bulk_out(const std::uint8_t* data, std::size_t n) {
  if (baud_ == fc::kBaudLoaderCheck && !firmware_loaded_) {
    out_stream_.insert(out_stream_.end(), data, data + n);
    auto it = std::search(out_stream_.begin(), out_stream_.end(), fc::kLoaderQuery.begin(), fc::kLoaderQuery.end());
    if (it != out_stream_.end()) {
      in_.insert(in_.end(), fc::kLoaderReply.begin(), fc::kLoaderReply.end());
      out_stream_.clear();
    }
    return;
  }
  if (baud_ == fc::kBaudLoaderUpload && !firmware_loaded_) {
    for (std::size_t i = 0; i < n; ++i) {
      if (!uploading_) {
        if (data[i] == fc::kLoaderStart) {
          uploading_ = true;
          uploaded_.clear();
          in_.push_back(fc::kLoaderStart);
        }
        continue;
      }
      const std::uint8_t echo = uploaded_.size() == corrupt_at_ ? static_cast<std::uint8_t>(data[i] ^ 0xff) : data[i];
      uploaded_.push_back(data[i]);
      in_.push_back(echo);
    }
    return;
  }
  if (baud_ != fc::kBaudNormal || !firmware_loaded_) return;  // no firmware: silence
  // Frame command packets.
  out_stream_.insert(out_stream_.end(), data, data + n);
  std::size_t pos = 0;
  while (out_stream_.size() - pos >= fc::kPacketSize) {
    fc::Command c;
    if (out_stream_[pos] == '<' &&
        fc::decode_command(std::span<const std::uint8_t>(&out_stream_[pos], fc::kPacketSize), c) ==
            fc::PacketError::None) {
      command_packet(c);
      pos += fc::kPacketSize;
    } else {
      ++pos;
    }
  }
  out_stream_.erase(out_stream_.begin(), out_stream_.begin() + static_cast<std::ptrdiff_t>(pos));
}

// The firmware: integrate up to now with the old torques, take the new
// command, answer with the encoders.
void FalconEmulator::command_packet(const fc::Command& c) {
  advance(now());
  command_ = c;
  ++packets_;
  if (homed_ != 0x7)
    for (int i = 0; i < 3; ++i) max_motor_unhomed_ = std::max(max_motor_unhomed_, std::abs(int{c.motor[i]}));

  fc::Vec3 angles;
  kin_.inverse(p_, angles);
  fc::Status st;
  for (int i = 0; i < 3; ++i) {
    const int truth = fc::angle_to_encoder(angles[i]);
    // Homing: in homing mode an arm passing its index (encoder 0) is homed.
    if (!(homed_ & (1u << i)) && c.homing && have_true_ &&
        ((last_true_[i] <= 0 && truth >= 0) || (last_true_[i] >= 0 && truth <= 0))) {
      homed_ = static_cast<std::uint8_t>(homed_ | (1u << i));
    }
    last_true_[i] = truth;
    const int reported = truth + ((homed_ & (1u << i)) ? 0 : offset_[i]);
    st.encoder[i] = static_cast<std::int16_t>(std::clamp(reported, -32768, 32767));
  }
  have_true_ = true;
  st.homed = homed_;
  st.buttons = buttons_;
  const auto packet = fc::encode_status(st);
  in_.insert(in_.end(), packet.begin(), packet.end());
}

// The end effector between the hand spring and the motors. The motor force
// is F = A^T tau with A = d theta / d p from central differences of the
// inverse kinematics (virtual work), tau = -command / 10000 N m.
void FalconEmulator::advance(double t) {
  if (last_time_ == 0) {
    last_time_ = t;
    return;
  }
  double remaining = std::min(t - last_time_, 0.05);
  last_time_ = t;
  const fc::Vec3 tau(-command_.motor[0] / fc::kTorqueScale, -command_.motor[1] / fc::kTorqueScale,
                     -command_.motor[2] / fc::kTorqueScale);
  while (remaining > 0) {
    const double dt = std::min(kSubstep, remaining);
    remaining -= dt;
    fc::Mat3 A = fc::Mat3::Zero();
    const double h = 1e-6;
    bool ok = true;
    for (int j = 0; j < 3 && ok; ++j) {
      fc::Vec3 plus, minus;
      ok = kin_.inverse(p_ + h * fc::Vec3::Unit(j), plus) && kin_.inverse(p_ - h * fc::Vec3::Unit(j), minus);
      if (ok) A.col(j) = (plus - minus) / (2 * h);
    }
    const fc::Vec3 motor = ok ? fc::Vec3(A.transpose() * tau) : fc::Vec3::Zero();
    const fc::Vec3 force = motor + kHandStiffness * (hand_ - p_) - kHandDamping * v_;
    v_ += force / kMass * dt;
    const fc::Vec3 next = p_ + v_ * dt;
    fc::Vec3 probe;
    if (kin_.inverse(next, probe))
      p_ = next;
    else
      v_.setZero();  // a mechanical stop
  }
}

bool FalconEmulator::ready(const Urb& u, double t) const {
  const usbdevfs_urb* r = urb_of(u.urb);
  if (r->type != USBDEVFS_URB_TYPE_BULK || !(r->endpoint & 0x80)) return true;
  return !in_.empty() || t - u.submitted >= latency_ms_ * 1e-3;
}

// Two FTDI status bytes, then whatever data is waiting (62 bytes at most).
void FalconEmulator::complete_in(Urb& u) {
  const usbdevfs_urb* r = urb_of(u.urb);
  const std::size_t room = std::min<std::size_t>(static_cast<std::size_t>(r->buffer_length), fc::kUsbPacketSize);
  std::vector<std::uint8_t> data(kFtdiStatus, kFtdiStatus + 2);
  while (data.size() < room && !in_.empty()) {
    data.push_back(in_.front());
    in_.pop_front();
  }
  umockdev_ioctl_data_update(u.buffer, 0, data.data(), static_cast<gint>(data.size()));
  put(u.urb, offsetof(usbdevfs_urb, actual_length), static_cast<int>(data.size()));
  put(u.urb, offsetof(usbdevfs_urb, status), 0);
}

gboolean FalconEmulator::handle(UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  GError* error = nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  // Unplugged: like usbfs after a disconnect, the URBs in flight can still
  // be reaped (killed, status -ESHUTDOWN); everything else fails with ENODEV.
  if (unplugged_) {
    if ((request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY) &&
        (!pending_.empty() || !discarded_.empty())) {
      std::deque<Urb>& q = discarded_.empty() ? pending_ : discarded_;
      Urb u = q.front();
      q.pop_front();
      put(u.urb, offsetof(usbdevfs_urb, status), -ESHUTDOWN);
      put(u.urb, offsetof(usbdevfs_urb, actual_length), 0);
      UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(void*), &error);
      umockdev_ioctl_data_set_ptr(pointer, 0, u.urb);
      umockdev_ioctl_client_complete(client, 0, 0);
      g_object_unref(pointer);
      g_object_unref(u.urb);
      if (u.buffer) g_object_unref(u.buffer);
      return TRUE;
    }
    umockdev_ioctl_client_complete(client, -1, ENODEV);
    return TRUE;
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(std::uint32_t), &error);
      put<std::uint32_t>(d, 0, USBDEVFS_CAP_BULK_CONTINUATION | USBDEVFS_CAP_NO_PACKET_SIZE_LIM);
      g_object_unref(d);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_RELEASEINTERFACE:
    case USBDEVFS_SETINTERFACE:
    case USBDEVFS_SETCONFIGURATION:
    case USBDEVFS_CLEAR_HALT:
    case USBDEVFS_RESET:
    case USBDEVFS_RESETEP:
    case USBDEVFS_DISCONNECT_CLAIM:
    case USBDEVFS_IOCTL:
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    case USBDEVFS_GETDRIVER:
      umockdev_ioctl_client_complete(client, -1, ENODATA);  // no kernel driver bound
      return TRUE;

    case USBDEVFS_SUBMITURB: {
      // Keep the URB (and its buffer); OUT data and control requests act now.
      Urb u;
      u.urb = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), &error);
      usbdevfs_urb* r = urb_of(u.urb);
      if (r->buffer_length > 0)
        u.buffer = umockdev_ioctl_data_resolve(u.urb, offsetof(usbdevfs_urb, buffer),
                                               static_cast<gsize>(r->buffer_length), &error);
      u.submitted = now();
      if (r->type == USBDEVFS_URB_TYPE_CONTROL && u.buffer && r->buffer_length >= 8) {
        const std::uint8_t* s = u.buffer->data;
        control(s[0], s[1], static_cast<std::uint16_t>(s[2] | (s[3] << 8)));
        put(u.urb, offsetof(usbdevfs_urb, actual_length), 0);
        put(u.urb, offsetof(usbdevfs_urb, status), 0);
      } else if (r->type == USBDEVFS_URB_TYPE_BULK && !(r->endpoint & 0x80)) {
        if (u.buffer) bulk_out(u.buffer->data, static_cast<std::size_t>(r->buffer_length));
        put(u.urb, offsetof(usbdevfs_urb, actual_length), r->buffer_length);
        put(u.urb, offsetof(usbdevfs_urb, status), 0);
      }
      pending_.push_back(u);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }

    case USBDEVFS_DISCARDURB: {
      const gulong address = *reinterpret_cast<const gulong*>(arg->data);
      auto it = std::find_if(pending_.begin(), pending_.end(),
                             [&](const Urb& u) { return u.urb->client_addr == address; });
      if (it == pending_.end()) {
        umockdev_ioctl_client_complete(client, -1, EINVAL);
        return TRUE;
      }
      discarded_.push_back(*it);
      pending_.erase(it);
      umockdev_ioctl_client_complete(client, 0, 0);
      return TRUE;
    }

    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY: {
      // Discarded URBs first (status -ENOENT), then the first one ready.
      Urb u;
      bool found = false;
      if (!discarded_.empty()) {
        u = discarded_.front();
        discarded_.pop_front();
        put(u.urb, offsetof(usbdevfs_urb, status), -ENOENT);
        put(u.urb, offsetof(usbdevfs_urb, actual_length), 0);
        found = true;
      } else {
        const double t = now();
        for (auto it = pending_.begin(); it != pending_.end(); ++it)
          if (ready(*it, t)) {
            u = *it;
            pending_.erase(it);
            found = true;
            const usbdevfs_urb* r = urb_of(u.urb);
            if (r->type == USBDEVFS_URB_TYPE_BULK && (r->endpoint & 0x80)) complete_in(u);
            break;
          }
      }
      if (!found) {
        umockdev_ioctl_client_complete(client, -1, EAGAIN);
        return TRUE;
      }
      UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(void*), &error);
      umockdev_ioctl_data_set_ptr(pointer, 0, u.urb);
      umockdev_ioctl_client_complete(client, 0, 0);
      g_object_unref(pointer);
      g_object_unref(u.urb);
      if (u.buffer) g_object_unref(u.buffer);
      return TRUE;
    }
    default:
      umockdev_ioctl_client_complete(client, -1, ENOTTY);
      return TRUE;
  }
}

}  // namespace palpa::test
