// The `igtl` device: a network bridge speaking OpenIGTLink (protocol version
// 2, as used by 3D Slicer and PLUS), so that a device driven by a vendor SDK
// on another computer can be used. It receives the tool pose as TRANSFORM or
// POSITION messages and sends the computed force back as a SENSOR message of
// three values with unit newton. Input older than stale_after is reported
// stale (the loop then sends zero force) and the force sent back is zero
// while the input is stale or the loop's command has expired.
//
// Sockets are our own (a server binds to 127.0.0.1 unless told otherwise, and
// says so with a warning when it listens on all addresses, 0.0.0.0); incoming
// messages are decoded by our own checked decoder (igtl_decoder.h: 64-bit body
// sizes against a per-type maximum, refused header versions named, resynchro-
// nisation after a bad header, orthonormal rotations, positions inside the
// workspace); OpenIGTLink's library packs the SENSOR messages sent back.
//
// Options:
//   mode=client        client: connect to host:port; server: listen on host:port
//   host=127.0.0.1     peer address (client) or bind address (server; 0.0.0.0 = all, with a warning)
//   port=18944         TCP port (0 with mode=server: any free port, see the message)
//   device=            accept poses only from this OpenIGTLink device name (empty: any)
//   unit=mm            length unit of incoming positions: mm (OpenIGTLink convention) or m
//   stale_after=0.1    s
//   force_name=PalpaForce  device name of the SENSOR messages sent back
//   send_rate=1000     most SENSOR messages per second, Hz
//   max_force=10       N, the force limit declared to the host
//   workspace=1        m, 0.001 .. 100: poses must satisfy |x|, |y|, |z| <= workspace (the spec's box)
//   peer_timeout=2     s, 0.05 .. 3600 (server): a peer that completed no message for this long
//                      is replaced by the next one that connects (one idle peer cannot lock out the tracker)

#include "core/triple_buffer.h"
#include "devices/plugin_support.h"
#include "igtl_decoder.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <igtlSensorMessage.h>
#include <igtlUnit.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

namespace {

using namespace palpa::devices::plugin;
namespace igtl_decoder = palpa::plugins::igtl;

// The options: the form's fields and the parser's defaults and ranges.
constexpr PalpaDeviceOption kOptions[] = {
    option_choice("mode", "client|server", "client",
                  "client: connect to host:port; server: listen on host:port for the tracker to connect."),
    option_string("host", "127.0.0.1",
                  "IPv4 address of the peer (client) or to bind (server; 0.0.0.0 listens on all, with a warning)."),
    option_int("port", "", 0, 65535, "18944", "TCP port (0 with mode=server: any free port, named in the message)."),
    option_string("device", "", "Accept poses only from this OpenIGTLink device name (empty: any)."),
    option_choice("unit", "mm|m", "mm", "Length unit of incoming positions (OpenIGTLink's convention is mm)."),
    option_double("stale_after", "s", 1e-3, 60.0, "0.1", "Input older than this is stale: the force sent is zero."),
    option_string("force_name", "PalpaForce", "Device name of the SENSOR messages sent back (1 to 20 characters)."),
    option_double("send_rate", "Hz", 1.0, 100000.0, "1000", "The most SENSOR messages sent per second."),
    option_double("max_force", "N", 0.01, 1e4, "10", "The force limit declared to the host."),
    option_double("workspace", "m", 1e-3, 100.0, "1", "Poses must satisfy |x|, |y|, |z| <= workspace."),
    option_double("peer_timeout", "s", 0.05, 3600.0, "2",
                  "Server: a peer that completed no message for this long is replaced by the next one."),
};

class IgtlDevice final : public DeviceImpl {
 public:
  explicit IgtlDevice(const Options& o) {
    server_ = o.choice("mode") == "server";
    host_ = o.text("host");
    in_addr probe{};
    if (inet_pton(AF_INET, host_.c_str(), &probe) != 1)
      throw PluginError("igtl: option host='" + host_ + "' is not an IPv4 address");
    port_ = static_cast<int>(o.integer("port"));
    // A client needs a port to connect to: the declared range, less 0.
    if (!server_ && port_ == 0) (void)o.get_int("port", 18944, 1, 65535);
    device_filter_ = o.text("device");
    unit_scale_ = o.choice("unit") == "mm" ? 1e-3 : 1.0;
    stale_after_ = o.number("stale_after");
    force_name_ = o.text("force_name");
    if (force_name_.empty() || force_name_.size() > 20)
      throw PluginError("igtl: option force_name must have 1 to 20 characters");
    send_period_ = 1.0 / o.number("send_rate");
    max_force_ = o.number("max_force");
    workspace_ = o.number("workspace");
    peer_timeout_ = o.number("peer_timeout");
    if (server_ && host_ == "0.0.0.0")
      warning_ = " (warning: listening on all addresses, so any computer that reaches this one can send poses)";
  }
  ~IgtlDevice() override { stop(); }

  PalpaDeviceSpec spec() const override {
    PalpaDeviceSpec s{};
    set_spec_name(s, "OpenIGTLink bridge");
    s.position_dof = 6;
    s.force_dof = 3;
    for (int i = 0; i < 3; ++i) {
      s.workspace_min[i] = -workspace_;
      s.workspace_max[i] = workspace_;
    }
    s.max_force = max_force_;
    s.max_stiffness = 1e4;
    s.max_damping = 100;
    s.nominal_rate = 1.0 / send_period_;
    s.button_count = 0;
    return s;
  }

  // A server binds now (errors are immediate); a client connects in the background.
  void start() override {
    if (running_.load()) return;
    if (server_) {
      listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (listen_fd_ < 0) throw PluginError(std::string("igtl: cannot create a socket: ") + std::strerror(errno));
      int one = 1;
      setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
      sockaddr_in a = address(host_, port_);
      if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || listen(listen_fd_, 1) != 0) {
        const std::string why = std::strerror(errno);
        ::close(listen_fd_);
        listen_fd_ = -1;
        throw PluginError("igtl: cannot listen on " + host_ + ":" + std::to_string(port_) + ": " + why);
      }
      socklen_t len = sizeof a;
      getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
      bound_port_ = ntohs(a.sin_port);
    }
    PalpaForceCommand zero{};
    commands_.write(zero);
    samples_.write(empty_sample());
    set_state(server_ ? "igtl: listening on " + host_ + ":" + std::to_string(bound_port_)
                      : "igtl: connecting to " + host_ + ":" + std::to_string(port_));
    stop_.store(false);
    running_.store(true);
    thread_ = std::thread([this] { io_main(); });
  }

  void stop() override {
    if (!running_.load()) return;
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    if (listen_fd_ >= 0) ::close(listen_fd_);
    listen_fd_ = -1;
    running_.store(false);
  }

  // Real-time: the latest pose; stale once older than stale_after.
  void read(PalpaDeviceSample& s) noexcept override {
    if (!running_.load(std::memory_order_acquire)) {
      s = empty_sample();
      return;
    }
    s = samples_.latest();
    if ((s.status & PALPA_STATUS_VALID) && !(monotonic_now() - s.time <= stale_after_)) s.status |= PALPA_STATUS_STALE;
  }

  int write(const PalpaForceCommand& c) noexcept override {
    commands_.write(c);
    return PALPA_DEVICE_OK;
  }

  std::string message() const override {
    std::lock_guard<std::mutex> lock(message_mutex_);
    return running_.load() ? state_ : "igtl: stopped";
  }

 private:
  static sockaddr_in address(const std::string& host, int port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    inet_pton(AF_INET, host.c_str(), &a.sin_addr);
    return a;
  }

  void set_state(const std::string& s) {
    std::lock_guard<std::mutex> lock(message_mutex_);
    state_ = s + warning_;
  }

  // Client: one connection attempt with a short timeout; -1 on failure.
  int try_connect() {
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) return -1;
    sockaddr_in a = address(host_, port_);
    if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 && errno != EINPROGRESS) {
      ::close(fd);
      return -1;
    }
    pollfd p{fd, POLLOUT, 0};
    int err = 0;
    socklen_t len = sizeof err;
    if (poll(&p, 1, 200) != 1 || getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0) {
      ::close(fd);
      return -1;
    }
    return fd;
  }

  // Server: wait briefly for a peer; -1 when none came.
  int try_accept() {
    pollfd p{listen_fd_, POLLIN, 0};
    if (poll(&p, 1, 100) != 1) return -1;
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    return fd;
  }

  bool send_all(int fd, const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    while (size > 0) {
      const ssize_t n = ::send(fd, p, size, MSG_NOSIGNAL);
      if (n > 0) {
        p += n;
        size -= static_cast<std::size_t>(n);
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        pollfd q{fd, POLLOUT, 0};
        if (poll(&q, 1, 100) == 1) continue;
      }
      return false;
    }
    return true;
  }

  // A SENSOR message with the force in newtons.
  bool send_force(int fd, const double f[3]) {
    igtl::SensorMessage::Pointer msg = igtl::SensorMessage::New();
    msg->SetDeviceName(force_name_.c_str());
    msg->SetLength(3);
    igtl::Unit::Pointer unit = igtl::Unit::New();
    unit->Init();
    unit->SetPrefix(igtl::Unit::SI_PREFIX_NONE);
    unit->Append(igtl::Unit::SI_DERIVED_NEWTON, 1);
    msg->SetUnit(unit.GetPointer());
    for (unsigned i = 0; i < 3; ++i) msg->SetValue(i, f[i]);
    msg->Pack();
    return send_all(fd, msg->GetPackPointer(), static_cast<std::size_t>(msg->GetPackSize()));
  }

  // Publishes a pose (m, unit quaternion w x y z).
  void publish(const igtl_decoder::Pose& pose) {
    PalpaDeviceSample s = empty_sample();
    for (int i = 0; i < 3; ++i) s.position[i] = pose.position[i];
    for (int i = 0; i < 4; ++i) s.orientation[i] = pose.orientation[i];
    s.time = monotonic_now();
    s.sequence = ++sequence_;
    s.status = PALPA_STATUS_VALID;
    samples_.write(s);
    ++poses_;
    last_pose_time_ = s.time;
  }

  // A new decoder for a new peer (the counts of bad messages carry on).
  igtl_decoder::DecoderOptions decoder_options() const {
    igtl_decoder::DecoderOptions d;
    d.unit_scale = unit_scale_;
    d.device_filter = device_filter_;
    d.workspace = workspace_;
    return d;
  }

  // Server: a peer waiting to connect while the current one has been idle
  // (no complete message) for peer_timeout replaces it.
  int replace_idle_peer(int fd, double now, double last_activity) {
    if (!server_ || now - last_activity < peer_timeout_) return fd;
    pollfd p{listen_fd_, POLLIN, 0};
    if (poll(&p, 1, 0) != 1) return fd;
    const int next = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (next < 0) return fd;
    ::close(fd);
    ++replaced_peers_;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g", now - last_activity);
    set_state("igtl: replaced a peer idle for " + std::string(buf) + " s (peer_timeout " + number(peer_timeout_) +
              " s) by a new one on " + host_ + ":" + std::to_string(bound_port_));
    return next;
  }

  static std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
  }

  // Connection management, message decoding and force sending.
  void io_main() {
    int fd = -1;
    igtl_decoder::Decoder decoder(decoder_options());
    std::vector<igtl_decoder::Pose> poses;
    double last_send = 0, last_activity = 0;
    std::uint64_t reported_bad = 0, seen_messages = 0;
    while (!stop_.load(std::memory_order_relaxed)) {
      if (fd < 0) {
        fd = server_ ? try_accept() : try_connect();
        if (fd < 0) {
          if (!server_) std::this_thread::sleep_for(std::chrono::milliseconds(100));
          continue;
        }
        int one = 1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        decoder.reset();
        last_activity = monotonic_now();
        set_state("igtl: connected to a peer on " + host_ + ":" + std::to_string(server_ ? bound_port_ : port_));
      }

      // Receive what is there (wait at most 1 ms) and decode every complete message.
      pollfd p{fd, POLLIN, 0};
      bool lost = false;
      if (poll(&p, 1, 1) == 1) {
        std::uint8_t buf[4096];
        const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
        if (n > 0) {
          poses.clear();
          decoder.feed(buf, static_cast<std::size_t>(n), poses);
          for (const auto& pose : poses) publish(pose);
        } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
          lost = true;
        }
      }
      if (decoder.messages() != seen_messages) {
        seen_messages = decoder.messages();
        last_activity = monotonic_now();
      }
      if (decoder.bad_messages() != reported_bad) {
        reported_bad = decoder.bad_messages();
        set_state("igtl: " + decoder.last_problem() + " (" + std::to_string(reported_bad) + " bad so far)");
      }

      // Send the force back, zero when the input is stale or the command expired.
      const double now = monotonic_now();
      if (!lost && now - last_send >= send_period_) {
        const PalpaForceCommand c = commands_.latest();
        double f[3] = {0, 0, 0};
        const bool fresh = now <= c.time + c.expires_after && poses_ > 0 && now - last_pose_time_ <= stale_after_;
        if (fresh)
          for (int i = 0; i < 3; ++i) f[i] = std::isfinite(c.force[i]) ? c.force[i] : 0.0;
        if (!send_force(fd, f)) lost = true;
        last_send = now;
      }

      if (lost) {
        ::close(fd);
        fd = -1;
        set_state(server_ ? "igtl: peer disconnected; listening on " + host_ + ":" + std::to_string(bound_port_)
                          : "igtl: peer disconnected; reconnecting to " + host_ + ":" + std::to_string(port_));
        continue;
      }
      const int next = replace_idle_peer(fd, now, last_activity);
      if (next != fd) {
        fd = next;
        int one = 1;
        setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        decoder.reset();
        last_activity = now;
      }
    }
    if (fd >= 0) {
      const double zero[3] = {0, 0, 0};
      send_force(fd, zero);
      ::close(fd);
    }
  }

  bool server_ = false;
  std::string host_;
  int port_ = 18944, bound_port_ = 0;
  std::string device_filter_, force_name_;
  double unit_scale_ = 1e-3, stale_after_ = 0.1, send_period_ = 1e-3, max_force_ = 10;
  double workspace_ = 1.0, peer_timeout_ = 2.0;
  std::string warning_;  // said with every state (listening on all addresses)
  int listen_fd_ = -1;
  std::thread thread_;
  std::atomic<bool> stop_{false}, running_{false};
  palpa::TripleBuffer<PalpaForceCommand> commands_;
  palpa::TripleBuffer<PalpaDeviceSample> samples_;
  std::uint64_t sequence_ = 0, poses_ = 0, replaced_peers_ = 0;  // I/O thread only
  double last_pose_time_ = 0;                                    // I/O thread only
  mutable std::mutex message_mutex_;
  std::string state_;
};

std::unique_ptr<DeviceImpl> make_igtl(const Options& o) { return std::make_unique<IgtlDevice>(o); }

}  // namespace

PALPA_EXPORT_DEVICE_PLUGIN("igtl", make_igtl, kOptions)
